//! `jogterm run` of a G-code job with tool changes and pauses (`M6`, `M0`,
//! `M1`; `docs/gcode.md`, "Tool changes"): host-driven. The job is cut at
//! its waits (`jogterm_gcode::toolchange::Sequence` says what comes next);
//! each piece is converted when its turn comes, with the Z shift the tool
//! in the spindle needs, and stored (in parts where it does not fit) or
//! streamed as the job's way says. Between two pieces the tool stands where
//! the piece left it (a tool change: retracted at the change position, the
//! spindle off) and jogterm waits for the operator: Enter on a terminal, a
//! line on standard input without one. With a tool sensor the new tool is
//! measured there and every later Z shifts by its length against the
//! reference tool (the tool table of `jogterm probe tool`, saved).

use std::io::IsTerminal;
use std::path::PathBuf;

use serde_json::json;
use tokio::sync::mpsc;

use super::keys::{Key, Keys};
use super::{RunArgs, streamed};
use crate::axis::Axis;
use crate::cli::out;
use crate::cli::probe::operator::Operator;
use crate::cli::probe::tool;
use crate::cli::session::{EXIT_USAGE, Session};
use crate::cli::upload::{self, Imported, Prepared, Remedy, Status};
use crate::config::Profile;
use crate::device::api::{Event, PerAxis, Request};
use crate::gcode::toolchange::{Sequence, Step, Wait};
use crate::gcode::ways::Way;
use crate::gcode::{Point, Target};
use crate::offsets::tools::ToolTable;
use crate::probing;
use crate::program::{Language, LintConfig};

/// What a job with waits needs at run time.
pub(super) struct Waited {
    pub(super) imported: Imported,
    pub(super) profile: Profile,
    pub(super) language: Language,
    pub(super) config: LintConfig,
    /// The tool sensor's point (`probe.tool_sensor`), machine units.
    pub(super) sensor: Option<PerAxis<f64>>,
    /// Where the tool table is kept, and what it holds (empty without a
    /// state directory: then only this run knows what was measured).
    pub(super) table: (Option<PathBuf>, ToolTable),
}

impl Waited {
    /// `None` for a job without waits, or a restart (whose program keeps
    /// the start-key waits of the controller: `docs/gcode.md`).
    pub(super) fn of(
        imported: Imported,
        profile: &Profile,
        language: Language,
        config: &LintConfig,
        global: &crate::cli::GlobalArgs,
    ) -> Result<Option<Waited>, (u8, String)> {
        if imported.restart.is_some() || imported.import.plan.waits.is_empty() {
            return Ok(None);
        }
        let sensor = match profile.probe.tool_sensor_point() {
            Some(Ok(p)) => Some(p),
            Some(Err(why)) => {
                return Err((EXIT_USAGE, format!("jogterm run: probe.tool_sensor: {why}")));
            }
            None => None,
        };
        let table = match tool::table_of(global, profile) {
            Some((path, Ok(t))) => (Some(path), t),
            Some((_, Err(why))) => return Err((EXIT_USAGE, format!("jogterm run: {why}"))),
            None => (None, ToolTable::default()),
        };
        Ok(Some(Waited {
            imported,
            profile: profile.clone(),
            language,
            config: config.clone(),
            sensor,
            table,
        }))
    }

    /// Piece `index` converted with the tool's `shifts` in Z.
    fn convert(
        &self,
        index: usize,
        shifts: (f64, f64),
    ) -> Result<crate::gcode::output::Program, Vec<crate::gcode::toolpath::Diagnostic>> {
        let imported = &self.imported;
        let target = match self.language {
            Language::Isel => Target::Isel,
            Language::Emcu => Target::Emcu,
        };
        let header = crate::gcode::output::Header {
            file: imported.header.clone(),
            profile: self.profile.name.clone(),
            system: imported.import.summary.system.to_string(),
            zero: imported.import.summary.zero,
        };
        crate::gcode::waits::convert_piece(
            &imported.import.plan,
            &imported.import.toolpath,
            index,
            shifts,
            &self.profile,
            target,
            &header,
        )
    }

    /// Each piece's seconds by the model on `way` (stored where it fits,
    /// else in parts), converted as the tool in the spindle has it (a
    /// measured tool shifts Z, not the time); none where a piece does not
    /// convert, which its turn then says.
    fn model_s(&self, way: Way) -> Vec<f64> {
        let costs = crate::gcode::ways::Costs::of(&self.profile, self.language);
        (0..self.imported.import.plan.segments())
            .map(|k| {
                let program = self.convert(k, (0.0, 0.0)).ok()?;
                let ways = crate::gcode::ways::Ways::of(&program, 0.0, &costs);
                Some(match (way, &ways.stored, &ways.chunked) {
                    (Way::Stream, ..) => ways.stream.total_s,
                    (_, Some(whole), _) => whole.total_s,
                    (_, None, Ok(parts)) => parts.total_s,
                    (_, None, Err(_)) => ways.stream.total_s,
                })
            })
            .collect::<Option<Vec<f64>>>()
            .unwrap_or_default()
    }

    /// What the confirmation says before the start: every wait with its
    /// line, how it ends, and the tool offset applied.
    pub(super) fn said_before(&self) -> Vec<String> {
        let import = &self.imported.import;
        let mut lines = Vec::new();
        // An offset applied was said with the import (`upload::import_gcode`).
        if import.tool.is_none() {
            lines.push(crate::gcode::waits::tool_text(None));
        }
        lines.push(format!(
            "{} tool changes and pauses: the job stops at each and waits for you ({}); --yes skips none",
            import.plan.waits.len(),
            confirm_how()
        ));
        for line in crate::gcode::waits::waits_text(&import.plan) {
            lines.push(format!("  {}:{line}", self.imported.name));
        }
        lines.push(match &self.sensor {
            Some(_) => "tool sensor (probe.tool_sensor): each new tool is measured after you confirm, every later Z shifted by its length".to_owned(),
            None => "no tool sensor (probe.tool_sensor): at a tool change the new tool must have the length of the one before".to_owned(),
        });
        lines
    }
}

/// `, about 3:10 min left and 2 waits`: the model's time of piece `index`
/// and the pieces after it; the waits between them are the operator's,
/// counted, not guessed.
fn left_text(model_s: &[f64], index: usize, pieces: usize) -> String {
    if model_s.len() != pieces {
        return String::new();
    }
    let left: f64 = model_s.iter().skip(index).sum();
    let waits = pieces.saturating_sub(index + 1);
    let waits = match waits {
        0 => String::new(),
        1 => " and 1 wait".to_owned(),
        n => format!(" and {n} waits"),
    };
    format!(", about {} left{waits}", crate::gcode::ways::duration(left))
}

fn terminal() -> bool {
    std::io::stdin().is_terminal()
}

fn confirm_how() -> &'static str {
    if terminal() {
        "Enter goes on, Space stops"
    } else {
        "a line on standard input goes on, `stop` stops"
    }
}

/// The job's pieces and waits, in turn, to the end.
#[allow(clippy::too_many_arguments)]
pub(super) async fn run(
    session: &mut Session,
    w: &Waited,
    way: Way,
    args: &RunArgs,
    remedy: &Remedy,
    keys: &mut Keys,
    log: &crate::cli::log::Logged,
) -> Status {
    let import = &w.imported.import;
    let dz0 = import.tool.as_ref().map_or(0.0, |t| t.offset_mm);
    // The import shifted the job by the offset of the tool in the spindle
    // already: the sequence's shifts are what a measured tool changes
    // after it.
    let mut sequence = Sequence::new(import.plan.clone(), w.sensor.is_some(), 0.0);
    let mut table = w.table.1.clone();
    let mut lines = Lines::default();
    let mut operator: Option<Operator> = None;
    let model_s = w.model_s(way);
    loop {
        match sequence.step() {
            Step::Run {
                index,
                dz_before,
                dz,
            } => {
                if let Some(op) = operator.take() {
                    *keys = op.into_keys();
                }
                let n = sequence.plan().segments();
                out::say(format_args!(
                    "piece {}/{n}{}{}",
                    index + 1,
                    if dz == 0.0 {
                        String::new()
                    } else {
                        format!(", every Z {:+.3} mm for the tool measured", dz)
                    },
                    left_text(&model_s, index, n)
                ));
                let how = (way, args, remedy, log);
                piece(session, w, index, (dz_before, dz), how, keys).await?;
                sequence.done();
            }
            Step::Confirm { index } => {
                let Some(wait) = sequence.plan().waits.get(index) else {
                    return Err(1);
                };
                let at = sequence
                    .plan()
                    .waits_at(index, sequence.shift())
                    .unwrap_or(wait.at);
                if way != Way::Stream
                    && w.profile.connection.protocol == crate::proto::Protocol::Isel
                {
                    erase_stored(session, w, remedy).await?;
                }
                announce(w, index, at, args);
                confirm(session, wait, args, keys, &mut lines).await?;
                sequence.confirmed();
            }
            Step::Measure { index, tool } => {
                let at = sequence
                    .plan()
                    .waits_at(index, sequence.shift())
                    .unwrap_or_default();
                // The probe's moves follow the run's keys (Space stops);
                // they come back with the next piece.
                let here = steps_of(&w.profile, at);
                let op = operator.get_or_insert_with(|| {
                    Operator::with_keys(std::mem::replace(keys, Keys::none()), Some(here))
                });
                let offset = measure(session, w, op, &tool, &mut table, remedy).await?;
                let line = sequence.plan().first_line(&import.toolpath, index + 1);
                let said = format!(
                    "{tool}: offset {offset:+.4} mm against the reference tool {}: every Z{} is {:+.4} mm from the program's",
                    table.reference.as_deref().unwrap_or("-"),
                    line.map_or_else(String::new, |l| format!(" from line {l} on")),
                    offset,
                );
                out::say(&said);
                if args.json {
                    event(&json!({
                        "event": "tool_measured",
                        "tool": tool,
                        "offset_mm": round4(offset),
                        "reference": table.reference,
                        "shift_mm": round4(offset),
                    }));
                }
                sequence.measured(offset - dz0);
            }
            Step::Return { to, .. } => {
                if let Some(op) = operator.as_mut() {
                    back_to(session, &w.profile, op, to, remedy).await?;
                }
                sequence.returned();
            }
            Step::Done => {
                if let Some(op) = operator.take() {
                    *keys = op.into_keys();
                }
                return Ok(());
            }
        }
    }
}

/// One piece converted for the tool in the spindle and run as the job's
/// way says: streamed, or stored (in parts where it does not fit).
async fn piece(
    session: &mut Session,
    w: &Waited,
    index: usize,
    shifts: (f64, f64),
    (way, args, remedy, log): (Way, &RunArgs, &Remedy, &crate::cli::log::Logged),
    keys: &mut Keys,
) -> Status {
    let imported = &w.imported;
    let program = w.convert(index, shifts).map_err(|errors| {
        for e in &errors {
            out::say(crate::gcode::render(&imported.name, e));
        }
        out::say(format_args!(
            "jogterm run: piece {} does not convert with the tool's offset; the tool stays where it stands",
            index + 1
        ));
        1
    })?;
    let checked = |p, config: &LintConfig| {
        imported
            .checked(p, w.language, config, "run")
            .map_err(|(code, m)| {
                out::say(m);
                code
            })
    };
    if way == Way::Stream {
        let part = checked(program, &streamed(&w.config))?;
        // The model of the piece's own commands: its live ETA.
        let place = part.place();
        let ways = place.gcode.map(|p| {
            crate::gcode::ways::Ways::of(
                p,
                0.0,
                &crate::gcode::ways::Costs::of(&w.profile, w.language),
            )
        });
        // The job log follows the piece's lines, as a whole stream's.
        let place = super::stream::Place {
            log: Some(log),
            ways: ways.as_ref(),
            ..place
        };
        return super::stream::run(
            session,
            part.program(),
            &place,
            (remedy.isel_device, remedy.axes),
            args.speed,
            keys,
        )
        .await;
    }
    let parts: Vec<Prepared> = if program.fits() {
        vec![checked(program, &w.config)?]
    } else {
        let cut = program.parts(program.capacity).map_err(|why| {
            out::say(format_args!("{}: {why}", imported.name));
            1
        })?;
        (0..cut.len())
            .map(|k| checked(program.part(&cut, k), &w.config))
            .collect::<Result<_, _>>()?
    };
    let mut pause_next = false;
    for (k, part) in parts.iter().enumerate() {
        if parts.len() > 1 {
            out::say(format_args!("part {}/{}", k + 1, parts.len()));
        }
        if pause_next {
            out::say("paused before the next part, the tool retracted (r resumes, Space stops)");
            super::wait_resume(session, keys).await?;
            pause_next = false;
        }
        let erase = args.erase || index > 0 || k > 0;
        upload::upload(session, part, erase, remedy).await?;
        super::stored_run(session, remedy, keys, &mut pause_next).await?;
        if let Some(line) = part.last_gcode_line() {
            log.line(line);
        }
    }
    Ok(())
}

/// Wait `index` said: its line, what it waits for, where the tool stands
/// and how it ends.
fn announce(w: &Waited, index: usize, at: Point, args: &RunArgs) {
    let plan = &w.imported.import.plan;
    let Some(wait) = plan.waits.get(index) else {
        return;
    };
    let name = &w.imported.name;
    let line = wait.origin.line;
    let place = if wait.is_tool_change() {
        format!(
            "the spindle is off, the tool at machine X {:.3} Y {:.3} Z {:.3}",
            at.x, at.y, at.z
        )
    } else {
        "the tool stands where the program left it".to_owned()
    };
    let then = match (wait.is_tool_change(), &w.sensor) {
        (true, Some(_)) => "; the new tool is then measured on the sensor".to_owned(),
        (true, None) => format!(
            "; no tool sensor: the new tool must have the old one's length (or stop, touch off Z and restart with --from-line {})",
            plan.first_line(&w.imported.import.toolpath, index + 1)
                .unwrap_or(line)
        ),
        (false, _) => String::new(),
    };
    out::say(format_args!(
        "{name}:{line}: waiting: {}: {place}{then}; {}",
        wait.what(),
        confirm_how()
    ));
    if args.json {
        event(&json!({
            "event": "wait",
            "line": line,
            "kind": crate::gcode::waits::kind_name(wait),
            "tool": wait.tool_name(),
            "what": wait.what(),
            "at_machine_mm": { "x": round4(at.x), "y": round4(at.y), "z": round4(at.z) },
            "ends_by": if terminal() { "enter" } else { "stdin_line" },
            "measure": wait.is_tool_change() && w.sensor.is_some(),
        }));
    }
}

/// The operator's answer: Enter (or `r`) on a terminal, a line on
/// standard input without one; Space, `stop`, the end of the input stop.
async fn confirm(
    session: &mut Session,
    wait: &Wait,
    args: &RunArgs,
    keys: &mut Keys,
    lines: &mut Lines,
) -> Status {
    // Standard input given to the simulator's start key is not the
    // operator's to answer with.
    let stdin_answers = !matches!(args.sim_start_key, Some(super::sim_start::SimStart::Stdin));
    let operator = async {
        if terminal() {
            if keys.forget_typed_ahead() {
                return Ended::Stop;
            }
            loop {
                match keys.next().await {
                    Key::Resume => break Ended::Operator,
                    Key::Stop | Key::Gone => break Ended::Stop,
                    _ => {}
                }
            }
        } else if stdin_answers {
            match lines.next().await {
                Some(line) if !matches!(line.trim(), "stop" | "s" | "q" | "quit") => {
                    Ended::Operator
                }
                _ => Ended::Stop,
            }
        } else {
            std::future::pending().await
        }
    };
    let ended = tokio::select! {
        ended = operator => ended,
        ended = start_key(session) => ended,
    };
    let _ = session.handle.request(Request::Poll {
        rate_hz: Some(0.0),
        ports_every: 1,
    });
    if args.json {
        event(&json!({
            "event": "wait_ended",
            "line": wait.origin.line,
            "by": match ended {
                Ended::Operator => "operator",
                Ended::StartKey => "start_key",
                Ended::Stop => "stop",
            },
        }));
    }
    if ended != Ended::Stop {
        out::say(format_args!(
            "line {}: going on{}",
            wait.origin.line,
            if ended == Ended::StartKey {
                " (the start key)"
            } else {
                ""
            }
        ));
        return Ok(());
    }
    let _ = session.handle.stop().written().await;
    out::say(format_args!(
        "jogterm run: stopped at the wait of line {}; nothing resumes",
        wait.origin.line
    ));
    Err(1)
}

/// isel: the piece that ran stays stored, and the iMC runs a stored
/// program when its start key is pressed (manual, "CNC-Modus": "durch einen
/// externen Start-Befehl (Betätigen der Starttaste) aktiviert"): a press
/// at a tool change, the operator's hands at the spindle, would run the
/// piece again. It is erased (`@0k`, manual 2.2.17) before the wait; the
/// next piece is stored anew in any case.
async fn erase_stored(session: &mut Session, w: &Waited, remedy: &Remedy) -> Status {
    out::say("erasing the stored piece (@0k): the start key must not run it again at the wait");
    let line = format!("@{}k", w.profile.isel.device);
    super::retract::one_line(session, &line, "the erase before the wait", remedy).await
}

/// How often the inputs are read while a job waits: a finger's press
/// (100-200 ms) is seen.
const WAIT_POLL_HZ: f64 = 20.0;

/// How a wait ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Ended {
    Operator,
    StartKey,
    Stop,
}

/// The machine's start key pressed: the profile's wired input with role
/// `start` seen released and then pressed in the device's input polls (a
/// key held down since before the wait confirms nothing). Never, where the
/// profile wires no start key or the link ends.
async fn start_key(session: &mut Session) -> Ended {
    // A moving session polls nothing (the wire is the job's); a wait is
    // the time to read the inputs, and `confirm` turns the polls off again.
    if session
        .handle
        .request(Request::Poll {
            rate_hz: Some(WAIT_POLL_HZ),
            ports_every: 1,
        })
        .is_err()
    {
        return std::future::pending().await;
    }
    let mut released = false;
    while let Some(e) = session.next_event().await {
        let Event::Io(io) = e else { continue };
        match io.start_key() {
            Some(false) => released = true,
            Some(true) if released => return Ended::StartKey,
            _ => {}
        }
    }
    std::future::pending().await
}

/// The new tool measured on the sensor from where `op` stands (the change
/// position, where the piece before left it); its offset against the
/// reference tool, kept in the tool table (saved where there is one).
async fn measure(
    session: &mut Session,
    w: &Waited,
    op: &mut Operator,
    name: &str,
    table: &mut ToolTable,
    remedy: &Remedy,
) -> Result<f64, u8> {
    let Some(sensor) = &w.sensor else {
        return Err(1);
    };
    let profile = &w.profile;
    let here = op.here();
    let end = tool::measure(op, session, profile, sensor, here, remedy).await?;
    let what = format!("the measure of {name}");
    let Some(touched) = probing::touched(&end) else {
        if let Some(z) = profile.axis(Axis::Z) {
            out::say(format_args!(
                "jogterm run: {}",
                probing::end_text(&what, (Axis::Z, z), &end)
            ));
        }
        return Err(1);
    };
    let z = probing::units(profile, Axis::Z, touched.get(Axis::Z).unwrap_or(0));
    let offset = table.measured(name, z);
    if let Some(path) = &w.table.0
        && let Err(why) = tool::save(path, table)
    {
        out::say(format_args!(
            "jogterm run: the tool table was not saved: {why}"
        ));
    }
    out::say(format_args!("{what}: touched at Z {z:.4}"));
    Ok(offset)
}

/// Back from the sensor to the change position: Z up alone, over, down
/// (`probing::up_over_down`).
async fn back_to(
    session: &mut Session,
    profile: &Profile,
    op: &mut Operator,
    to: Point,
    remedy: &Remedy,
) -> Status {
    let here = op.here().unwrap_or_default();
    for leg in probing::up_over_down(profile, &here, &steps_of(profile, to)) {
        op.move_to(session, leg.target, leg.speed_hz, remedy)
            .await?;
    }
    Ok(())
}

/// A machine point (mm) in steps of the profile's axes.
fn steps_of(profile: &Profile, p: Point) -> PerAxis<i64> {
    probing::steps_of(profile, [(Axis::X, p.x), (Axis::Y, p.y), (Axis::Z, p.z)])
}

fn round4(v: f64) -> f64 {
    (v * 1e4).round() / 1e4
}

/// One `--json` event on stdout.
fn event(value: &serde_json::Value) {
    use std::io::Write as _;
    let _ = writeln!(std::io::stdout().lock(), "{value}");
}

/// Lines of a standard input that is no terminal, read on a thread from
/// the first wait on (never before: a run without waits leaves stdin
/// alone).
#[derive(Default)]
struct Lines {
    rx: Option<mpsc::UnboundedReceiver<Option<String>>>,
}

impl Lines {
    /// The next line; `None` at the end of the input.
    async fn next(&mut self) -> Option<String> {
        let rx = self.rx.get_or_insert_with(crate::cli::lines::stdin_lines);
        rx.recv().await.flatten()
    }
}
