//! The live ETA of `jogterm run` (issue 41 item 3): the real binary
//! streaming a job to `jogterm sim --pty` at real time. Halfway through,
//! the time left it says is within 10 % of the time the job then takes, at
//! the programmed speeds and at a speed factor of 50 %.

use std::io::{BufRead, BufReader};
use std::process::Stdio;
use std::time::Instant;

use crate::sim_process::SimProcess;

/// The shipped machine, the simulated axes 1 mm from their reference point
/// (the job's own reference run takes a moment).
const MACHINE: (&str, &str) = ("profiles/default.toml", "[sim]\nstart_position = 1.0\n");

/// 30 cuts of 1.5 mm in X at 900 mm/min, zigzagging in Y so that none is
/// merged with its neighbour: about 5 s streamed at 100 %.
fn job() -> String {
    let mut t = String::from("G21 G90 G17\nG0 X0 Y0 Z5\nG1 Z-0.5 F600\n");
    for k in 1..=30 {
        let y = if k % 2 == 0 { 0.0 } else { 0.3 };
        t.push_str(&format!("G1 X{:.3} Y{y:.3} F900\n", k as f64 * 1.5));
    }
    t.push_str("G0 Z5\nM30\n");
    t
}

/// `1:05 min`, `12.5 s` as `jogterm run` writes them.
fn seconds(text: &str) -> Option<f64> {
    if let Some(s) = text.strip_suffix(" s") {
        return s.parse().ok();
    }
    let clock = text.strip_suffix(" min")?;
    let (m, s) = clock.split_once(':')?;
    Some(m.parse::<f64>().ok()? * 60.0 + s.parse::<f64>().ok()?)
}

/// Streams the job at `speed` %; returns the first progress line at or
/// past half, the time left it says, and the seconds the run took after it.
fn eta_at_half(speed: &str) -> (String, f64, f64) {
    let sim = SimProcess::start_variant("isel", &[MACHINE], &[]);
    let file = sim.dir.path().join("eta.nc");
    std::fs::write(&file, job()).expect("write the job");
    let mut child = sim
        .configured(&[
            "run",
            &file.display().to_string(),
            "--work-zero",
            "X50 Y50 Z60",
            "--stream",
            "--speed",
            speed,
            "--yes",
        ])
        .stderr(Stdio::piped())
        .spawn()
        .expect("jogterm run");
    let stderr = child.stderr.take().expect("stderr");
    let mut half: Option<(String, f64, Instant)> = None;
    let mut ended: Option<Instant> = None;
    let mut said = String::new();
    for line in BufReader::new(stderr).lines() {
        let Ok(line) = line else { break };
        said.push_str(&line);
        said.push('\n');
        // The job's last answer; what follows is the session's close.
        if line.contains("the stream ended after") {
            ended.get_or_insert_with(Instant::now);
        }
        if half.is_some() {
            continue;
        }
        // `eta.nc:19:1: 52 % after 3.1 s, about 2.9 s left at speed 100 %`
        let Some((head, rest)) = line.split_once(" % after ") else {
            continue;
        };
        let share: usize = head
            .rsplit(' ')
            .next()
            .and_then(|p| p.parse().ok())
            .unwrap_or(0);
        let left = rest
            .split_once("about ")
            .and_then(|(_, l)| l.split_once(" left"))
            .and_then(|(l, _)| seconds(l));
        if let (true, Some(left)) = (share >= 50, left) {
            half = Some((line.clone(), left, Instant::now()));
        }
    }
    let status = child.wait().expect("the run ends");
    assert!(status.success(), "{said}");
    let end = ended.unwrap_or_else(|| panic!("no end of the stream:\n{said}"));
    let (line, left, at) = half.unwrap_or_else(|| panic!("no progress past half:\n{said}"));
    (line, left, end.duration_since(at).as_secs_f64())
}

#[test]
fn halfway_through_a_stream_the_time_left_is_within_ten_percent() {
    let (line, left, took) = eta_at_half("100");
    assert!(line.ends_with("at speed 100 %"), "{line}");
    assert!(
        (left - took).abs() <= 0.1 * took,
        "said {left:.2} s left, took {took:.2} s: {line}"
    );
}

#[test]
fn at_half_the_speed_the_time_left_follows_the_factor() {
    let (line, left, took) = eta_at_half("50");
    assert!(line.ends_with("at speed 50 %"), "{line}");
    assert!(
        (left - took).abs() <= 0.1 * took,
        "said {left:.2} s left, took {took:.2} s: {line}"
    );
    // Slower than at full speed: the factor is in the forecast.
    assert!(took > 3.0, "{took}");
}
