//! The simulator's time scale (`sim::timescale`, `jogterm sim
//! --time-scale`): the model's time, the modelled wire and timed controls
//! run that many times faster than the wall clock, consistently, and what
//! goes over the line is the same as at real time.
//!
//! The bounds here check the scale, not the machine's speed: a 3 s model
//! delay at scale 30 is 0.1 s of wall time, so a bound of half the unscaled
//! time holds under any load the other tests survive, and the lower bounds
//! (never sooner than the scaled time) hold always.

use std::io::Write;
use std::time::{Duration, Instant};

use jogterm::sim::shell::serve_socket_scaled;
use jogterm::sim::timescale::TimeScale;
use jogterm::sim::{Timed, TimedControl};

use crate::sim_process::{self, SimProcess, text};
use crate::sim_shell_support::{
    LineAnswerer, REPLY, REQUEST, byte_time, read_exact_within, wait_for_show,
};

fn scale(factor: f64) -> TimeScale {
    TimeScale::new(factor).expect("a valid scale")
}

#[test]
fn a_scaled_shell_answers_a_delayed_reply_that_many_times_sooner_and_whole() {
    let delay = Duration::from_secs(3);
    let (device, arrivals) = LineAnswerer::new(19200, delay);
    let (shell, mut client) = serve_socket_scaled(Box::new(device), scale(30.0)).expect("serve");
    client
        .set_read_timeout(Some(Duration::from_millis(50)))
        .expect("timeout");
    for cycle in 0..3 {
        let sent = Instant::now();
        client.write_all(b"0123456789\r").expect("write");
        let reply = read_exact_within(&mut client, REPLY.len(), delay);
        let took = sent.elapsed();
        assert_eq!(reply, REPLY, "cycle {cycle}: the reply whole and in order");
        // 3 s of model delay is 100 ms of wall time: never sooner, and far
        // sooner than the unscaled 3 s.
        assert!(
            took >= delay / 30 && took < delay / 2,
            "cycle {cycle}: {took:?}"
        );
    }
    // The device saw the bytes one *model* byte time apart, in order: the
    // receive side runs on the same model clock.
    let got = arrivals.lock().unwrap().clone();
    assert_eq!(got.len(), 33);
    assert_eq!(
        got.iter().take(11).map(|&(b, _)| b).collect::<Vec<_>>(),
        b"0123456789\r"
    );
    for line in got.chunks(11) {
        for pair in line.windows(2) {
            assert_eq!(
                pair[1].1 - pair[0].1,
                byte_time(19200),
                "one byte time apart"
            );
        }
    }
    shell.shutdown();
}

#[test]
fn a_scaled_shell_runs_timed_controls_on_model_time() {
    let (shell, mut client) =
        serve_socket_scaled(LineAnswerer::boxed(19200), scale(40.0)).expect("serve");
    let control = shell.control();
    let started = Instant::now();
    // Opened for 20 s of model time: 500 ms of wall time, room for the
    // `show` right behind it on a loaded machine.
    control
        .timed(vec![TimedControl {
            delay: Duration::ZERO,
            what: Timed::Pulse {
                name: "hood".into(),
                hold: Duration::from_secs(20),
            },
        }])
        .expect("pulse");
    assert!(control.show().expect("show").contains("hood=0"));
    wait_for_show(&control, "hood=1");
    let took = started.elapsed();
    assert!(
        took >= Duration::from_millis(500) && took < Duration::from_secs(10),
        "{took:?}"
    );
    // `show` says the line runs on a scale.
    assert!(
        control
            .show()
            .expect("show")
            .contains("time scale 40 (the model runs 40 times the wall clock)"),
        "{}",
        control.show().expect("show")
    );
    client
        .set_read_timeout(Some(Duration::from_millis(50)))
        .expect("timeout");
    client.write_all(REQUEST).expect("write");
    assert_eq!(
        read_exact_within(&mut client, REPLY.len(), Duration::from_secs(2)),
        REPLY
    );
    shell.shutdown();
}

#[test]
fn jogterm_sim_takes_a_time_scale_in_range_only() {
    for bad in ["0", "-1", "5000", "fast"] {
        let out = std::process::Command::new(sim_process::JOGTERM)
            .args(["sim", "--protocol", "isel", "--pty"])
            .arg(format!("--time-scale={bad}"))
            .env("JOGTERM_CONFIG_DIR", "/nonexistent-jogterm-config")
            .stdin(std::process::Stdio::null())
            .output()
            .expect("run jogterm sim");
        assert_eq!(out.status.code(), Some(2), "--time-scale {bad}");
        assert!(
            text(&out.stderr).contains("a time scale is"),
            "--time-scale {bad}: {}",
            text(&out.stderr)
        );
    }
}

/// The isel simulator at scale 50: a reference run from the default start
/// position (40 mm) and a 20 s move (20000 steps at 1000 Hz) take well under
/// half of the move's 20 s, never less than its 0.4 s, and end exactly where
/// they do at real time.
#[test]
fn an_isel_move_on_a_scaled_simulator_ends_where_it_would_sooner() {
    let mut sim = SimProcess::options("isel").time_scale(50.0).start();
    assert!(
        sim.device_state().starts_with("device: "),
        "the simulator answers its controls"
    );
    let started = Instant::now();
    let out = sim.run(&[
        "send",
        "@07",
        "@0R7",
        "@0A 20000,1000,-300,900,0,900,0,900",
        "@0P",
    ]);
    let took = started.elapsed();
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    assert!(
        stdout.contains("<< 0 X=20000 Y=-300 Z=0 (steps)"),
        "{stdout}"
    );
    let motion = Duration::from_secs(20);
    assert!(took < motion / 2, "{took:?} for {motion:?} of motion");
    assert!(
        took >= motion.div_f64(sim.time_scale),
        "{took:?}: sooner than the scale allows"
    );
    sim.assert_alive();
}
