//! End to end: `jogterm watch` against the real `jogterm sim --pty`, whose
//! inputs are pulsed, made to chatter and opened with a skew from its
//! control language; and the device task's input recorder, fed the same way.

use std::io::{BufRead, BufReader};
use std::process::{Child, ExitStatus, Stdio};
use std::sync::mpsc::{self, Receiver};
use std::thread;
use std::time::{Duration, Instant};

use serde_json::Value;

use crate::sim_process;
use sim_process::{SimProcess, WAIT, contains_panic};

/// A running `jogterm watch`, its stdout and stderr line by line.
struct Watch {
    child: Child,
    out: Receiver<String>,
    err: Receiver<String>,
    said: Vec<String>,
}

fn lines_of(pipe: impl std::io::Read + Send + 'static) -> Receiver<String> {
    let (tx, rx) = mpsc::channel();
    thread::spawn(move || {
        for line in BufReader::new(pipe).lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    rx
}

impl Watch {
    fn start(sim: &SimProcess, args: &[&str]) -> Watch {
        let mut all = vec!["watch"];
        all.extend_from_slice(args);
        let mut child = sim
            .jogterm(&all)
            // The profiles the simulator was started with.
            .env("JOGTERM_CONFIG_DIR", sim.dir.path())
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("jogterm watch");
        let out = lines_of(child.stdout.take().expect("stdout"));
        let err = lines_of(child.stderr.take().expect("stderr"));
        Watch {
            child,
            out,
            err,
            said: Vec::new(),
        }
    }

    /// Wait for the line on stderr that tells the shortest pulse; the
    /// interval in ms.
    fn sampling_ms(&mut self) -> f64 {
        let end = Instant::now() + WAIT;
        while let Some(left) = end.checked_duration_since(Instant::now()) {
            let Ok(line) = self.err.recv_timeout(left) else {
                break;
            };
            self.said.push(line.clone());
            if let Some(rest) = line.split("read at least every ").nth(1) {
                let ms = rest.split(" ms").next().unwrap_or_default();
                return ms.parse().expect("a time in ms");
            }
        }
        panic!("watch never told its shortest pulse: {:?}", self.said);
    }

    fn next_json(&self, what: &str) -> Value {
        match self.out.recv_timeout(WAIT) {
            Ok(line) => serde_json::from_str(&line).unwrap_or_else(|e| panic!("{line}: {e}")),
            Err(_) => panic!("no change for {what} within {WAIT:?}"),
        }
    }

    /// What came on stdout within `d`.
    fn quiet_for(&self, d: Duration) -> Vec<String> {
        thread::sleep(d);
        self.out.try_iter().collect()
    }

    /// Ctrl-C: the exit status and the rest of stderr.
    fn interrupt(mut self) -> (ExitStatus, String) {
        // SAFETY: kill(2) on our own child's pid.
        unsafe {
            libc::kill(self.child.id() as libc::pid_t, libc::SIGINT);
        }
        let end = Instant::now() + WAIT;
        let status = loop {
            if let Ok(Some(s)) = self.child.try_wait() {
                break s;
            }
            assert!(Instant::now() < end, "watch does not end on Ctrl-C");
            thread::sleep(Duration::from_millis(20));
        };
        let mut said = self.said.join("\n");
        for line in self.err.try_iter() {
            said.push('\n');
            said.push_str(&line);
        }
        (status, said)
    }
}

fn secs(v: &Value, key: &str) -> f64 {
    v[key].as_f64().unwrap_or_else(|| panic!("{key} in {v}"))
}

#[test]
fn a_one_second_pulse_of_limit_x1_is_one_second_within_one_window() {
    let mut sim = SimProcess::start("isel");
    let mut watch = Watch::start(&sim, &["--json"]);
    let sampling = watch.sampling_ms();
    assert!(
        watch.quiet_for(Duration::from_millis(300)).is_empty(),
        "nothing while nothing changes"
    );
    sim.control("pulse limit-x1 1000");
    let on = watch.next_json("limit X1 hit");
    let off = watch.next_json("limit X1 free");
    for (v, level) in [(&on, 1), (&off, 0)] {
        assert_eq!(v["input"], "limit X1", "{v}");
        assert_eq!(v["address"], "in3.0");
        assert_eq!((v["port"].as_u64(), v["bit"].as_u64()), (Some(3), Some(0)));
        assert_eq!(v["level"], level, "{v}");
    }
    let measured = secs(&off, "t") - secs(&on, "t");
    let window = secs(&on, "window_ms").max(secs(&off, "window_ms")) / 1000.0;
    // t is rounded to the millisecond.
    assert!(
        (measured - 1.0).abs() <= window + 0.001,
        "pulse measured {measured} s, windows {on} {off}"
    );
    // Neither the interval told nor a window can beat the line: one reading
    // of the four ports is 4 x 8 bytes, 16.7 ms at 19200 baud. (Upper
    // bounds depend on the machine's load and are not checked here.)
    let cycle_ms = 32.0 * 10.0 / 19.2;
    assert!(sampling >= cycle_ms - 0.1, "told {sampling} ms");
    for v in [&on, &off] {
        assert!(secs(v, "window_ms") >= cycle_ms - 0.1, "{v}");
    }
    assert!(watch.quiet_for(Duration::from_millis(200)).is_empty());
    let (status, said) = watch.interrupt();
    assert!(status.success(), "{status:?}: {said}");
    assert!(!contains_panic(said.as_bytes()), "{said}");
    // The shortest pulse, and nothing moved: only reads went out.
    assert!(
        said.contains("a pulse shorter than that may be missed"),
        "{said}"
    );
    let received = sim.received();
    for line in received.split("<CR>").filter(|l| !l.is_empty()) {
        // The closing stop's control bytes may land between any two bytes
        // of a read on its way: the controller takes them in its receive
        // interrupt, apart from the command (isel manual 2.2.31).
        let command = line.replace("<FD>", "").replace("<FF>", "");
        let command = command.as_str();
        assert!(
            command.is_empty() || sim_process::isel_reads_or_moves_nothing(command),
            "watch sent {command:?}: {received}"
        );
    }
}

/// The default profile with a chatter window long enough that the flips
/// can be far apart: 250 ms between two is far more than a loaded machine
/// delays a reading, so none falls between two readings.
const SLOW_CHATTER: &str =
    "base = \"default\"\n\n[diagnostics]\nchatter_changes = 5\nchatter_ms = 3000\n";

#[test]
fn chatter_and_a_30_ms_estop_skew_are_reported_as_such() {
    let mut sim = SimProcess::start_with_files("isel", &[("profiles/slow.toml", SLOW_CHATTER)]);
    let mut watch = Watch::start(&sim, &["--json", "--profile", "slow"]);
    watch.sampling_ms();
    sim.control("chatter in0.3 10 250");
    let mut flagged = None;
    for i in 0..10 {
        let v = watch.next_json(&format!("flip {i} of user input 3"));
        assert_eq!(v["input"], "user input 3", "{v}");
        assert_eq!(v["level"], if i % 2 == 0 { 1 } else { 0 }, "flip {i}: {v}");
        if flagged.is_none() && v.get("chatter").is_some() {
            flagged = Some((i, v));
        }
    }
    let (i, v) = flagged.expect("chatter reported");
    assert_eq!(
        i, 5,
        "the sixth change within 3 s (the profile's window) is the first to chatter: {v}"
    );
    assert!(v["chatter"]["changes"].as_u64() > Some(5), "{v}");

    sim.control("set estop1 open; after 30 set estop2 open");
    let first = watch.next_json("E-stop circuit 1 open");
    assert_eq!(first["input"], "E-stop circuit 1", "{first}");
    assert_eq!(
        (first["level"].as_u64(), first["active"].as_bool()),
        (Some(0), Some(true))
    );
    assert!(first.get("estop_skew").is_none());
    let second = watch.next_json("E-stop circuit 2 open");
    assert_eq!(second["input"], "E-stop circuit 2", "{second}");
    let skew = &second["estop_skew"];
    assert_eq!(skew["after"], "E-stop circuit 1", "{second}");
    let (ms, min, max) = (secs(skew, "ms"), secs(skew, "min_ms"), secs(skew, "max_ms"));
    assert!(
        min <= 30.0 && 30.0 <= max,
        "30 ms outside {min}..{max}: {second}"
    );
    let window = secs(&first, "window_ms").max(secs(&second, "window_ms"));
    assert!(
        (ms - 30.0).abs() <= window + 0.1,
        "skew {ms} ms, window {window} ms"
    );

    sim.control("set estop1 closed; set estop2 closed");
    for _ in 0..2 {
        let v = watch.next_json("an E-stop circuit closed");
        assert_eq!(v["active"], false, "{v}");
        assert!(v.get("estop_skew").is_none(), "closing is no skew: {v}");
    }
    let (status, said) = watch.interrupt();
    assert!(status.success(), "{status:?}: {said}");
}

#[test]
fn text_lines_name_the_input_and_a_closed_stdout_ends_cleanly() {
    let mut sim = SimProcess::start("isel");
    let mut watch = Watch::start(&sim, &[]);
    watch.sampling_ms();
    sim.control("pulse stop 300");
    let line = watch.out.recv_timeout(WAIT).expect("a change");
    assert!(line.starts_with("stop key (in1.4) 1 pressed, t "), "{line}");
    // The reader goes away (its thread ends at the release's line, which
    // it can no longer hand on, and closes the pipe): watch stops and
    // closes, status 0.
    drop(watch.out);
    let end = Instant::now() + WAIT;
    let status = loop {
        if let Ok(Some(s)) = watch.child.try_wait() {
            break s;
        }
        assert!(
            Instant::now() < end,
            "watch does not end when its reader has gone"
        );
        thread::sleep(Duration::from_millis(20));
    };
    assert!(status.success(), "{status:?}");
}

#[test]
fn the_recorder_of_the_device_task_times_the_pulse_as_well() {
    use jogterm::config::{ConfigDirs, load_profile};
    use jogterm::device::{TaskOptions, spawn};
    use jogterm::transport::PortSpec;
    use jogterm::wire::LineSettings;

    let mut sim = SimProcess::start("isel");
    let profile = load_profile("isel", &ConfigDirs::builtin_only()).expect("profile");
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .expect("runtime");
    runtime.block_on(async {
        // The console's polling: positions, and the ports every 4th cycle.
        let spec = PortSpec::Serial {
            path: sim.link.clone(),
            line: LineSettings::new(19_200),
        };
        let (handle, mut events) = spawn(&profile, spec, TaskOptions::default()).expect("task");
        // Readings must have started before the pulse.
        let start = Instant::now();
        while handle.inputs().read(|r| r.sampling()).is_none() {
            assert!(start.elapsed() < WAIT, "no readings");
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
        sim.control("pulse limit-x1 1000");
        let on = next_input(&mut events).await;
        let off = next_input(&mut events).await;
        assert_eq!((on.channel.name.as_str(), on.level), ("limit X1", true));
        assert_eq!((off.channel.name.as_str(), off.level), ("limit X1", false));
        let measured = off.seen - on.seen;
        let window = on.window().max(off.window());
        let error = measured.abs_diff(Duration::from_secs(1));
        assert!(error <= window, "measured {measured:?}, window {window:?}");
        // It keeps both, for a client that asks later.
        let kept = handle.inputs().read(|r| r.history().count(on.channel.key));
        assert_eq!(kept, 2);
        handle.shutdown().await;
    });
}

async fn next_input(
    events: &mut jogterm::device::EventReceiver,
) -> jogterm::device::api::InputChange {
    use jogterm::device::api::{Event, LinkState};
    let deadline = tokio::time::Instant::now() + WAIT;
    loop {
        match tokio::time::timeout_at(deadline, events.recv()).await {
            Ok(Some(Event::Input(c))) => return c,
            Ok(Some(Event::Link(LinkState::Lost { reason }))) => panic!("link lost: {reason}"),
            Ok(Some(_)) => {}
            Ok(None) | Err(_) => panic!("no input change within {WAIT:?}"),
        }
    }
}
