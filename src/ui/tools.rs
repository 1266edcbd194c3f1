//! The tool table in the console (`docs/probing.md`, "Tool length"): the
//! same file as `jogterm probe tool` and `jogterm run` keep
//! (`offsets::tools`), read once at start. The tool in the spindle and its
//! offset shift every Z of a G-code job the console imports, as `run`'s
//! import does, and show in the position panel's title; a tool measured at
//! a tool change and a Z touch-off (`P`) change it, and the change is
//! written on the work offsets' writer thread (the [`SaveJob`]s returned
//! here). The editor reads it through its context; this file imports no
//! other of `ui`'s.

use std::path::PathBuf;

use crate::gcode::waits::ToolOffset;
use crate::offsets::store::SaveJob;
use crate::offsets::tools::{self, ToolTable};

#[derive(Debug, Clone, Default, PartialEq)]
pub struct ToolsState {
    pub table: ToolTable,
    /// Where the table is kept; `None`: no state directory, this session
    /// only.
    pub path: Option<PathBuf>,
    /// The file could not be read: why. Nothing is measured into it or
    /// written over it while this stands.
    pub broken: Option<String>,
}

impl ToolsState {
    /// What the session starts with: `read` is the file at `path` as
    /// `offsets::tools::load` read it.
    pub fn start(path: Option<PathBuf>, read: Option<Result<ToolTable, String>>) -> ToolsState {
        match read {
            Some(Ok(table)) => ToolsState {
                table,
                path,
                broken: None,
            },
            Some(Err(why)) => ToolsState {
                table: ToolTable::default(),
                path,
                broken: Some(why),
            },
            None => ToolsState {
                path,
                ..ToolsState::default()
            },
        }
    }

    /// The tool in the spindle and its offset: what an import shifts every
    /// Z by.
    pub fn active(&self) -> Option<ToolOffset> {
        let (tool, offset_mm) = self.table.active_offset()?;
        Some(ToolOffset { tool, offset_mm })
    }

    /// `tool` is the tool in the spindle with its offset (or both are
    /// none): what a job imported with it needs no check again for.
    pub fn is_active(&self, tool: Option<&ToolOffset>) -> bool {
        self.table.active_tool() == tool.map(|t| (t.tool.as_str(), t.offset_mm))
    }

    /// Why the table cannot take a measure, if it cannot.
    pub fn refused(&self) -> Option<String> {
        self.broken
            .as_ref()
            .map(|why| format!("the tool table cannot be read ({why}): fix or remove it first"))
    }

    /// `tool` touched the sensor at machine Z `z` (units): the write of
    /// the table.
    pub fn measured(&mut self, tool: &str, z: f64) -> Option<SaveJob> {
        self.table.measured(tool, z);
        self.save()
    }

    /// A Z touch-off set work Z with the tool in the spindle: the next tool
    /// measured is the reference.
    pub fn touched_off(&mut self) -> Option<SaveJob> {
        // Nothing to reset: nothing to write.
        self.table.reference.as_ref()?;
        self.table.touched_off();
        self.save()
    }

    fn save(&self) -> Option<SaveJob> {
        if self.broken.is_some() {
            return None;
        }
        let path = self.path.as_ref()?;
        tools::save_job(path, &self.table).ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_measure_is_saved_beside_the_offsets_and_a_broken_file_is_left_alone() {
        let path = PathBuf::from("/state/tools/default@sim.json");
        let mut tools = ToolsState::start(Some(path.clone()), Some(Ok(ToolTable::default())));
        let save = tools.measured("T1", 30.0);
        assert_eq!(tools.table.offset("T1"), Some(0.0));
        let Some(job) = save else { panic!("no write") };
        assert_eq!(job.path, path);
        assert!(job.text.contains("\"T1\""), "{}", job.text);
        tools.measured("T2", 31.0);
        assert_eq!(tools.table.offset("T2"), Some(1.0));
        assert_eq!(tools.active().map(|t| t.offset_mm), Some(1.0));
        assert!(tools.is_active(tools.active().as_ref()));
        assert!(!tools.is_active(None));
        assert!(tools.touched_off().is_some());
        assert_eq!(tools.active(), None);
        // Nothing to reset: nothing written.
        assert!(tools.touched_off().is_none());

        let mut broken = ToolsState::start(Some(path), Some(Err("bad json".into())));
        assert!(broken.refused().is_some_and(|w| w.contains("bad json")));
        assert!(broken.measured("T1", 30.0).is_none());
    }
}
