//! A job bigger than the controller's memory, run both ways (issue 27):
//! a CAM-style G-code file of `--moves` moves (default 50 000) run by the
//! real `jogterm run` against the isel simulator (`jogterm sim --pty`, the
//! wire paced at 19200 baud as the controller's), once as a DNC stream and
//! once chunked, both at the same time on simulators of their own.
//!
//! For each way: the estimate `jogterm run` said before the start
//! (`gcode::ways`), the measured time, the planner's motion time (the
//! physical floor: feeds and rapids, no ramps) and the time the axes stood
//! still with the tool in the part and retracted, measured from the
//! traffic log of the run (`--log`, every byte with its time):
//!
//! - stream: a move begins when its command's last byte is on the wire
//!   (the log's `>>` time plus the command's wire time) and ends when its
//!   answer arrives (`<<`); between the answer of one move and the start of
//!   the next the axes stand, in the part when the move before ended below
//!   the job's safe height.
//! - chunked: each part runs from its `@0S` to the program's answer; between
//!   one part's end and the next start (the erase, the next part's upload)
//!   the tool stands retracted, since parts are cut only at the safe height.
//!
//! Run: `cargo bench --bench jobs` (optimised build; about an hour and a
//! half of real time at 50 000 moves: the wire is the controller's). Options:
//! `--moves N`, `--only stream|chunked`. Results: `docs/gcode.md`, "Jobs
//! bigger than the memory".
//!
//! `cargo bench --bench jobs -- --estimate` (issue 41) instead runs small
//! jobs (short and long lines, arcs and short arcs; a few seconds each) stored
//! and streamed, and one of pockets in parts on a controller that stores
//! 20 commands, on simulators at real time, and prints the estimate of the
//! controller's model (`gcode::timing`, `gcode::ways`) beside the time
//! measured from the traffic log, with the error of each (about two
//! minutes in all). Results: `docs/performance.md`, "Estimates against the
//! simulator".
//!
//! Hand-written, not on divan: a job run at the controller's real time
//! (hours of wire), not a function timed in a loop.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod support;

use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

use jogterm::proto::Protocol;
use support::{Args, SimProcess};

const BAUD: f64 = 19_200.0;
/// The job's work zero in machine mm, and its safe height (work Z5).
const WORK_ZERO: &str = "X150 Y100 Z50";
const SAFE_Z_STEPS: i64 = 55 * 400;
/// Moves of one pass between two retracts: a part holds several passes.
const PASS: usize = 200;

/// Finishing passes of short segments (0.25 mm in X at 3000 mm/min over
/// a rough surface, as a CAM 3D finish writes them), each entered from and left to the safe height.
fn job(moves: usize) -> String {
    let mut text = String::from("%\n(bench job)\nG21 G90 G17\nG0 Z5\n");
    let mut written = 0;
    let mut pass = 0usize;
    while written < moves {
        let y = -40.0 + (pass % 160) as f64 * 0.5;
        let x0 = -60.0;
        writeln!(text, "G0 X{x0:.3} Y{y:.3}").unwrap();
        writeln!(text, "G1 Z-0.5 F600").unwrap();
        written += 2;
        let segments = PASS.min(moves.saturating_sub(written + 1)).max(1);
        for k in 1..=segments {
            let x = x0 + k as f64 * 0.25;
            // A surface rough enough that no segment lies on the line of
            // its neighbours: the import merges those (`merge_lines`).
            let z = -0.5 + 0.2 * (k as f64 * 1.3).sin();
            writeln!(text, "G1 X{x:.3} Z{z:.3} F3000").unwrap();
        }
        writeln!(text, "G0 Z5").unwrap();
        written += segments + 1;
        pass += 1;
    }
    text.push_str("M30\n%\n");
    text
}

/// One line of the traffic log: seconds of the day, direction, text.
struct Record {
    at: f64,
    sent: bool,
    text: String,
}

fn records(log: &str) -> Vec<Record> {
    let mut out = Vec::new();
    let mut day = 0.0;
    let mut last = 0.0;
    for line in log.lines() {
        let Some((stamp, rest)) = line.split_once(' ') else {
            continue;
        };
        let Some(time) = stamp.split('T').nth(1) else {
            continue;
        };
        let f: Vec<f64> = time
            .trim_end_matches('Z')
            .split(':')
            .filter_map(|v| v.parse().ok())
            .collect();
        if f.len() != 3 {
            continue;
        }
        let mut at = f[0] * 3600.0 + f[1] * 60.0 + f[2] + day;
        if at < last {
            day += 86_400.0;
            at += 86_400.0;
        }
        last = at;
        let (sent, text) = if let Some(t) = rest.strip_prefix(">> ") {
            (true, t)
        } else if let Some(t) = rest.strip_prefix("<< ") {
            (false, t)
        } else {
            continue;
        };
        out.push(Record {
            at,
            sent,
            text: text.to_owned(),
        });
    }
    out
}

/// Wire time of `text` as logged (`<CR>` is one byte).
fn wire_s(text: &str) -> f64 {
    let bytes = text.replace("<CR>", "\r").len();
    bytes as f64 * 10.0 / BAUD
}

#[derive(Default)]
struct Measured {
    total_s: f64,
    moving_s: f64,
    at_part_s: f64,
    stops_at_part: usize,
    retracted_s: f64,
    wall_s: f64,
}

/// The stream's moves from its log.
fn measure_stream(log: &[Record]) -> Measured {
    let mut m = Measured::default();
    let mut first: Option<f64> = None;
    let mut ended: Option<(f64, bool)> = None;
    let mut pending: Option<(f64, bool)> = None;
    for r in log {
        if r.sent && r.text.starts_with("@0M") {
            let begin = r.at + wire_s(&r.text);
            first.get_or_insert(begin);
            if let Some((end, below)) = ended.take() {
                let still = (begin - end).max(0.0);
                if below {
                    m.at_part_s += still;
                    m.stops_at_part += 1;
                } else {
                    m.retracted_s += still;
                }
            }
            let z: i64 = r
                .text
                .trim_start_matches("@0M")
                .trim_end_matches("<CR>")
                .split(',')
                .nth(4)
                .and_then(|v| v.parse().ok())
                .unwrap_or(SAFE_Z_STEPS);
            pending = Some((begin, z < SAFE_Z_STEPS));
        } else if !r.sent
            && let Some((begin, below)) = pending.take()
        {
            m.moving_s += r.at - begin;
            m.total_s = r.at - first.unwrap_or(begin);
            ended = Some((r.at, below));
        }
    }
    m
}

/// The parts of a chunked run from its log.
fn measure_chunked(log: &[Record]) -> Measured {
    let mut m = Measured::default();
    let mut first: Option<f64> = None;
    let mut running: Option<f64> = None;
    let mut ended: Option<f64> = None;
    for r in log {
        if r.sent && r.text == "@0S<CR>" {
            let begin = r.at + wire_s(&r.text);
            first.get_or_insert(begin);
            if let Some(end) = ended.take() {
                m.retracted_s += begin - end;
            }
            running = Some(begin);
        } else if !r.sent
            && let Some(begin) = running.take()
        {
            m.moving_s += r.at - begin;
            m.total_s = r.at - first.unwrap_or(begin);
            ended = Some(r.at);
        }
    }
    m
}

/// `12.3 s` from the duration texts `jogterm run` prints (`1:05:12 h`,
/// `4:31 min`, `12.5 s`).
fn seconds(text: &str) -> Option<f64> {
    let text = text.trim();
    if let Some(s) = text.strip_suffix(" s") {
        return s.parse().ok();
    }
    let (clock, unit) = text.split_once(' ')?;
    let parts: Vec<f64> = clock.split(':').filter_map(|v| v.parse().ok()).collect();
    match (unit, parts.as_slice()) {
        ("min", [m, s]) => Some(m * 60.0 + s),
        ("h", [h, m, s]) => Some(h * 3600.0 + m * 60.0 + s),
        _ => None,
    }
}

/// What `jogterm run` estimated for `way` (`stream:  36:12 min in all; …`).
fn estimated(said: &str, way: &str) -> Option<f64> {
    let line = said
        .lines()
        .find(|l| l.trim_start().starts_with(&format!("{way}:")))?;
    let rest = line.trim_start().strip_prefix(&format!("{way}:"))?;
    seconds(rest.split(" in all").next()?)
}

fn floor(said: &str) -> Option<f64> {
    let line = said
        .lines()
        .find(|l| l.contains("motion alone (the floor): "))?;
    seconds(line.split("motion alone (the floor): ").nth(1)?)
}

struct Run {
    way: &'static str,
    said: String,
    measured: Measured,
    ok: bool,
}

fn run_way(way: &'static str, file: &Path, config: &Path) -> std::thread::JoinHandle<Run> {
    let file = file.to_path_buf();
    let config = config.to_path_buf();
    std::thread::spawn(move || {
        let sim = SimProcess::start_with(Protocol::Isel, &[], Some(&config));
        let state = tempfile::tempdir().expect("state dir");
        let log = state.path().join("traffic.log");
        let started = Instant::now();
        let out = Command::new(env!("CARGO_BIN_EXE_jogterm"))
            .arg("--log")
            .arg(&log)
            .arg("run")
            .arg("--port")
            .arg(&sim.link)
            .args(["--protocol", "isel"])
            .arg(&file)
            .args(["--work-zero", WORK_ZERO, "--yes"])
            .arg(format!("--{way}"))
            .env("JOGTERM_CONFIG_DIR", &config)
            .env("JOGTERM_STATE_DIR", state.path())
            .output()
            .expect("run jogterm run");
        let wall_s = started.elapsed().as_secs_f64();
        let said = String::from_utf8_lossy(&out.stderr).into_owned();
        let text = std::fs::read_to_string(&log).unwrap_or_default();
        let log = records(&text);
        let mut measured = if way == "stream" {
            measure_stream(&log)
        } else {
            measure_chunked(&log)
        };
        measured.wall_s = wall_s;
        Run {
            way,
            said,
            measured,
            ok: out.status.success(),
        }
    })
}

fn main() {
    let args = Args::from_env();
    if args.flag("--estimate") {
        estimate::main(&args);
        return;
    }
    let moves: usize = args.value("--moves").map_or(50_000, |v| v.parse().unwrap());
    let only = args.value("--only").map(str::to_owned);
    let dir = tempfile::tempdir().expect("temp dir");
    let file = dir.path().join("job.nc");
    std::fs::write(&file, job(moves)).expect("write the job");
    // The shipped isel machine and its simulator: no profiles of the user's.
    let config = dir.path().join("config");
    std::fs::create_dir_all(&config).expect("config dir");
    println!(
        "jobs bench ({} build): {moves} moves, isel at {BAUD} baud, started {:?}",
        support::build_kind(),
        std::time::SystemTime::now()
    );
    let ways: Vec<&'static str> = ["stream", "chunked"]
        .into_iter()
        .filter(|w| only.as_deref().is_none_or(|o| o == *w))
        .collect();
    let runs: Vec<Run> = ways
        .iter()
        .map(|w| run_way(w, &file, &config))
        .collect::<Vec<_>>()
        .into_iter()
        .map(|h| h.join().expect("a way's thread"))
        .collect();
    println!(
        "\n| way | estimated | measured (first move to last answer) | wall of `jogterm run` | motion floor | moving | standing in the part | standing retracted |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    for r in &runs {
        let m = &r.measured;
        let est = estimated(&r.said, r.way).map_or("?".into(), |s| format!("{s:.0} s"));
        let fl = floor(&r.said).map_or("?".into(), |s| format!("{s:.0} s"));
        println!(
            "| {} | {est} | {:.0} s | {:.0} s | {fl} | {:.0} s | {:.1} s ({} stops, {:.1} ms each) | {:.0} s |",
            r.way,
            m.total_s,
            m.wall_s,
            m.moving_s,
            m.at_part_s,
            m.stops_at_part,
            if m.stops_at_part > 0 {
                m.at_part_s * 1000.0 / m.stops_at_part as f64
            } else {
                0.0
            },
            m.retracted_s
        );
        if !r.ok {
            println!("  {} did not end well:\n{}", r.way, tail(&r.said, 12));
        }
    }
    for r in &runs {
        println!("\n`jogterm run --{}` said:\n{}", r.way, head(&r.said, 14));
    }
}

fn head(text: &str, n: usize) -> String {
    text.lines().take(n).collect::<Vec<_>>().join("\n")
}

fn tail(text: &str, n: usize) -> String {
    let lines: Vec<&str> = text.lines().collect();
    lines[lines.len().saturating_sub(n)..].join("\n")
}

/// `--estimate`: the model's estimate of small jobs against their runs.
mod estimate {
    use super::*;
    use jogterm::config::{ConfigDirs, load_profile};
    use jogterm::gcode::ways::Ways;
    use jogterm::gcode::{Target, import};
    use jogterm::offsets::WorkOffsets;

    /// The bench's machine: the shipped isel profile without a reference
    /// run in the program (a reference run's time depends on where the
    /// axes stood, which no estimate before the start knows). Before each
    /// job the simulator is referenced and its axes brought to the job's
    /// first point, where the model takes them to stand (`gcode::timing`).
    const PROFILE: &str = "base = \"isel\"\nname = \"bench\"\ndescription = \"jobs bench\"\n\n[gcode]\nreference_first = false\n\n[sim]\nstart_position = 1.0\n";
    const ZERO: &str = "X2 Y10 Z60";
    const ZERO_MM: [f64; 3] = [2.0, 10.0, 60.0];

    fn lines(segment: f64, count: usize, feed: f64) -> String {
        let mut t = String::from("G21 G90 G17\nG0 X0 Y0 Z5\nG1 Z-0.5 F600\n");
        for k in 1..=count {
            let x = k as f64 * segment;
            // Off the line of their neighbours: the import merges those.
            let z = -0.5 + 0.2 * (k as f64 * 1.3).sin();
            t.push_str(&format!("G1 X{x:.3} Z{z:.3} F{feed}\n"));
        }
        t.push_str("G0 Z5\nM30\n");
        t
    }

    fn arcs(radius: f64, count: usize, feed: f64) -> String {
        let mut t = String::from("G21 G90 G17\nG0 X0 Y0 Z5\nG1 Z-0.5 F600\n");
        let mut x = 0.0;
        for k in 0..count {
            // Half circles to and fro along X.
            let (g, dx) = if k % 2 == 0 {
                (2, 2.0 * radius)
            } else {
                (3, 2.0 * radius)
            };
            x += dx;
            t.push_str(&format!("G{g} X{x:.3} Y0 I{radius:.3} J0 F{feed}\n"));
        }
        t.push_str("G0 Z5\nM30\n");
        t
    }

    /// Squares cut one after the other, the tool retracted between them
    /// (where a job in parts may be cut).
    fn pockets(count: usize, side: f64, feed: f64) -> String {
        let mut t = String::from("G21 G90 G17\nG0 Z5\n");
        for k in 0..count {
            let (x, y) = ((k % 4) as f64 * 8.0, (k / 4) as f64 * 8.0);
            t.push_str(&format!(
                "G0 X{x:.3} Y{y:.3}\nG1 Z-0.5 F600\nG1 X{:.3} F{feed}\nG1 Y{:.3}\nG1 X{x:.3}\nG1 Y{y:.3}\nG0 Z5\n",
                x + side,
                y + side
            ));
        }
        t.push_str("M30\n");
        t
    }

    struct Job {
        name: &'static str,
        text: String,
        /// A controller that stores this many commands: the job runs in
        /// parts (`--chunked`); else stored and streamed.
        memory: Option<usize>,
    }

    fn jobs() -> Vec<Job> {
        vec![
            Job {
                name: "short lines (0.25 mm, 3000 mm/min)",
                text: lines(0.25, 120, 3000.0),
                memory: None,
            },
            Job {
                name: "long lines (20 mm, 1200 mm/min)",
                text: lines(20.0, 5, 1200.0),
                memory: None,
            },
            Job {
                name: "arcs (R 5 mm half circles, 1200 mm/min)",
                text: arcs(5.0, 6, 1200.0),
                memory: None,
            },
            Job {
                name: "short arcs (R 0.5 mm half circles, 1500 mm/min)",
                text: arcs(0.5, 60, 1500.0),
                memory: None,
            },
            Job {
                name: "pockets in parts (8 squares of 4 mm, 1200 mm/min, memory 20)",
                text: pockets(8, 4.0, 1200.0),
                memory: Some(20),
            },
        ]
    }

    /// From the first byte of the job (`@0i` stored and in parts, the first
    /// command after the set-up streamed) to the last answer.
    fn measure(log: &[Record], way: &str, first: &str) -> Option<f64> {
        let start = if way != "stream" {
            log.iter().find(|r| r.sent && r.text.starts_with("@0i"))?.at
        } else {
            log.iter().find(|r| r.sent && r.text == first)?.at
        };
        let end = log.iter().rev().find(|r| !r.sent)?.at;
        Some(end - start)
    }

    /// The host's turnaround in a stream: from an answer to the next
    /// command's first byte, median and mean in ms.
    fn turnaround(log: &[Record], first: &str) -> (f64, f64) {
        let from = log
            .iter()
            .position(|r| r.sent && r.text == first)
            .unwrap_or(0);
        let mut gaps: Vec<f64> = log[from..]
            .windows(2)
            .filter(|w| !w[0].sent && w[1].sent)
            .map(|w| (w[1].at - w[0].at) * 1000.0)
            .collect();
        if gaps.is_empty() {
            return (0.0, 0.0);
        }
        gaps.sort_by(f64::total_cmp);
        let mean = gaps.iter().sum::<f64>() / gaps.len() as f64;
        (gaps[gaps.len() / 2], mean)
    }

    pub fn main(_args: &Args) {
        let dir = tempfile::tempdir().expect("temp dir");
        let config = dir.path().join("config");
        std::fs::create_dir_all(&config).expect("config dir");
        println!(
            "jobs bench --estimate ({} build), isel at {BAUD} baud, started {:?}",
            support::build_kind(),
            std::time::SystemTime::now()
        );
        println!("\n| job | commands | way | estimated | measured | error |");
        println!("|---|---:|---|---:|---:|---:|");
        let mut worst: f64 = 0.0;
        let only: Option<usize> = std::env::var("JOBS_ONLY").ok().and_then(|v| v.parse().ok());
        for (k, job) in jobs().into_iter().enumerate() {
            if only.is_some_and(|o| o != k) {
                continue;
            }
            let file = dir.path().join("job.nc");
            std::fs::write(&file, &job.text).expect("job");
            let profile_path = dir.path().join("bench.toml");
            let text = match job.memory {
                Some(m) => PROFILE.replace(
                    "reference_first = false\n",
                    &format!("reference_first = false\nmemory = {m}\n"),
                ),
                None => PROFILE.to_owned(),
            };
            std::fs::write(&profile_path, text).expect("profile");
            let spec = profile_path.to_string_lossy().into_owned();
            let profile = load_profile(&spec, &ConfigDirs::builtin_only()).expect("bench profile");
            let mut offsets = WorkOffsets::default();
            for (axis, mm) in [
                jogterm::axis::Axis::X,
                jogterm::axis::Axis::Y,
                jogterm::axis::Axis::Z,
            ]
            .into_iter()
            .zip(ZERO_MM)
            {
                let p = profile.axis(axis).expect("axis");
                offsets.set(jogterm::offsets::System::G54, axis, p.to_steps(mm));
            }
            let imported = import(&job.text, "job.nc", &profile, &offsets, Target::Isel)
                .unwrap_or_else(|e| panic!("{}: {e:?}", job.name));
            let ways = Ways::of_import(&imported, None, &profile);
            let first = imported
                .program
                .lines
                .iter()
                .find(|l| !l.command.is_empty())
                .map(|l| match l.command.strip_prefix('7') {
                    // CNC `7` is `@0R` in DNC form.
                    Some(mask) => format!("@0R{mask}<CR>"),
                    None => format!("@0{}<CR>", l.command),
                })
                .unwrap_or_default();
            // The job's first point: its first move after the reference
            // run, in 2.5D (Z last: up from below).
            let to_start = imported
                .program
                .lines
                .iter()
                .find(|l| l.command.starts_with('m'))
                .map(|l| format!("@0M{}", &l.command[1..]))
                .expect("a move");
            let run_ways: &[&str] = match job.memory {
                Some(_) => &["chunked"],
                None => &["stored", "stream"],
            };
            for &way in run_ways {
                let estimated = match way {
                    "stored" => ways.stored.map(|e| e.total_s),
                    "chunked" => ways.chunked.as_ref().ok().map(|e| e.total_s),
                    _ => Some(ways.stream.total_s),
                }
                .unwrap_or_else(|| panic!("{}: no {way} estimate", job.name));
                let sim =
                    SimProcess::start_with(Protocol::Isel, &["--profile", &spec], Some(&config));
                let state = tempfile::tempdir().expect("state dir");
                let referenced = Command::new(env!("CARGO_BIN_EXE_jogterm"))
                    .args(["--profile", &spec, "send", "--port"])
                    .arg(&sim.link)
                    .args(["--protocol", "isel", "@07", "@0R7", &to_start])
                    .env("JOGTERM_CONFIG_DIR", &config)
                    .env("JOGTERM_STATE_DIR", state.path())
                    .output()
                    .expect("jogterm send");
                assert!(
                    referenced.status.success(),
                    "{}",
                    String::from_utf8_lossy(&referenced.stderr)
                );
                let log = state.path().join("traffic.log");
                let out = Command::new(env!("CARGO_BIN_EXE_jogterm"))
                    .args(["--profile", &spec, "--log"])
                    .arg(&log)
                    .arg("run")
                    .arg("--port")
                    .arg(&sim.link)
                    .args(["--protocol", "isel"])
                    .arg(&file)
                    .args(["--work-zero", ZERO, "--yes"])
                    .args(match way {
                        "stream" => &["--stream"][..],
                        "chunked" => &["--chunked"][..],
                        _ => &[][..],
                    })
                    .env("JOGTERM_CONFIG_DIR", &config)
                    .env("JOGTERM_STATE_DIR", state.path())
                    .output()
                    .expect("jogterm run");
                let said = String::from_utf8_lossy(&out.stderr).into_owned();
                assert!(
                    out.status.success(),
                    "{said}\nthe set-up said:\n{}",
                    String::from_utf8_lossy(&referenced.stdout)
                );
                let text = std::fs::read_to_string(&log).unwrap_or_default();
                let records = records(&text);
                let measured = measure(&records, way, &first).expect("the log");
                if way == "stream" {
                    let (median, mean) = turnaround(&records, &first);
                    eprintln!(
                        "{}: host turnaround median {median:.2} ms, mean {mean:.2} ms",
                        job.name
                    );
                    if std::env::var_os("JOBS_DUMP").is_some() {
                        for line in text.lines().skip_while(|l| !l.contains(&first)).take(30) {
                            eprintln!("  {line}");
                        }
                    }
                }
                let error = (estimated - measured) / measured * 100.0;
                worst = worst.max(error.abs());
                println!(
                    "| {} | {} | {way} | {estimated:.3} s | {measured:.3} s | {error:+.1} % |",
                    job.name, imported.program.commands
                );
            }
        }
        println!("\nworst error {worst:.1} % (the goal: within 5 %)");
    }
}
