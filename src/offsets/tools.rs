//! Tool-length offsets (`docs/probing.md`, "Tool length"): the tools
//! measured on the fixed sensor and which one is the reference, kept in the
//! state directory beside the work offsets of the same profile and port
//! (`tools/<profile>@<port>.json`). `jogterm probe tool`, `jogterm run` and
//! the console read and write the same file.

use std::path::{Path, PathBuf};

use super::store::{OffsetsFile, SaveJob};

/// The tools measured on the fixed sensor (`jogterm probe tool`), kept in
/// the state directory per profile and port: the machine Z at which each
/// touched the sensor, and which one is the reference. A longer tool
/// touches higher; its offset is the difference to the reference tool.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ToolTable {
    /// The reference tool: the one measured right after a Z touch-off, or
    /// the first measured. `None`: the next tool measured becomes it.
    pub reference: Option<String>,
    /// Per tool, the machine Z (units) where it touched the sensor.
    pub touched: std::collections::BTreeMap<String, f64>,
    /// The tool in the spindle: the one measured last. Its offset shifts
    /// every Z of a job (`docs/probing.md`, "Tool length").
    #[serde(default)]
    pub active: Option<String>,
}

impl ToolTable {
    /// `tool` touched the sensor at machine Z `z`: kept (the reference
    /// when there is none), and its offset against the reference.
    pub fn measured(&mut self, tool: &str, z: f64) -> f64 {
        self.touched.insert(tool.to_owned(), z);
        self.active = Some(tool.to_owned());
        if self.reference.is_none() {
            self.reference = Some(tool.to_owned());
        }
        self.offset(tool).unwrap_or(0.0)
    }

    /// How much higher `tool` touches than the reference, units.
    pub fn offset(&self, tool: &str) -> Option<f64> {
        let reference = self.reference.as_deref()?;
        Some(self.touched.get(tool)? - self.touched.get(reference)?)
    }

    /// A Z touch-off sets the work Z with the tool in the spindle: the next
    /// tool measured is the reference, and until then the tool in the
    /// spindle has no offset (work Z is its own).
    pub fn touched_off(&mut self) {
        self.reference = None;
    }

    /// The tool in the spindle and its offset against the reference, when
    /// both are measured.
    pub fn active_offset(&self) -> Option<(String, f64)> {
        self.active_tool()
            .map(|(tool, offset)| (tool.to_owned(), offset))
    }

    /// The same, borrowed: what a screen drawn every frame reads.
    pub fn active_tool(&self) -> Option<(&str, f64)> {
        let tool = self.active.as_deref()?;
        Some((tool, self.offset(tool)?))
    }
}

/// Where the tool table of the session whose work offsets live in
/// `offsets` is kept: beside them, `tools/<profile>@<port>.json`.
pub fn table_path(offsets: &OffsetsFile) -> Option<PathBuf> {
    let name = offsets.path.file_stem()?.to_owned();
    let state = offsets.path.parent()?.parent()?;
    Some(state.join("tools").join(name).with_extension("json"))
}

/// The table as saved; a missing one is empty, a broken one an error.
pub fn load(path: &Path) -> Result<ToolTable, String> {
    match std::fs::read_to_string(path) {
        Ok(text) => serde_json::from_str(&text)
            .map_err(|e| format!("{}: not a tool table: {e}", path.display())),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(ToolTable::default()),
        Err(e) => Err(format!("{}: {e}", path.display())),
    }
}

/// The write of `table` to `path`, for the work offsets' writer thread
/// (the console) or [`save`] (the command line): atomic, the directory
/// made.
pub fn save_job(path: &Path, table: &ToolTable) -> Result<SaveJob, String> {
    let text = serde_json::to_string_pretty(table).map_err(|e| e.to_string())?;
    Ok(SaveJob {
        what: "the tool table",
        path: path.to_owned(),
        text,
        put_aside: false,
    })
}

/// Write `table` to `path` now (blocking).
pub fn save(path: &Path, table: &ToolTable) -> Result<(), String> {
    super::store::save(&save_job(path, table)?).map(drop)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tool_is_measured_against_the_reference_tool() {
        let mut tools = ToolTable::default();
        assert_eq!(tools.measured("T1", 30.0), 0.0);
        assert_eq!(tools.reference.as_deref(), Some("T1"));
        // One millimetre longer: it touches one millimetre higher.
        assert_eq!(tools.measured("T2", 31.0), 1.0);
        assert_eq!(tools.offset("T1"), Some(0.0));
        assert_eq!(tools.active_offset(), Some(("T2".into(), 1.0)));
        tools.touched_off();
        assert_eq!(tools.active_offset(), None);
        assert_eq!(tools.measured("T2", 31.0), 0.0);
        assert_eq!(tools.offset("T1"), Some(-1.0));
    }

    #[test]
    fn a_saved_table_loads_back_and_a_missing_one_is_empty() {
        let dir = tempfile::tempdir().expect("dir");
        let path = dir.path().join("tools").join("default@sim.json");
        assert_eq!(load(&path), Ok(ToolTable::default()));
        let mut table = ToolTable::default();
        table.measured("T1", 30.0);
        table.measured("T2", 31.25);
        save(&path, &table).expect("saved");
        assert_eq!(load(&path), Ok(table));
        std::fs::write(&path, "{ not json").expect("write");
        assert!(load(&path).is_err_and(|e| e.contains("not a tool table")));
    }
}
