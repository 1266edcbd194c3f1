//! `jogterm import FILE`: G-code from CAM, read, checked against the
//! machine profile (soft limits over the whole toolpath, arcs included,
//! through the work offset in force) and converted into the controller's
//! own program (`docs/gcode.md`).
//!
//! stdout: the summary (or one JSON object with `--json`); with `-o` the
//! program goes to that file, `-o -` prints it instead of the summary.
//! stderr: `FILE:LINE:COL: error|warning: message`. Exit 0 converted, 1
//! errors in the file (nothing written), 2 bad usage.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{SystemTime, UNIX_EPOCH};

use clap::{Args, ValueEnum};
use serde_json::json;

use super::out::closed_is_ok;
use super::{GlobalArgs, profile};
use crate::config::ConfigDirs;
use crate::config::profile::Profile;
use crate::gcode::heightmap::HeightMap;
use crate::gcode::output::Header;
use crate::gcode::ways::{Costs, Ways};
use crate::gcode::{HeightMapFile, Import, MapApplied, Target, import_with_tool, render, restart};
use crate::offsets::store::{OffsetsFile, profile_key};
use crate::offsets::{Identity, WorkOffsets};
use crate::program::Language;

pub const LONG_ABOUT: &str = "\
Import G-code from CAM (Fusion 360, FreeCAD, Estlcam, LinuxCNC-style files) for a machine
profile: read it, check the whole toolpath against the machine (every axis against its soft
limits, arcs' bulges included, in machine coordinates through the work offset in force or
the one the file selects) and convert it into the controller's own program: an isel CNC
program (circles as the controller's circle interpolation) or an EMCU job (arcs as chords).

The work offsets are the console's (`O`, `s`; saved per profile and port). The summary says
what the file holds (moves, arcs, extents in the file's own coordinates, path length,
estimated time), how many commands the program has and whether it fits the controller's
memory. Every problem is reported as FILE:LINE:COL on stderr; with an error nothing is
written. EMP drives are refused: they run independently and have no interpolated path.";

pub const AFTER_LONG_HELP: &str = "\
Exit status: 0 converted (warnings allowed), 1 errors in the file or the profile's [gcode]
table (nothing written), 2 bad usage or an unreadable file.

Examples:
  jogterm import part.nc                          summary for the default (isel) machine
  jogterm import part.nc --profile mymill -o part.isel   write the isel program
  jogterm import part.nc --to emcu -o -           print the EMCU job
  jogterm import part.nc --json                   the summary as one JSON object
  jogterm import part.nc --work-zero 'X50 Y50 Z60'   G54's zero at machine X50 Y50 Z60
  jogterm import part.nc --height-map map.json    cut following a probed surface: every Z
                                                  counts from the surface (docs/gcode.md)
  jogterm import part.nc --from-line 120 -o part.isel   restart from line 120: retract,
                                                  above its start, spindle and coolant, descend";

/// Which program to make.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum To {
    Isel,
    Emcu,
}

#[derive(Debug, Clone, Args)]
pub struct ImportArgs {
    /// The G-code file (.nc .ngc .gcode .tap .gc, or any name)
    #[arg(value_name = "FILE")]
    pub file: PathBuf,
    /// The controller program to make [default: the profile's family]
    #[arg(long, value_enum)]
    pub to: Option<To>,
    /// Write the program to OUT (`-`: to stdout instead of the summary)
    #[arg(short = 'o', long = "output", value_name = "OUT")]
    pub output: Option<PathBuf>,
    /// Print the summary as one JSON object
    #[arg(long)]
    pub json: bool,
    /// The active work offset's zero for this import, in machine units (`X50 Y50 Z60`),
    /// instead of the console's stored one; axes not named keep theirs
    #[arg(long, value_name = "POS")]
    pub work_zero: Option<String>,
    /// Follow a probed surface: shift every Z by the height map's surface under it (a map
    /// `jogterm probe grid` wrote, for this profile and work offset)
    #[arg(long, value_name = "MAP")]
    pub height_map: Option<PathBuf>,
    /// Restart the job from G-code line N (after a broken tool or a power cut): the
    /// confirmation says the modal state applied and the entry moves; -o writes the
    /// restart program
    #[arg(long, value_name = "N")]
    pub from_line: Option<u32>,
}

/// `X50 Y50 Z60` into the active system's zero.
pub(super) fn apply_work_zero(
    text: &str,
    profile: &Profile,
    offsets: &mut WorkOffsets,
) -> Result<(), String> {
    for word in text.split_whitespace() {
        let mut chars = word.chars();
        let letter = chars.next().unwrap_or(' ').to_ascii_uppercase();
        let axis = crate::axis::Axis::from_letter(letter)
            .ok_or_else(|| format!("--work-zero: `{word}` is no axis and value (X50 Y50 Z60)"))?;
        let value: f64 = chars
            .as_str()
            .parse()
            .map_err(|_| format!("--work-zero: `{word}` is no axis and value (X50 Y50 Z60)"))?;
        let p = profile
            .axis(axis)
            .ok_or_else(|| format!("--work-zero: this machine has no {axis} axis"))?;
        let active = offsets.active();
        offsets.set(active, axis, p.to_steps(value));
    }
    Ok(())
}

const ERRORS: u8 = 1;
const USAGE: u8 = 2;

pub fn run(global: &GlobalArgs, args: &ImportArgs) -> anyhow::Result<ExitCode> {
    let stdout = std::io::stdout();
    let stderr = std::io::stderr();
    run_to(
        global,
        args,
        &ConfigDirs::from_env(),
        &mut stdout.lock(),
        &mut stderr.lock(),
    )
}

/// Why a program converted from G-code (its `jogterm-gcode` header) may
/// not run with the work offsets in force now: made for another profile,
/// or for a work zero that has moved since. `None` for a program without
/// the header, or one that still fits.
pub fn stale_offset(global: &GlobalArgs, profile: &Profile, program: &str) -> Option<String> {
    let header = Header::of(program)?;
    if header.profile != profile.name {
        return Some(format!(
            "converted from {} for profile \"{}\", not for \"{}\": import the G-code again for this machine",
            header.file, header.profile, profile.name
        ));
    }
    let (offsets, _) = offsets(global, &ConfigDirs::from_env(), profile);
    let system = crate::offsets::System::ALL
        .into_iter()
        .find(|s| s.to_string() == header.system)?;
    let now = |axis: crate::axis::Axis| {
        profile
            .axis(axis)
            .map_or(0.0, |p| p.to_units(offsets.zero(system, axis)))
    };
    let then = header.zero;
    let moved = [
        (crate::axis::Axis::X, then.x),
        (crate::axis::Axis::Y, then.y),
        (crate::axis::Axis::Z, then.z),
    ]
    .into_iter()
    .filter(|(axis, was)| {
        // Half a step is what the header's four decimals can say.
        let step = profile.axis(*axis).map_or(0.0, |p| 0.5 / p.steps_per_unit);
        (now(*axis) - was).abs() > step.max(1e-4)
    })
    .map(|(axis, was)| format!("{axis} {was:.3} mm then, {:.3} mm now", now(axis)))
    .collect::<Vec<_>>();
    (!moved.is_empty()).then(|| {
        format!(
            "converted from {} for work offset {} with its zero where it no longer is ({}): import the G-code again, or set the zero back",
            header.file,
            header.system,
            moved.join(", ")
        )
    })
}

/// The work offsets the console would apply for this profile and port.
fn offsets(
    global: &GlobalArgs,
    dirs: &ConfigDirs,
    profile: &Profile,
) -> (WorkOffsets, Option<String>) {
    let Ok((_, sources)) = profile::resolve_with_sources(global, dirs) else {
        return (WorkOffsets::default(), None);
    };
    let key = profile_key(&sources);
    match OffsetsFile::from_env(Identity::of(&key, profile)) {
        Some(file) => {
            let startup = file.load();
            (startup.offsets, startup.note)
        }
        None => (WorkOffsets::default(), None),
    }
}

pub fn run_to(
    global: &GlobalArgs,
    args: &ImportArgs,
    dirs: &ConfigDirs,
    out: &mut dyn Write,
    err: &mut dyn Write,
) -> anyhow::Result<ExitCode> {
    let profile = match profile::resolve(global, dirs) {
        Ok(p) => p,
        Err(e) => {
            let _ = writeln!(err, "jogterm import: {e:#}");
            return Ok(ExitCode::from(USAGE));
        }
    };
    let target = match args.to {
        Some(To::Isel) => Target::Isel,
        Some(To::Emcu) => Target::Emcu,
        None => match Target::of(profile.connection.protocol) {
            Ok(t) => t,
            Err(why) => {
                let _ = writeln!(err, "jogterm import: {why}");
                return Ok(ExitCode::from(USAGE));
            }
        },
    };
    let name = args.file.display().to_string();
    let (imported, text, offsets) = match read_and_import(
        global,
        dirs,
        &profile,
        &args.file,
        target,
        Placement {
            work_zero: args.work_zero.as_deref(),
            height_map: args.height_map.as_deref(),
        },
        err,
    ) {
        Ok(i) => i,
        Err(code) => return Ok(ExitCode::from(code)),
    };
    let header_name = crate::gcode::import::header_name(&args.file);
    for w in &imported.warnings {
        let _ = writeln!(err, "{}", render(&name, w));
    }
    let restarted = match args.from_line {
        Some(line) => match restart(&text, &header_name, &profile, &offsets, &imported, line) {
            Ok(r) => Some(r),
            Err(e) => {
                super::restart::refused(&name, line, &e, err);
                return Ok(ExitCode::from(ERRORS));
            }
        },
        None => None,
    };
    let program = restarted.as_ref().map_or(&imported.program, |r| &r.program);
    let program_text = program.text(&header_name);
    let mut to_stdout = false;
    if let Some(path) = &args.output {
        if path.as_os_str() == "-" {
            to_stdout = true;
        } else if let Err(e) = crate::program::store::save(path, &program_text, None) {
            let _ = writeln!(err, "jogterm import: cannot write {}: {e}", path.display());
            return Ok(ExitCode::from(USAGE));
        }
    }
    let report = if let Some(r) = &restarted {
        let confirmation =
            super::restart::text(&name, &profile, &imported, r, args.output.as_ref(), false);
        if to_stdout {
            // stdout is the program: the operator still reads what it does.
            let _ = err.write_all(confirmation.as_bytes());
            program_text
        } else if args.json {
            format!("{}\n", super::restart::json(&imported, r, &profile))
        } else {
            confirmation
        }
    } else if to_stdout {
        program_text
    } else if args.json {
        format!("{}\n", summary_json(&imported, &profile))
    } else {
        summary_text(&name, &profile, &imported, args.output.as_ref())
    };
    closed_is_ok(out.write_all(report.as_bytes()).and_then(|()| out.flush()))?;
    Ok(ExitCode::SUCCESS)
}

/// Reads and imports a G-code file for `profile` with the work offsets the
/// console would apply (or `placement`'s work zero), onto `placement`'s
/// height map when it names one. Every diagnostic goes to `err`
/// as `FILE:LINE:COL`; `Err` is the exit status (1 errors in the file, 2 an
/// unreadable file or a bad `work_zero`).
pub fn convert(
    global: &GlobalArgs,
    dirs: &ConfigDirs,
    profile: &Profile,
    path: &std::path::Path,
    target: Target,
    placement: Placement<'_>,
    err: &mut dyn Write,
) -> Result<Import, u8> {
    read_and_import(global, dirs, profile, path, target, placement, err).map(|(i, _, _)| i)
}

/// A height map file read and checked (`--height-map`): every problem by
/// the file and its field (`map.json: points[12].x: expected 20 …`).
pub(super) fn read_height_map(path: &std::path::Path) -> Result<HeightMapFile, String> {
    let name = path.display().to_string();
    let bytes = read_bounded(path, crate::gcode::MAX_FILE_BYTES)
        .map_err(|e| format!("cannot read height map {name}: {e}"))?;
    let text = String::from_utf8(bytes)
        .map_err(|_| format!("height map {name}: not UTF-8 text: a JSON file was expected"))?;
    let mut json = serde_json::Deserializer::from_str(&text);
    let map: HeightMap = serde_path_to_error::deserialize(&mut json).map_err(|e| {
        let field = e.path().to_string();
        let inner = e.into_inner();
        if field == "." {
            format!("height map {name}: {inner}")
        } else {
            format!("height map {name}: {field}: {inner}")
        }
    })?;
    let surface = map.validate().map_err(|errors| {
        errors
            .iter()
            .map(|e| format!("height map {name}: {e}"))
            .collect::<Vec<_>>()
            .join("\n")
    })?;
    Ok(HeightMapFile { name, surface })
}

/// Seconds since 1970, now.
fn unix_now() -> i64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_secs()).unwrap_or(i64::MAX))
}

/// Where a G-code job goes on the machine, beyond the profile: the work
/// zero given for this import (`--work-zero`) and the surface it follows
/// (`--height-map`).
#[derive(Debug, Clone, Copy, Default)]
pub struct Placement<'a> {
    pub work_zero: Option<&'a str>,
    pub height_map: Option<&'a std::path::Path>,
}

/// [`convert`], with the text and the work offsets it was imported with
/// (a restart interprets the text again up to its line).
pub(super) fn read_and_import(
    global: &GlobalArgs,
    dirs: &ConfigDirs,
    profile: &Profile,
    path: &std::path::Path,
    target: Target,
    placement: Placement<'_>,
    err: &mut dyn Write,
) -> Result<(Import, String, WorkOffsets), u8> {
    let Placement {
        work_zero,
        height_map,
    } = placement;
    let name = path.display().to_string();
    let height_map = match height_map.map(read_height_map).transpose() {
        Ok(map) => map,
        Err(why) => {
            let _ = writeln!(err, "jogterm: {why}");
            return Err(USAGE);
        }
    };
    let bytes = match read_bounded(path, crate::gcode::MAX_FILE_BYTES) {
        Ok(b) => b,
        Err(e) => {
            let _ = writeln!(err, "jogterm: cannot read {name}: {e}");
            return Err(USAGE);
        }
    };
    let text = String::from_utf8_lossy(&bytes).into_owned();
    let (mut offsets, note) = offsets(global, dirs, profile);
    match work_zero {
        Some(zero) => {
            if let Err(why) = apply_work_zero(zero, profile, &mut offsets) {
                let _ = writeln!(err, "jogterm: {why}");
                return Err(USAGE);
            }
        }
        None => {
            if let Some(note) = note {
                let _ = writeln!(err, "jogterm: {note}");
            }
        }
    }
    let tool = super::probe::tool::active_offset(global, profile);
    match import_with_tool(
        &text,
        &crate::gcode::import::header_name(path),
        profile,
        &offsets,
        target,
        height_map.as_ref(),
        tool.as_ref(),
    ) {
        Ok(i) => Ok((i, text, offsets)),
        Err(errors) => {
            for e in &errors {
                let _ = writeln!(err, "{}", render(&name, e));
            }
            let _ = writeln!(
                err,
                "jogterm: {name}: {} error{}; nothing written or sent",
                errors.len(),
                if errors.len() == 1 { "" } else { "s" }
            );
            Err(ERRORS)
        }
    }
}

/// The bytes of `path`, at most `max` of them: a longer input (a runaway
/// file, `/dev/zero`) is refused after `max + 1` bytes instead of read
/// until the memory runs out.
pub(in crate::cli) fn read_bounded(path: &std::path::Path, max: u64) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    let mut bytes = Vec::new();
    std::fs::File::open(path)?
        .take(max + 1)
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("more than {max} bytes: too large to be read"),
        ));
    }
    Ok(bytes)
}

/// An axis' extents as JSON: `[min, max]`, or null when the file never
/// moves it.
fn range(e: &crate::gcode::check::Extents, axis: usize) -> serde_json::Value {
    e.range(axis).map_or(serde_json::Value::Null, |(min, max)| {
        json!([round3(min), round3(max)])
    })
}

pub(super) fn round3(v: f64) -> f64 {
    (v * 1000.0).round() / 1000.0
}

pub fn summary_json(i: &Import, profile: &Profile) -> serde_json::Value {
    let ways = Ways::of_import(i, None, profile);
    let e = &i.summary.extents;
    let extents = if e.is_empty() {
        serde_json::Value::Null
    } else {
        json!({ "x": range(e, 0), "y": range(e, 1), "z": range(e, 2) })
    };
    json!({
        "lines": i.toolpath.lines,
        "extents_mm": extents,
        "length_mm": round3(i.summary.length_mm),
        "moves": i.summary.moves,
        "arcs": i.summary.arcs,
        "estimated_s": round3(ways.chosen_s()),
        "estimated_by_way": by_way_json(&ways),
        "estimated_way": ways.chosen.to_string(),
        "feeds_s": round3(i.summary.estimated_s),
        "output": i.target.name(),
        "output_lines": i.program.commands,
        "memory": i.program.capacity,
        "fits_memory": i.program.fits(),
        "work_offset": i.summary.system.to_string(),
        "height_map": i.height_map.as_ref().map(height_map_json),
        "tool_offset": i.tool.as_ref().map(|t| json!({ "tool": t.tool, "offset_mm": round3(t.offset_mm) })),
        "waits": i.plan.waits.iter().map(|w| json!({
            "line": w.origin.line,
            "col": w.origin.col,
            "kind": crate::gcode::waits::kind_name(w),
            "tool": w.tool_name(),
            "what": w.what(),
        })).collect::<Vec<_>>(),
        "warnings": i.warnings.iter().map(|w| json!({
            "line": w.origin.line,
            "col": w.origin.col,
            "message": w.message,
        })).collect::<Vec<_>>(),
    })
}

/// Each way's estimate by the controller's model (`null` where the way
/// cannot run the job), what the tool stands in a stream, and what waits
/// for the operator.
pub(super) fn by_way_json(ways: &Ways) -> serde_json::Value {
    let s = &ways.stream;
    json!({
        "stored": ways.stored.as_ref().map(|e| round3(e.total_s)),
        "parts": ways.chunked.as_ref().ok().filter(|_| ways.stored.is_none()).map(|e| round3(e.total_s)),
        "stream": round3(s.total_s),
        "stream_standing_s": round3(s.at_part_s + s.retracted_s),
        "not_timed": ways.timing.listed,
    })
}

/// The summary's lines of the estimate: by the model, each way, what the
/// tool stands in a stream, what is not timed.
pub(super) fn estimate_text(ways: &Ways) -> String {
    let mut out = String::new();
    let mut each = Vec::new();
    if let Some(e) = &ways.stored {
        each.push(format!("stored {}", duration(e.total_s)));
    }
    if let (None, Ok(e)) = (&ways.stored, &ways.chunked) {
        each.push(format!("in {} parts {}", e.parts, duration(e.total_s)));
    }
    let s = &ways.stream;
    each.push(format!(
        "stream {} (the tool stands {} between commands)",
        duration(s.total_s),
        duration(s.at_part_s + s.retracted_s)
    ));
    out.push_str(&format!(
        "  estimated {} {} by the controller's ramps and the wire: {}\n",
        duration(ways.chosen_s()),
        ways.chosen,
        each.join(", ")
    ));
    for why in &ways.timing.listed {
        out.push_str(&format!("  not timed, waits for the operator: {why}\n"));
    }
    out
}

/// A height map's part of the summary: which file, its correction's range,
/// its age and points, and what it did to the job.
fn height_map_json(m: &MapApplied) -> serde_json::Value {
    let a = &m.applied;
    json!({
        "file": m.file,
        "correction_mm": { "min": round3(a.correction_min), "max": round3(a.correction_max) },
        "age_s": a.age_s(unix_now()),
        "points": a.points,
        "z_zero_moved_mm": round3(a.z_zero_moved),
        "rapids_raised_mm": round3(a.rapids_raised),
        "arcs_as_segments": a.arcs_as_segments,
        "feed_moves": a.feed_moves,
        "feed_segments": a.feed_segments,
    })
}

/// The summary's lines of the tool offset and of the waits (tool changes,
/// pauses), each with its line.
pub(super) fn waits_text(i: &Import) -> String {
    let mut out = String::new();
    if i.tool.is_some() || i.plan.waits.iter().any(|w| w.is_tool_change()) {
        out.push_str(&format!(
            "  {}\n",
            crate::gcode::waits::tool_text(i.tool.as_ref())
        ));
    }
    let lines = crate::gcode::waits::waits_text(&i.plan);
    if !lines.is_empty() {
        out.push_str(&format!(
            "  tool changes and pauses: {} (each waits for the operator)\n",
            lines.len()
        ));
        for line in lines {
            out.push_str(&format!("    {line}\n"));
        }
    }
    out
}

/// The summary's line of a height map.
pub(super) fn height_map_text(m: &MapApplied) -> String {
    m.describe(unix_now())
}

fn summary_text(name: &str, profile: &Profile, i: &Import, written: Option<&PathBuf>) -> String {
    let s = &i.summary;
    let e = &s.extents;
    let mut out = String::new();
    out.push_str(&format!(
        "{name}: {} lines read for profile \"{}\"\n",
        i.toolpath.lines, profile.name
    ));
    out.push_str(&format!(
        "  moves {}, arcs {}, path {:.1} mm, {} at the feeds alone (no ramps)\n",
        s.moves,
        s.arcs,
        s.length_mm,
        duration(s.estimated_s)
    ));
    out.push_str(&estimate_text(&Ways::of_import(i, None, profile)));
    if !e.is_empty() {
        let axes: Vec<String> = ["X", "Y", "Z"]
            .iter()
            .enumerate()
            .filter_map(|(i, name)| {
                e.range(i)
                    .map(|(min, max)| format!("{name} {min:.3} .. {max:.3}"))
            })
            .collect();
        out.push_str(&format!(
            "  extents (work {}): {} mm\n",
            s.system,
            axes.join("  ")
        ));
    }
    out.push_str(&format!(
        "  work offset {}: zero at machine X {:.3} Y {:.3} Z {:.3} mm; soft limits: all inside\n",
        s.system, s.zero.x, s.zero.y, s.zero.z
    ));
    if let Some(m) = &i.height_map {
        out.push_str(&height_map_text(m));
    }
    out.push_str(&waits_text(i));
    out.push_str(&format!(
        "  {} program: {} commands, {}\n",
        i.target.name(),
        i.program.commands,
        fits(&i.program, i.summary.estimated_s, profile, i.target)
    ));
    out.push_str(&format!("  warnings: {}\n", i.warnings.len()));
    if let Some(path) = written.filter(|p| p.as_os_str() != "-") {
        out.push_str(&format!("  written to {}\n", path.display()));
    }
    out
}

/// Whether a converted program fits the controller's memory, and what to
/// do when it does not.
///
/// The advice comes from the ways `jogterm run` lists (`gcode::ways`), for
/// `profile`'s line and controller and the program's motion time
/// `motion_s`: it names parts only where the job can be cut.
pub(super) fn fits(
    program: &crate::gcode::output::Program,
    motion_s: f64,
    profile: &Profile,
    target: Target,
) -> String {
    if program.fits() {
        return "fits the controller's memory".to_owned();
    }
    let language = match target {
        Target::Isel => Language::Isel,
        Target::Emcu => Language::Emcu,
    };
    let ways = Ways::of(program, motion_s, &Costs::of(profile, language));
    format!(
        "does NOT fit the controller's memory ({} commands): {}",
        program.capacity,
        ways.advice()
    )
}

fn duration(seconds: f64) -> String {
    let total = seconds.round() as u64;
    if total >= 3600 {
        format!(
            "{}:{:02}:{:02} h",
            total / 3600,
            total / 60 % 60,
            total % 60
        )
    } else {
        format!("{}:{:02} min", total / 60, total % 60)
    }
}
