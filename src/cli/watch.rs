//! `jogterm watch`: read every input as fast as the line allows and print
//! one line per change, nothing while nothing changes. The changes are the
//! device task's input recorder's (`device::inputs`), the same the console's
//! port timeline draws.

use std::process::ExitCode;
use std::time::Duration;

use clap::Args;

use super::GlobalArgs;
use super::out;
use super::session::{self, EXIT_LINK, Polling, Session};
use crate::device::api::{Event, InputChange, InputSource, LinkState, Recovery};
use crate::device::inputs::{self, Sampling};
use crate::proto::Protocol;

pub const LONG_ABOUT: &str = "\
Read every input of the controller as fast as the line allows and print one line per change
of an input bit, nothing while nothing changes: a limit switch, an E-stop circuit, a key, a
user input. Positions are not read, so the inputs are read as often as the line can carry:
isel ports 1, 3, 2 and 0 (`@0b1` … `@0b0`), the EMCU's `@X` flags, or the switches and
inputs I1-I4 of every EMP drive (`40 01`; --drive 11,21 names the drives on the link).

Each change is timed by the two readings around it: the last one that read the old level
and the first one that read the new level. The input changed in between; `window_ms` is how
long that was. A pulse shorter than the time between two readings may fall between them and
go unseen, a longer one is always seen: once the readings have been timed for a moment, the
command says on stderr how long that is.

An input that changes more often than the profile allows (`[diagnostics] chatter_changes`
within `chatter_ms`, default more than 5 changes in 500 ms) is marked as chattering; when a
second E-stop circuit opens after the first, the skew between them is printed with the range
the two windows allow.

It never moves anything and switches nothing, and sends no stop (it would end a program the
machine runs from its own start key). It runs until interrupted (Ctrl-C) or until the reader of its output goes away
(`| head -5`), then closes cleanly.";

pub const AFTER_LONG_HELP: &str = "\
Output: `limit X1 (in3.0) 1 hit, t 1.234 s, within 20.8 ms` (t: seconds since the link came
up; the level as read, then what it means for the input); `; CHATTER: 6 changes in 100.0 ms`
and `; E-STOP SKEW 34.0 ms after E-stop circuit 1 (between 17.0 ms and 51.0 ms)` are added
when they apply. With --json one object per change:
  {\"active\":true,\"address\":\"in3.0\",\"bit\":0,\"input\":\"limit X1\",\"level\":1,\"port\":3,\"t\":1.234,\"window_ms\":20.8}
`input` is the profile's name of the bit, `address` where it is read: isel `in<port>.<bit>`
(and `port`), EMCU `@X.<flag>` (bit 0 moving, 1 waiting, 2 error, 3 position unknown, 4
referencing, 5 job running), EMP `<drive>.limit+`, `.limit-`, `.ref`, `.I1`-`.I4` (and
`drive`, e.g. \"11\"; bit 0 limit +, 1 limit -, 2 reference, 3-6 I1-I4). `active` says whether
the level is the input's active one (hit, open, pressed). A chattering input adds
\"chatter\":{\"changes\":6,\"within_ms\":100.0}; the second E-stop circuit to open adds
\"estop_skew\":{\"after\":\"E-stop circuit 1\",\"ms\":34.0,\"min_ms\":17.0,\"max_ms\":51.0}.

Names, active levels and what is wired come from the profile (`[io]`, docs/profiles.md).
Without --all, inputs it does not declare wired are left out (by default: isel bits \"not
used\", the hood, power-ok, over-temperature and key-switch bits, limit switches of axes the
machine does not have).

Exit status: 0 done (interrupted, or the reader of its output went away); 1 no input could be
read, or stdout failed otherwise; 2 bad usage; 3 link failure (the port cannot be opened or vanished, a reply did not come, a busy isel answered
nothing within isel.busy_wait_s, the line streams bytes that answer nothing).

Examples:
  jogterm watch --port /dev/ttyUSB0 --protocol isel
  jogterm watch --port /tmp/isel --json | tee inputs.jsonl
  jogterm watch --port /tmp/emp --protocol emp --drive 11,21 --all";

/// Options of `jogterm watch`.
#[derive(Debug, Args)]
pub struct WatchArgs {
    /// Baud rate, instead of the profile's (isel: 19200)
    #[arg(long, value_name = "N")]
    pub baud: Option<u32>,
    /// One JSON object per change
    #[arg(long)]
    pub json: bool,
    /// Also the inputs the profile says are not wired
    #[arg(long)]
    pub all: bool,
    /// EMP: the drives on the link (`11`, `11,21`), for the axes X, Y, Z, A
    #[arg(long, value_name = "DS")]
    pub drive: Vec<String>,
}

/// How long to wait for the first reading of the inputs.
const FIRST_READING: Duration = Duration::from_secs(5);

/// Readings of every input group before the shortest pulse is told: the
/// read-back after connecting has passed by then.
const READINGS_TO_TELL: u64 = 16;

fn ms(d: Duration) -> f64 {
    (d.as_secs_f64() * 10_000.0).round() / 10.0
}

/// One change as a JSON object (see `AFTER_LONG_HELP`).
pub fn change_json(change: &InputChange) -> serde_json::Value {
    let c = &change.channel;
    let mut obj = serde_json::Map::new();
    obj.insert(
        "t".into(),
        serde_json::json!((change.t.as_secs_f64() * 1000.0).round() / 1000.0),
    );
    obj.insert("input".into(), c.name.clone().into());
    obj.insert("address".into(), c.address.clone().into());
    match c.key.source {
        InputSource::IselPort(p) => {
            obj.insert("port".into(), p.into());
        }
        InputSource::EmpDrive(ds) => {
            obj.insert("drive".into(), format!("{ds:02X}").into());
        }
        InputSource::EmcuStatus => {}
    }
    obj.insert("bit".into(), c.key.bit.into());
    obj.insert("level".into(), u8::from(change.level).into());
    obj.insert("active".into(), change.activated().into());
    obj.insert("window_ms".into(), ms(change.window()).into());
    if let Some(ch) = change.chatter {
        obj.insert(
            "chatter".into(),
            serde_json::json!({"changes": ch.changes, "within_ms": ms(ch.within)}),
        );
    }
    if let Some(s) = &change.skew {
        obj.insert(
            "estop_skew".into(),
            serde_json::json!({
                "after": s.first.label(),
                "ms": ms(s.measured),
                "min_ms": ms(s.min),
                "max_ms": ms(s.max),
            }),
        );
    }
    serde_json::Value::Object(obj)
}

/// What the command says about the shortest pulse it can see.
pub fn sampling_text(s: &Sampling) -> String {
    format!(
        "jogterm watch: each input is read at least every {:.1} ms ({} input groups): a pulse \
         shorter than that may be missed, a longer one is always seen",
        ms(s.longest),
        s.groups,
    )
}

fn no_input_hint(family: Protocol) -> &'static str {
    match family {
        Protocol::Isel => "is the controller connected and switched on?",
        Protocol::Emcu => "is the interface connected and switched on?",
        Protocol::Emp => {
            "is the drive switched on? watch switches nothing on (jogterm send --protocol emp \
             '02 11 11 00 00000000')"
        }
    }
}

pub fn run(global: &GlobalArgs, args: &WatchArgs) -> anyhow::Result<ExitCode> {
    let profile = match session::command_profile("watch", global, args.baud, &args.drive) {
        Ok(p) => p,
        Err(ended) => return ended,
    };
    let family = profile.connection.protocol;
    let runtime = session::runtime()?;
    runtime.block_on(async {
        match session::command_session(
            "watch",
            global,
            profile,
            Polling::INPUTS,
            session::Moves::No,
        )
        .await
        {
            Ok(session) => Ok(watch(session, args, family).await),
            Err(ended) => ended,
        }
    })
}

/// Changes until an interrupt, a closed stdout or the link's end.
async fn watch(mut session: Session, args: &WatchArgs, family: Protocol) -> ExitCode {
    out::say("jogterm watch: reading every input as fast as the line allows; Ctrl-C ends");
    let inputs = session.handle.inputs().clone();
    let mut told = false;
    let mut code = 0u8;
    let first_deadline = tokio::time::Instant::now() + FIRST_READING;
    let interrupted = session::interrupted();
    tokio::pin!(interrupted);
    let stdout_gone = out::stdout_gone();
    tokio::pin!(stdout_gone);
    loop {
        let waiting_first = inputs.read(|r| r.sampling()).is_none();
        let first_timeout = async {
            if waiting_first {
                tokio::time::sleep_until(first_deadline).await;
            } else {
                std::future::pending::<()>().await;
            }
        };
        let event = tokio::select! {
            _ = &mut interrupted => break,
            () = &mut stdout_gone => break,
            () = first_timeout => {
                out::say(format_args!(
                    "jogterm watch: no input was read within {} s: {}",
                    FIRST_READING.as_secs(),
                    no_input_hint(family)
                ));
                code = 1;
                break;
            }
            e = session.next_event() => e,
        };
        match event {
            None => {
                code = EXIT_LINK;
                break;
            }
            Some(Event::Link(LinkState::Lost { reason })) => {
                out::say(format_args!(
                    "jogterm watch: link failure: {reason}; {}",
                    Recovery::CheckLink.instruction()
                ));
                code = EXIT_LINK;
                break;
            }
            Some(Event::Io(_)) if !told => {
                if let Some(s) = inputs
                    .read(|r| r.sampling())
                    .filter(|s| s.readings >= READINGS_TO_TELL)
                {
                    out::say(sampling_text(&s));
                    told = true;
                }
            }
            Some(Event::Input(change)) if args.all || change.channel.wired => {
                let text = if args.json {
                    change_json(&change).to_string()
                } else {
                    inputs::describe(&change)
                };
                if let Err(e) = out::line(text) {
                    code = out::stdout_failed(e, "watch", "stopped watching");
                    break;
                }
            }
            Some(Event::Notice(text)) => out::say(format_args!("jogterm watch: {text}")),
            Some(Event::Fault(f)) => out::say(format_args!(
                "jogterm watch: {} answered {}: {}",
                f.command, f.code, f.meaning
            )),
            Some(_) => {}
        }
    }
    session.close().await;
    ExitCode::from(code)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};
    use crate::device::api::{Chatter, EstopSkew};
    use std::sync::Arc;
    use std::time::Instant;

    fn change(profile: &str, address: &str, level: bool) -> InputChange {
        let profile = load_profile(profile, &ConfigDirs::builtin_only()).expect("profile");
        let channel = inputs::channels::shared(&profile)
            .into_iter()
            .find(|c| c.address == address)
            .expect(address);
        let seen = Instant::now();
        InputChange {
            seq: 1,
            channel,
            level,
            seen,
            before: seen - Duration::from_micros(20_830),
            t: Duration::from_millis(1234),
            chatter: None,
            skew: None,
        }
    }

    #[test]
    fn json_has_the_fields_the_help_promises() {
        let c = change("isel", "in3.0", true);
        assert_eq!(
            change_json(&c).to_string(),
            r#"{"active":true,"address":"in3.0","bit":0,"input":"limit X1","level":1,"port":3,"t":1.234,"window_ms":20.8}"#
        );
        let mut e = change("emp", "11.I2", false);
        e.chatter = Some(Chatter {
            changes: 6,
            within: Duration::from_millis(100),
        });
        let json = change_json(&e);
        assert_eq!(json["drive"], "11");
        assert_eq!(json["bit"], 4);
        assert_eq!(json["active"], false);
        assert_eq!(json["chatter"]["changes"], 6);
        assert!(json.get("port").is_none());
        let mut s = change("isel", "in1.1", false);
        s.skew = Some(EstopSkew {
            first: Arc::clone(&change("isel", "in1.0", false).channel),
            measured: Duration::from_millis(34),
            min: Duration::from_millis(17),
            max: Duration::from_millis(51),
        });
        let json = change_json(&s);
        assert_eq!(json["estop_skew"]["after"], "E-stop circuit 1");
        assert_eq!(json["estop_skew"]["ms"], 34.0);
        assert_eq!(
            json["active"], true,
            "an E-stop circuit is active when open"
        );
    }
}
