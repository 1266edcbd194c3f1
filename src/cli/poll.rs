//! `jogterm poll`: read the position (and the ports) as fast as the line
//! allows or at an interval, one line per sample.

use std::collections::BTreeMap;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::Args;

use super::GlobalArgs;
use super::out;
use super::session::{self, EXIT_LINK, Polling, Session};
use crate::axis::Axis;
use crate::device::api::{
    ANSWERS_AGAIN_NOTICE, BUSY_NOTICE, Event, IoSnapshot, LinkState, PositionSample,
    PositionSource, Recovery,
};
use crate::device::common::PollRate;
use crate::proto::Protocol;

pub const LONG_ABOUT: &str = "\
Read the controller's position (isel `@0P`, EMCU `@LX @LY @LZ`) again and again and print one
line per sample, in steps. With --ports the input ports 1 (E-stop circuits, keys), 3 (limit
switches) and 2 (power, hood) of an isel controller (and 0, the user inputs, when the profile's
[io] gives one a role such as probe; a port the controller answers `1` to is left out), or the
`@X` flags of an EMCU interface, are read every cycle too and printed with each sample.

EMP (--protocol emp): every drive's position (`2C`) per cycle, as fast as the line allows
(10.8 ms per drive) or at the interval; with --ports the switches and inputs (`40 01`) of
every drive too. --drive 11,21 names the drives on the link (axes X, Y, Z, A in that order).

The state is read back first (as on every connection); the first sample is that read-back.
Without --count the command runs until interrupted (Ctrl-C) or until the reader of its output
goes away (`| head -5`), then stops and closes cleanly.";

pub const AFTER_LONG_HELP: &str = "\
Output: `t=0.012 X=16000 Y=16000 Z=16000` (t: seconds since the link came up), with --ports
`… in1=03 in3=10 in2=62 active: limit Z1`: the raw bytes, then the wired inputs that are active
(a limit switch hit, an E-stop circuit open, a key pressed …) under the profile's names ([io],
docs/profiles.md); with --json one object per line:
  {\"t\":0.012,\"source\":\"measured\",\"pos\":[16000,16000,16000],\"ports\":{\"1\":3,\"3\":16,\"2\":98},\"active\":[\"limit Z1\"]}
pos has one entry per axis of the machine (X, Y, Z, A as far as it has them; EMP: one per
drive), in steps, as the controller reports them. EMCU with --ports: `… status=08`,
{\"status\":8}: the `@X` flags as a byte, bit 0 moving, 1 waiting, 2 error, 3 position
unknown, 4 referencing, 5 job running. EMP with --ports: `… drive11=05`, {\"drive11\":5}:
inputs I1-I4 of drive 11 as bits 0-3.

Exit status: 0 done (also when interrupted, or when the reader of its output goes away as
`| head -1` does: it stops and closes first); 1 no position could be read, or stdout failed
otherwise (a hung-up terminal); 2 bad usage; 3 link failure (the port cannot be opened or vanished, a reply did not come, a busy isel answered
nothing within isel.busy_wait_s, the line streams bytes that answer nothing).

Examples:
  jogterm poll --port /dev/ttyUSB0 --protocol isel --count 5
  jogterm poll --port /tmp/isel --interval-ms 0 --json --ports
  jogterm poll --port /tmp/emcu --protocol emcu --interval-ms 0 --count 100
  jogterm poll --port /tmp/emp --protocol emp --drive 11 --interval-ms 0 --count 100";

/// Options of `jogterm poll`.
#[derive(Debug, Args)]
pub struct PollArgs {
    /// Baud rate, instead of the profile's (isel: 19200)
    #[arg(long, value_name = "N")]
    pub baud: Option<u32>,
    /// Stop after N samples
    #[arg(long, value_name = "N")]
    pub count: Option<u64>,
    /// Time between samples; 0 = as fast as the line allows
    #[arg(long, value_name = "M", default_value_t = 100)]
    pub interval_ms: u64,
    /// One JSON object per line
    #[arg(long)]
    pub json: bool,
    /// Read and print the input ports 1, 3, 2 every cycle (EMP: every drive's inputs)
    #[arg(long)]
    pub ports: bool,
    /// EMP: the drives on the link (`11`, `11,21`), for the axes X, Y, Z, A
    #[arg(long, value_name = "DS")]
    pub drive: Vec<String>,
}

/// One line of output.
pub fn format_sample(
    sample: &PositionSample,
    t: f64,
    ports: Option<&IoSnapshot>,
    json: bool,
) -> String {
    let axes: Vec<Axis> = Axis::ALL
        .into_iter()
        .filter(|a| sample.steps.get(*a).is_some())
        .collect();
    let pos: Vec<i64> = axes
        .iter()
        .map(|a| sample.steps.get(*a).unwrap_or(0))
        .collect();
    let port_values: Vec<(String, u8)> = ports
        .map(|io| {
            io.groups
                .iter()
                .filter_map(|g| Some((port_key(&g.name)?, g.raw?)))
                .collect()
        })
        .unwrap_or_default();
    let active = ports.map(active_inputs).unwrap_or_default();
    let source = match sample.source {
        PositionSource::Measured => "measured",
        PositionSource::Estimated => "estimated",
    };
    if json {
        let mut obj = serde_json::Map::new();
        obj.insert("t".into(), serde_json::json!((t * 1000.0).round() / 1000.0));
        obj.insert("source".into(), source.into());
        obj.insert("pos".into(), serde_json::json!(pos));
        if ports.is_some() {
            let map: BTreeMap<String, u8> = port_values.iter().cloned().collect();
            obj.insert("ports".into(), serde_json::json!(map));
            obj.insert("active".into(), serde_json::json!(active));
        }
        serde_json::Value::Object(obj).to_string()
    } else {
        let mut line = format!("t={t:.3}");
        for (a, v) in axes.iter().zip(&pos) {
            line.push_str(&format!(" {a}={v}"));
        }
        if sample.source == PositionSource::Estimated {
            line.push_str(" (estimated)");
        }
        for (key, v) in &port_values {
            if key.bytes().all(|b| b.is_ascii_digit()) {
                line.push_str(&format!(" in{key}={v:02X}"));
            } else {
                line.push_str(&format!(" {key}={v:02X}"));
            }
        }
        if !active.is_empty() {
            line.push_str(&format!(" active: {}", active.join(", ")));
        }
        line
    }
}

/// The wired inputs that read active, under the profile's names
/// (`crate::wiring`: a limit switch hit, an E-stop open, a key pressed …).
fn active_inputs(io: &IoSnapshot) -> Vec<String> {
    io.groups
        .iter()
        .flat_map(|g| &g.bits)
        .filter(|b| b.output.is_none() && b.wiring.is_some() && b.wired() && b.active())
        .filter(|b| {
            b.wiring
                .as_ref()
                .is_some_and(|w| w.role != crate::wiring::Role::Unused)
        })
        .map(|b| b.name.clone())
        .collect()
}

/// How a port group is keyed in the output: isel input ports by number
/// (`in 3: limit switches` -> `3`; port 0 when the profile has it read), the EMCU status group
/// by name (`status: @X flags` -> `status`), EMP drives by address
/// (`drive 11 (X)` -> `drive11`).
fn port_key(group: &str) -> Option<String> {
    let head = group.split(':').next()?.trim();
    if let Some(n) = head.strip_prefix("in ") {
        return n.parse::<u8>().ok().map(|n| n.to_string());
    }
    if head == "status" {
        return Some(head.to_owned());
    }
    let ds = head.strip_prefix("drive ")?.split(' ').next()?;
    Some(format!("drive{ds}"))
}

/// Why no position may come, in the family's terms.
fn no_position_hint(family: Protocol) -> &'static str {
    match family {
        Protocol::Isel => "is the controller initialised (jogterm send '@07')?",
        Protocol::Emp => {
            "is the drive switched on (jogterm send --protocol emp '02 11 11 00 00000000') and connected?"
        }
        Protocol::Emcu => "is the controller connected and switched on?",
    }
}

pub fn run(global: &GlobalArgs, args: &PollArgs) -> anyhow::Result<ExitCode> {
    let profile = match session::command_profile("poll", global, args.baud, &args.drive) {
        Ok(p) => p,
        Err(ended) => return ended,
    };
    let rate = match args.interval_ms {
        0 => PollRate::LineSpeed,
        ms => PollRate::Hz(1000.0 / ms as f64),
    };
    let polling = Polling {
        rate,
        ports: args.ports,
        positions: true,
    };
    let family = profile.connection.protocol;
    let runtime = session::runtime()?;
    runtime.block_on(async {
        match session::command_session("poll", global, profile, polling, session::Moves::No).await {
            Ok(session) => Ok(poll(session, args, family).await),
            Err(ended) => ended,
        }
    })
}

/// Samples until the count, an interrupt, a closed stdout or the link's end.
async fn poll(mut session: Session, args: &PollArgs, family: Protocol) -> ExitCode {
    let start = Instant::now();
    // With a real isel controller that has no axes `@0P` answers `4`: give
    // up when no position has come for a while.
    let patience =
        Duration::from_millis(args.interval_ms.saturating_mul(5)).max(Duration::from_secs(3));
    let mut samples = 0u64;
    let mut last_position = Instant::now();
    let mut ports: Option<IoSnapshot> = None;
    let mut code = 0u8;
    // The controller does not answer because a program or a move runs: wait
    // without giving up (`docs/device.md`, "Sessions that do not move").
    let mut busy = false;
    let interrupted = session::interrupted();
    tokio::pin!(interrupted);
    let stdout_gone = out::stdout_gone();
    tokio::pin!(stdout_gone);
    loop {
        if args.count.is_some_and(|n| samples >= n) {
            break;
        }
        // Patience counts from the last position, not the last event: a
        // controller that rejects every poll still produces traffic.
        let left = patience.saturating_sub(last_position.elapsed());
        let event = tokio::select! {
            _ = &mut interrupted => break,
            // As a sample stdout cannot take (`stdout_failed`): status 0.
            () = &mut stdout_gone => break,
            e = tokio::time::timeout(left, session.next_event()) => e,
        };
        match event {
            Err(_) if busy => last_position = Instant::now(),
            Err(_) => {
                out::say(format_args!(
                    "jogterm poll: no position for {} s: {}",
                    patience.as_secs(),
                    no_position_hint(family)
                ));
                code = 1;
                break;
            }
            Ok(None) => {
                code = EXIT_LINK;
                break;
            }
            Ok(Some(Event::Link(LinkState::Lost { reason }))) => {
                // What happened and what to do: the line, not the machine, is in doubt.
                out::say(format_args!(
                    "jogterm poll: link failure: {reason}; {}",
                    Recovery::CheckLink.instruction()
                ));
                code = EXIT_LINK;
                break;
            }
            Ok(Some(Event::Notice(text))) if text.starts_with(BUSY_NOTICE) => {
                busy = true;
                out::say(format_args!("jogterm poll: {text}"));
            }
            Ok(Some(Event::Notice(text))) if text.starts_with(ANSWERS_AGAIN_NOTICE) => {
                busy = false;
                last_position = Instant::now();
                out::say(format_args!("jogterm poll: {text}"));
            }
            Ok(Some(Event::Io(io))) => ports = Some(io),
            // With --ports every line has them: the read-back's position,
            // which comes before the ports are read, is left out.
            Ok(Some(Event::Position(_))) if args.ports && ports.is_none() => {}
            Ok(Some(Event::Position(p))) => {
                last_position = Instant::now();
                let t = p.at.saturating_duration_since(start).as_secs_f64();
                let io = if args.ports { ports.as_ref() } else { None };
                if let Err(e) = out::line(format_sample(&p, t, io, args.json)) {
                    code = out::stdout_failed(e, "poll", "stopped polling");
                    break;
                }
                samples += 1;
            }
            Ok(Some(_)) => {}
        }
    }
    session.close().await;
    ExitCode::from(code)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::api::PerAxis;
    use crate::device::isel::input_group;
    use crate::proto::isel::InputPort;

    fn sample() -> PositionSample {
        PositionSample {
            at: Instant::now(),
            steps: PerAxis::new()
                .with(Axis::X, 256)
                .with(Axis::Y, 131_087)
                .with(Axis::Z, -2),
            source: PositionSource::Measured,
        }
    }

    #[test]
    fn samples_as_text_and_json() {
        let wiring =
            crate::wiring::Wiring::defaults(Protocol::Isel, crate::axis::AxisSet::XYZ, &[]);
        let io = IoSnapshot {
            at: Instant::now(),
            groups: vec![
                input_group(InputPort::Status1, 0x03, &wiring),
                input_group(InputPort::LimitSwitches, 0x10, &wiring),
            ],
        };
        assert_eq!(
            format_sample(&sample(), 0.25, None, false),
            "t=0.250 X=256 Y=131087 Z=-2"
        );
        assert_eq!(
            format_sample(&sample(), 0.25, Some(&io), false),
            "t=0.250 X=256 Y=131087 Z=-2 in1=03 in3=10 active: limit Z1"
        );
        let json: serde_json::Value =
            serde_json::from_str(&format_sample(&sample(), 1.5, Some(&io), true)).expect("json");
        assert_eq!(json["pos"], serde_json::json!([256, 131087, -2]));
        assert_eq!(json["t"], serde_json::json!(1.5));
        assert_eq!(json["source"], "measured");
        assert_eq!(json["ports"], serde_json::json!({"1": 3, "3": 16}));
        assert_eq!(json["active"], serde_json::json!(["limit Z1"]));
    }

    #[test]
    fn emcu_samples_have_the_machines_axes_and_the_status_byte() {
        use crate::device::emcu::status_group;
        use crate::proto::emcu::Status;
        let xy = PositionSample {
            at: Instant::now(),
            steps: PerAxis::new().with(Axis::X, 12).with(Axis::Y, -3),
            source: PositionSource::Measured,
        };
        let status = Status {
            position_unknown: true,
            ..Status::default()
        };
        let io = IoSnapshot {
            at: Instant::now(),
            groups: vec![status_group(&status)],
        };
        assert_eq!(
            format_sample(&xy, 0.5, Some(&io), false),
            "t=0.500 X=12 Y=-3 status=08"
        );
        let json: serde_json::Value =
            serde_json::from_str(&format_sample(&xy, 0.5, Some(&io), true)).expect("json");
        assert_eq!(json["pos"], serde_json::json!([12, -3]));
        assert_eq!(json["ports"], serde_json::json!({"status": 8}));
    }
}
