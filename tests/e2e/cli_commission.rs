//! End to end: `jogterm commission` (the switch walk-test) against the real
//! `jogterm sim --pty`, the operator played by this test: it reads each
//! prompt, works the simulator's inputs as asked (one limit switch wired to
//! the wrong bit), answers on stdin, and reads the report the binary wrote.

use std::io::{BufRead, BufReader, Write};
use std::process::Stdio;
use std::sync::mpsc;
use std::thread;
use std::time::{Duration, Instant};

use serde_json::Value;

use crate::sim_process;
use sim_process::{SimProcess, WAIT, contains_panic};

/// The simulator's name of the input at `address`, as the test's machine is
/// wired: limit X2's switch is on limit Y1's terminal.
fn wired_to(address: &str) -> Option<&'static str> {
    Some(match address {
        "in3.0" => "limit-x1",
        "in3.1" => "limit-y1",
        "in3.2" => "limit-y1",
        "in1.3" => "start",
        "in1.5" => "probe",
        _ => return None,
    })
}

/// The address in a prompt: `[2/23] limit X1 (in3.0): …`.
fn address(prompt: &str) -> Option<&str> {
    let open = prompt.find(" (")? + 2;
    let close = open + prompt.get(open..)?.find(')')?;
    prompt.get(open..close)
}

#[test]
fn the_walk_test_finds_a_swapped_wire_times_the_estop_and_writes_its_report() {
    let mut sim = SimProcess::start("isel");
    let base = sim.dir.path().join("report");
    let mut child = sim
        .jogterm(&["commission", "--outputs", "--step-s", "20", "--report"])
        .arg(&base)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("jogterm commission");
    let mut answers = child.stdin.take().expect("stdin");
    let stderr = child.stderr.take().expect("stderr");
    let (tx, prompts) = mpsc::channel();
    thread::spawn(move || {
        for line in BufReader::new(stderr).lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let mut said = Vec::new();
    let mut answer = |text: &str| {
        writeln!(answers, "{text}").expect("answer");
        answers.flush().expect("flush");
    };
    let end = Instant::now() + Duration::from_secs(120);
    loop {
        let left = end.saturating_duration_since(Instant::now());
        let Ok(line) = prompts.recv_timeout(left.min(WAIT)) else {
            panic!("commission stopped asking:\n{}", said.join("\n"));
        };
        said.push(line.clone());
        if line.starts_with("jogterm commission: report written") {
            break;
        }
        // The spindle: its feedback input (port 2 bit 0) follows it.
        if line.starts_with("walk: did spindle switch on?") {
            thread::sleep(Duration::from_millis(300));
            answer("y");
            continue;
        }
        let Some(prompt) = line.strip_prefix("walk: [") else {
            continue;
        };
        if prompt.contains("press the emergency stop") {
            sim.control("set estop1 open; after 30 set estop2 open");
            thread::sleep(Duration::from_millis(300));
            sim.control("set estop1 closed; set estop2 closed");
        } else if prompt.contains(" output spindle (out2)") {
            answer("y");
        } else if prompt.contains(" output ") {
            answer("");
        } else if let Some(input) = address(prompt).and_then(wired_to) {
            sim.control(&format!("pulse {input} 300"));
        } else {
            answer("");
        }
    }
    let status = loop {
        if let Ok(Some(s)) = child.try_wait() {
            break s;
        }
        assert!(Instant::now() < end, "commission does not end");
        thread::sleep(Duration::from_millis(20));
    };
    let said = said.join("\n");
    // A finding (the swapped wire): status 1.
    assert_eq!(status.code(), Some(1), "{said}");
    assert!(!contains_panic(said.as_bytes()), "{said}");
    assert!(
        said.contains("walk: limit Y1 (in3.2) moved instead of limit X2 (in3.1)"),
        "{said}"
    );

    let json: Value = serde_json::from_str(
        &std::fs::read_to_string(base.with_extension("json")).expect("the JSON report"),
    )
    .expect("JSON");
    assert_eq!(json["machine"], "isel simulator");
    assert_eq!(json["profile"], "default");
    assert_eq!(json["protocol"], "isel");
    assert!(
        json["date"].as_str().is_some_and(|d| d.ends_with('Z')),
        "{json}"
    );
    assert_eq!(json["complete"], true);
    let input = |address: &str| -> Value {
        json["inputs"]
            .as_array()
            .and_then(|a| a.iter().find(|i| i["address"] == address))
            .cloned()
            .unwrap_or_else(|| panic!("{address} not in the report: {json}"))
    };
    let x1 = input("in3.0");
    assert_eq!(x1["result"], "ok", "{x1}");
    assert_eq!(x1["active_level"], 1);
    let held = x1["held_s"].as_f64().expect("held");
    assert!((held - 0.3).abs() < 0.1, "{x1}");
    let x2 = input("in3.1");
    assert_eq!(x2["result"], "other input moved", "{x2}");
    assert_eq!(x2["moved_instead"], serde_json::json!(["in3.2"]));
    assert_eq!(input("in3.2")["result"], "ok");
    assert_eq!(input("in1.3")["result"], "ok");
    assert_eq!(input("in1.5")["result"], "ok");
    assert_eq!(input("in0.0")["result"], "skipped");
    let estop = &json["estop"];
    for circuit in estop["circuits"].as_array().expect("circuits") {
        assert_eq!(circuit["result"], "ok", "{circuit}");
        assert_eq!(circuit["active_level"], 0, "open = 0: {circuit}");
    }
    let (lo, hi) = (
        estop["open_skew_min_ms"].as_f64().expect("min"),
        estop["open_skew_max_ms"].as_f64().expect("max"),
    );
    assert!(
        lo <= 30.0 && 30.0 <= hi,
        "30 ms outside {lo}..{hi}: {estop}"
    );
    let spindle = json["outputs"]
        .as_array()
        .and_then(|o| o.iter().find(|o| o["address"] == "out2"))
        .expect("the spindle output");
    assert_eq!(spindle["confirmed"], true, "{spindle}");
    assert_eq!(spindle["inputs_followed"], serde_json::json!(["in2.0"]));

    let md = std::fs::read_to_string(base.with_extension("md")).expect("the Markdown report");
    assert!(md.starts_with("# Commissioning report\n"), "{md}");
    assert!(md.contains("- Machine: isel simulator"), "{md}");
    assert!(
        md.contains("- limit X2 (in3.1): other input moved"),
        "the finding is listed:\n{md}"
    );
    assert!(md.contains("Opening skew: "), "{md}");
    assert!(
        md.contains("| spindle | out2 | switched to 1: confirmed | spindle (in2.0) |"),
        "{md}"
    );

    // Nothing moved: the controller was read, and switched only the
    // spindle, on and off again.
    // The stop bytes (closing sends them, as every command does) may come
    // between two bytes of a command (isel manual 2.2.31): they are left
    // out first. The spindle must have been switched off before they came.
    let raw = sim.received();
    assert!(
        raw.contains("@0B2,0<CR>"),
        "the spindle was not switched off (whole, before the closing stop): {raw}"
    );
    let received = raw.replace("<FD>", "").replace("<FF>", "");
    for line in received.split("<CR>").filter(|l| !l.is_empty()) {
        let command = line;
        let moves_nothing = command.is_empty()
            || sim_process::isel_reads_or_moves_nothing(command)
            || command == "@0B2,1"
            || command == "@0B2,0";
        assert!(moves_nothing, "commission sent {command:?}: {received}");
    }
    sim.assert_alive();
}
