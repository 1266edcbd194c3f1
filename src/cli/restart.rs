//! What `jogterm import FILE --from-line N` says: the confirmation of a
//! restart (`docs/gcode.md`, "Restart from a line") as text or JSON, and
//! why a line cannot be restarted.

use std::io::Write;
use std::path::PathBuf;

use serde_json::json;

use super::import::{fits, round3, summary_json};
use crate::config::profile::Profile;
use crate::gcode::toolpath::Point;
use crate::gcode::{Diagnostic, Import, Origin, Restart, RestartError, Spindle, render};

/// The refusal at `FILE:LINE`, as the import's errors are said.
pub fn refused(name: &str, line: u32, e: &RestartError, err: &mut dyn Write) {
    let diagnostics = match e {
        RestartError::Convert(errors) => errors.clone(),
        other => vec![Diagnostic::error(
            Origin {
                line: line.max(1),
                col: 1,
            },
            other.to_string(),
        )],
    };
    for d in &diagnostics {
        let _ = writeln!(err, "{}", render(name, d));
    }
    let _ = writeln!(
        err,
        "jogterm: {name}: no restart from line {line}; nothing written"
    );
}

/// A machine point in the file's work coordinates, mm.
fn work_mm(r: &Restart, p: Point) -> [f64; 3] {
    [p.x - r.zero.x, p.y - r.zero.y, p.z - r.zero.z]
}

/// The command number (1-based) of the line's own first command.
fn cut_command(r: &Restart) -> usize {
    r.program.lines[..r.cut]
        .iter()
        .filter(|l| !l.command.is_empty())
        .count()
        + 1
}

pub fn text(
    name: &str,
    profile: &Profile,
    i: &Import,
    r: &Restart,
    written: Option<&PathBuf>,
    run: bool,
) -> String {
    let mut out = format!(
        "{name}: restart from line {} for profile \"{}\"\n",
        r.line, profile.name
    );
    out.push_str(&format!(
        "  skipped lines 1-{}; left to run lines {}-{} ({} lines)\n",
        r.skipped_lines, r.line, i.toolpath.lines, r.remaining_lines
    ));
    for note in &r.notes {
        out.push_str(&format!("  note: {note}\n"));
    }
    out.push_str(&format!("  modal state applied: {}\n", r.modal.text()));
    let [x, y, z] = r.work(r.start);
    let (p, unit) = (r.places(), if r.places() == 4 { "in" } else { "mm" });
    out.push_str(&format!(
        "  line {}'s start (work {}): X {x:.p$} Y {y:.p$} Z {z:.p$} {unit}\n",
        r.line, r.modal.system
    ));
    out.push_str("  entry, in this order:\n");
    for (k, step) in r.entry_text(run).iter().enumerate() {
        out.push_str(&format!("    {}. {step}\n", k + 1));
    }
    out.push_str(&format!(
        "  then line {} on, from command {}: {} program of {} commands, {}\n",
        r.line,
        cut_command(r),
        i.target.name(),
        r.program.commands,
        fits(&r.program, r.estimated_s, profile, i.target)
    ));
    if let Some(path) = written.filter(|p| p.as_os_str() != "-") {
        out.push_str(&format!("  written to {}\n", path.display()));
    }
    out
}

/// The whole job's summary (as `--json` without `--from-line`) and the
/// restart under `restart`.
pub fn json(i: &Import, r: &Restart, profile: &Profile) -> serde_json::Value {
    let m = &r.modal;
    let mut coolant = Vec::new();
    if m.mist {
        coolant.push("M7");
    }
    if m.flood {
        coolant.push("M8");
    }
    let [x, y, z] = work_mm(r, r.start);
    let mut summary = summary_json(i, profile);
    summary["restart"] = json!({
        "requested_line": r.requested,
        "line": r.line,
        "skipped_lines": r.skipped_lines,
        "remaining_lines": r.remaining_lines,
        "modal": {
            "text": m.text(),
            "units": m.units.map(|u| match u {
                crate::gcode::Units::Mm => "G21",
                crate::gcode::Units::Inch => "G20",
            }),
            "plane": m.plane_code(),
            "distance": if m.absolute { "G90" } else { "G91" },
            "work_offset": m.system.to_string(),
            "feed_mm_min": m.feed.map(round3),
            "spindle": match m.spindle {
                Spindle::Off => "M5",
                Spindle::Clockwise => "M3",
                Spindle::CounterClockwise => "M4",
            },
            "spindle_rpm": m.speed,
            "coolant": coolant,
            "tool": m.tool,
        },
        "start_mm": [round3(x), round3(y), round3(z)],
        "safe_z_mm": round3(r.safe_z - r.zero.z),
        "entry": r.entry_text(false),
        "notes": r.notes,
        "output_lines": r.program.commands,
        "first_command": cut_command(r),
        "fits_memory": r.program.fits(),
    });
    summary
}
