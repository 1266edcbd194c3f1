//! `jogterm send`: send isel or EMCU commands one by one through the device
//! task and print each reply decoded.

use std::process::ExitCode;
use std::time::Duration;

use clap::Args;

use super::out::{self, StdoutError};
use super::session::{self, EXIT_LINK, EXIT_USAGE, Linked, Moves, Polling, Session, StartError};
use super::{GlobalArgs, emp};
use crate::config::Profile;
use crate::device::api::{
    ANSWERS_AGAIN_NOTICE, Activity, BUSY_NOTICE, Event, LinkState, Recovery, Refusal, ReplyKind,
    Request,
};
use crate::device::describe::describe;
use crate::device::emcu::{RUN_MARK, RawKind, parse_raw};
use crate::proto::Protocol;
use crate::proto::emcu::{Command as EmcuCommand, Terminator};
use crate::proto::isel::{
    AxisConfig, Command, ControlByte, ReplyCode, check, check_cnc, parse_cnc, parse_frame,
};
use crate::traffic::readable;

pub const LONG_ABOUT: &str = "\
Send isel @-format commands to a controller one by one and print each reply decoded:
positions in steps, port bits by name, an error code with its meaning and what to do.

Every command is checked before anything is sent (the whole list): a line the controller
would refuse is bad usage. Lines after `@0i` are stored program lines (CNC commands such as
`0100,900` or `9`) until `9`. Before the commands jogterm reads the controller's state back;
a list with a command that may move opens and closes its connection with the stop sequence
0xFD 0xFF; a list of lines that move nothing sends no stop and nothing but reads of its own
(docs/device.md, \"Sessions that only read\").

Control bytes act at once, also during a move, and have no reply. Write them as
`\\xFD`, `0xFD` or by name: `softstop` (0xFD: ramp down, the rest can be resumed with @0S),
`break` (0xFF: ramp down and forget the rest), `reset` (0xFE: the controller forgets its axes
and reference). A control byte right after a move goes out while the move runs.

EMCU (--protocol emcu): every line is checked with jogterm's EMCU parser first (the interface
itself acknowledges bad lines and only sets its error flag). End a line with `\\x01` to run the
data memory (`#E1,800` `L1,x500\\x01`). The queries `@X`, `@LX`, `@LY`, `@LZ`, `@V` and the
stops `@B` (ramp, positions kept) and `@S` (at once, positions lost) go out at once, also while
a batch runs; any other line waits until the batch before it has ended, and the command ends
when the last batch has.

EMP (--protocol emp): every command is a frame of 16 hex characters, spaces allowed
(`2C 11 00 00 00000000`), or 14 without the drive byte, which --drive then supplies (default:
the profile's first drive). Frames are checked with jogterm's EMP parser first. A long action
(`26` homing, `2A 01` positioning) prints its `55` answer (`started: …`) and then waits for its
completion. The stops `08` and `2A 03` go out at once.";

pub const AFTER_LONG_HELP: &str = "\
Exit status: 0 every command answered `0`; 1 the controller answered an error (the rest is
not sent) or refused for its state (E-stop, fault), or interrupted (Ctrl-C, SIGTERM, a
hang-up: the machine is stopped first), or stdout closed or failed (`| head -1`: a command in
flight is answered, nothing more is sent, the machine is stopped); 2 bad usage (a command that would be refused, an
unknown option, a --baud outside 300 to 4000000); 3 link failure (the port cannot be opened
or vanished, a reply did not come, a busy isel answered nothing within isel.busy_wait_s, the
line streams bytes that answer nothing).

Examples:
  jogterm send --port /dev/ttyUSB0 --protocol isel '@07' '@0R7' '@0P'
  jogterm send --port /tmp/isel '@0A 4000,2000,0,900,0,900,0,900' softstop
  jogterm --sim isel send '@07' '@0N7' '@0i' '0400,900,0,900,0,900,0,900' '9' '@0S'
  jogterm send --port /tmp/isel --log traffic.log '@0b1' '@0b3'
  jogterm send --port /tmp/emcu --protocol emcu '#S200' '#R500\\x01' '$HZYX\\x01' '@X'
  jogterm send --port /tmp/emcu --protocol emcu '#E1,1000' 'L1,x4000\\x01' '@LX' '@B'
  jogterm send --port /tmp/emp --protocol emp '02 11 11 00 00000000' '22 11 07 00 00000000'
  jogterm send --port /tmp/emp --protocol emp --drive 11 '26 00 00 00140400' '2C 00 00 00000000'";

/// Options of `jogterm send`.
#[derive(Debug, Args)]
pub struct SendArgs {
    /// Baud rate, instead of the profile's (isel: 19200)
    #[arg(long, value_name = "N")]
    pub baud: Option<u32>,
    /// EMP: the drives on the link (`11`, `11,21`), for the axes X, Y, Z, A; the first
    /// is the drive of frames typed without one
    #[arg(long, value_name = "DS")]
    pub drive: Vec<String>,
    /// The commands, in order: `@0P`, program lines after `@0i`, control bytes; EMP frames
    #[arg(required = true, value_name = "CMD")]
    pub commands: Vec<String>,
}

/// One thing to send.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Item {
    Line {
        text: String,
        /// How the driver names it in its events (`@0A5000,900`).
        canonical: String,
        may_move: bool,
    },
    Control(ControlByte),
    /// Wait until what runs has ended (EMCU: a batch or job).
    AwaitIdle,
}

/// The plan for the profile's family.
pub fn plan_for(profile: &Profile, args: &[String]) -> Result<Vec<Item>, String> {
    match profile.connection.protocol {
        Protocol::Isel => plan(args),
        Protocol::Emcu => emcu_plan(args),
        Protocol::Emp => emp::plan(args, emp::default_drive(profile)),
    }
}

/// EMCU: every line checked with the driver's parser; a line that is no
/// query or stop waits for the batch before it, and the last batch is
/// awaited at the end (closing the link stops what still runs).
pub fn emcu_plan(args: &[String]) -> Result<Vec<Item>, String> {
    let mut items = Vec::with_capacity(args.len() + 1);
    // After `@F` the buffered lines are the job's (the interface runs none
    // of them) until the one ended by 0x01 (decision 2).
    let mut storing = false;
    for (i, arg) in args.iter().enumerate() {
        let text = match arg.strip_suffix("\\x01") {
            Some(head) => format!("{head}{RUN_MARK}"),
            None => arg.clone(),
        };
        let line = parse_raw(&text).map_err(|e| format!("command {} `{arg}`: {e}", i + 1))?;
        let job_line = storing && !line.command.is_master();
        if line.kind() == RawKind::Other && !job_line {
            items.push(Item::AwaitIdle);
        }
        match line.command {
            EmcuCommand::StoreJob => storing = true,
            _ if job_line && line.end == Terminator::RunBuffer => storing = false,
            _ => {}
        }
        items.push(Item::Line {
            text,
            canonical: line.text(),
            may_move: line.command.may_move(),
        });
    }
    items.push(Item::AwaitIdle);
    Ok(items)
}

/// `\xFD`, `0xFD`, `softstop`, `break`, `reset` (case-insensitive).
pub fn control_byte(arg: &str) -> Option<ControlByte> {
    let lower = arg.trim().to_ascii_lowercase();
    let hex = lower
        .strip_prefix("\\x")
        .or_else(|| lower.strip_prefix("0x"))
        .and_then(|h| u8::from_str_radix(h, 16).ok());
    match (lower.as_str(), hex) {
        (_, Some(b)) => ControlByte::from_byte(b),
        ("softstop" | "soft-stop", _) => Some(ControlByte::SoftStop),
        ("break", _) => Some(ControlByte::Break),
        ("reset", _) => Some(ControlByte::Reset),
        _ => None,
    }
}

/// Check every command before anything is sent. The axis configuration is
/// followed through the list (`@07` makes the pair counts of later moves
/// known); before the first axis setting only what does not depend on the
/// axes is checked, the rest is checked by the driver against the
/// controller's own configuration.
pub fn plan(args: &[String]) -> Result<Vec<Item>, String> {
    let mut config: Option<Option<AxisConfig>> = None;
    let mut storing = false;
    let mut items = Vec::with_capacity(args.len());
    for (i, arg) in args.iter().enumerate() {
        let n = i + 1;
        if let Some(c) = control_byte(arg) {
            // 0xFE leaves the controller without axes (manual 2.2.31).
            if c == ControlByte::Reset {
                config = Some(None);
                storing = false;
            }
            items.push(Item::Control(c));
            continue;
        }
        if storing {
            let parsed = parse_cnc(arg).map_err(|e| {
                format!(
                    "command {n} `{arg}` (a program line after @0i): {}",
                    e.message
                )
            })?;
            if let Some(Some(c)) = config
                && let Err(e) = check_cnc(&parsed.value, c)
            {
                return Err(format!("command {n} `{arg}`: {}", e.message));
            }
            if parsed.value == crate::proto::isel::CncCommand::End {
                storing = false;
            }
            items.push(Item::Line {
                text: arg.clone(),
                canonical: parsed.value.to_string(),
                may_move: false,
            });
            continue;
        }
        let frame = parse_frame(arg)
            .map_err(|e| format!("command {n} `{arg}`: {}", e.message))?
            .value;
        if let Some(known) = config {
            let checked = match known {
                Some(c) => check(&frame.command, c),
                None => crate::proto::isel::check_with(&frame.command, None),
            };
            if let Err(e) = checked {
                return Err(format!("command {n} `{arg}`: {}", e.message));
            }
        }
        match &frame.command {
            Command::SetAxes(s) => {
                config = Some(AxisConfig::after_setting(config.flatten(), *s).ok());
            }
            Command::StoreProgram => storing = true,
            _ => {}
        }
        items.push(Item::Line {
            text: arg.clone(),
            canonical: frame.to_string(),
            may_move: frame.command.may_move(),
        });
    }
    Ok(items)
}

/// How one command ended.
enum Outcome {
    /// The reply (`kind`: the answer, or a long action's start, whose
    /// completion follows).
    Answered {
        text: String,
        kind: ReplyKind,
    },
    ControllerError {
        code: String,
        meaning: String,
        recovery: Recovery,
    },
    Refused(Refusal),
    LinkFailed(String),
    /// A line could not be written to stdout: nothing more is sent.
    Unwritable(StdoutError),
}

pub fn run(global: &GlobalArgs, args: &SendArgs) -> anyhow::Result<ExitCode> {
    let mut profile = match session::resolve(global, args.baud) {
        Ok(p) => p,
        Err(StartError::Usage(m)) => {
            out::say(format_args!("jogterm send: {m}"));
            return Ok(ExitCode::from(EXIT_USAGE));
        }
        Err(StartError::Failed(e)) => return Err(e),
    };
    if profile.connection.protocol == Protocol::Emp
        && let Err(m) = emp::apply_drives(&mut profile, &args.drive)
    {
        out::say(format_args!("jogterm send: {m}"));
        return Ok(ExitCode::from(EXIT_USAGE));
    }
    let items = match plan_for(&profile, &args.commands) {
        Ok(items) => items,
        Err(message) => {
            out::say(format_args!("jogterm send: {message}"));
            return Ok(ExitCode::from(EXIT_USAGE));
        }
    };
    let runtime = session::runtime()?;
    runtime.block_on(async {
        let session = match session::start(global, profile, Polling::OFF, moves_of(&items)) {
            Ok(s) => s,
            Err(StartError::Usage(m)) => {
                out::say(format_args!("jogterm send: {m}"));
                return Ok(ExitCode::from(EXIT_USAGE));
            }
            Err(StartError::Failed(e)) => return Err(e),
        };
        Ok(send_all(session, &items).await)
    })
}

/// A list of reads (and of stops the operator wrote) asks for no motion:
/// its session sends no stop of its own (`docs/device.md`, "Sessions that
/// do not move").
pub fn moves_of(items: &[Item]) -> Moves {
    let moves = items
        .iter()
        .any(|i| matches!(i, Item::Line { may_move: true, .. }));
    if moves { Moves::Yes } else { Moves::No }
}

async fn send_all(mut session: Session, items: &[Item]) -> ExitCode {
    let stopper = session.handle.clone();
    let moves = session.moves;
    tokio::select! {
        code = send_items(&mut session, items) => {
            session.close().await;
            code
        }
        () = session::interrupted() => {
            // Stop first, then the orderly close; reads stop nothing.
            if moves == Moves::Yes {
                let _ = stopper.stop().written().await;
            }
            session::say_interrupted("send", moves);
            session.close().await;
            ExitCode::from(1)
        }
    }
}

async fn send_items(session: &mut Session, items: &[Item]) -> ExitCode {
    if let Linked::Failed(reason) = session.linked(Duration::from_secs(10)).await {
        out::say(format_args!(
            "jogterm send: link failure: {reason}; {}",
            Recovery::CheckLink.instruction()
        ));
        return ExitCode::from(EXIT_LINK);
    }
    let mut i = 0;
    let mut code = 0u8;
    while let Some(item) = items.get(i) {
        i += 1;
        let outcome = match item {
            Item::AwaitIdle => match await_idle(session).await {
                Some(outcome) => outcome,
                None => continue,
            },
            Item::Control(c) => send_control(session, *c).await,
            Item::Line {
                text,
                canonical,
                may_move,
            } => {
                if let Err(e) = out::line(format_args!(">> {}", readable(text.as_bytes()))) {
                    Outcome::Unwritable(e)
                } else if let Err(e) = session.handle.request(Request::Raw { line: text.clone() }) {
                    Outcome::LinkFailed(e.to_string())
                } else {
                    // Control bytes right after a move go out while it runs.
                    let mut controls = Vec::new();
                    while let Some(Item::Control(c)) = items.get(i) {
                        controls.push(*c);
                        i += 1;
                    }
                    let mut outcome =
                        await_line(session, text, canonical, *may_move, &controls).await;
                    // EMP: a long action's `55`; its completion follows.
                    while let Outcome::Answered {
                        text: t,
                        kind: ReplyKind::Started,
                    } = &outcome
                    {
                        if let Err(e) = out::line(format_args!("<< {t}")) {
                            outcome = Outcome::Unwritable(e);
                            break;
                        }
                        outcome = wait_outcome(session, text, canonical).await;
                    }
                    outcome
                }
            }
        };
        code = match outcome {
            Outcome::Answered { text, .. } => {
                match text
                    .lines()
                    .try_for_each(|line| out::line(format_args!("<< {line}")))
                {
                    Ok(()) => continue,
                    Err(e) => unwritable(e, session.moves),
                }
            }
            Outcome::Unwritable(e) => unwritable(e, session.moves),
            Outcome::ControllerError {
                code,
                meaning,
                recovery,
            } => {
                // An isel reply code is one character; other families' codes
                // (EMCU `error flag`) carry their recovery in the event.
                let advice = match code.as_bytes() {
                    [b] => ReplyCode::from_byte(*b),
                    _ => None,
                }
                .map_or(recovery.instruction(), |c| c.recovery().advice());
                // The status is 1 whether or not stdout takes the code: the
                // error is said on stderr in any case.
                let _ = out::line(format_args!("<< {code}"));
                out::say(format_args!(
                    "jogterm send: the controller answered `{code}`: {meaning} {advice}"
                ));
                1
            }
            Outcome::Refused(reason) => {
                out::say(format_args!("jogterm send: refused: {reason}"));
                match reason {
                    Refusal::Invalid { .. } => EXIT_USAGE,
                    Refusal::NotConnected => EXIT_LINK,
                    _ => 1,
                }
            }
            Outcome::LinkFailed(reason) => {
                // What happened and what to do: the line, not the machine, is in doubt.
                out::say(format_args!(
                    "jogterm send: link failure: {}; {}",
                    reason.trim_end_matches('.'),
                    Recovery::CheckLink.instruction()
                ));
                EXIT_LINK
            }
        };
        break;
    }
    ExitCode::from(code)
}

/// Wait until the machine is idle; a fault or a lost link on the way ends
/// the wait with that outcome.
async fn await_idle(session: &mut Session) -> Option<Outcome> {
    while session.activity != Activity::Idle {
        match session.next_event().await {
            Some(Event::Fault(f)) => return Some(fault_outcome(f)),
            // The driver ends what ran when the link goes: idle, but lost.
            Some(Event::State(s)) if !s.link_up => {
                return Some(Outcome::LinkFailed("the link was lost".into()));
            }
            Some(Event::Link(LinkState::Lost { reason })) => {
                return Some(Outcome::LinkFailed(reason));
            }
            None => return Some(Outcome::LinkFailed("the device task ended".into())),
            Some(_) => {}
        }
    }
    None
}

async fn send_control(session: &mut Session, control: ControlByte) -> Outcome {
    let text = char::from(control.byte()).to_string();
    if let Err(e) = out::line(format_args!(">> {}", readable(&[control.byte()]))) {
        return Outcome::Unwritable(e);
    }
    if let Err(e) = session.handle.request(Request::Raw { line: text.clone() }) {
        return Outcome::LinkFailed(e.to_string());
    }
    wait_outcome(session, &text, &readable(&[control.byte()])).await
}

/// Wait for the answer to `text` (a raw line), sending `controls` as soon as
/// the command is running (or has answered).
async fn await_line(
    session: &mut Session,
    text: &str,
    canonical: &str,
    may_move: bool,
    controls: &[ControlByte],
) -> Outcome {
    if !controls.is_empty() {
        if may_move {
            // Wait until the move runs, so the bytes act on it.
            loop {
                match session.next_event().await {
                    Some(Event::State(s)) if s.activity != Activity::Idle => break,
                    Some(e) => {
                        if let Some(outcome) = outcome_of(&e, text, canonical) {
                            return match send_controls(session, controls).await {
                                Ok(()) => outcome,
                                Err(e) => Outcome::Unwritable(e),
                            };
                        }
                    }
                    None => return Outcome::LinkFailed("the device task ended".into()),
                }
            }
        }
        if let Err(e) = send_controls(session, controls).await {
            return Outcome::Unwritable(e);
        }
    }
    wait_outcome(session, text, canonical).await
}

/// Send `controls`, each said on stdout first. They go out even when stdout
/// fails: they are the stops the operator asked for during a move; the
/// first failure is returned once all have gone.
async fn send_controls(session: &Session, controls: &[ControlByte]) -> Result<(), StdoutError> {
    let mut said = Ok(());
    for c in controls {
        if said.is_ok() {
            said = out::line(format_args!(">> {}", readable(&[c.byte()])));
        }
        let _ = session.handle.request(Request::Raw {
            line: char::from(c.byte()).to_string(),
        });
    }
    said
}

/// The exit status when stdout cannot take a line, said on stderr: nothing
/// more is sent, and the session's close stops the machine if it moved. 1
/// also for a reader that went away on purpose (`| head -1`): commands may
/// be left unsent, as after Ctrl-C.
fn unwritable(e: StdoutError, moves: Moves) -> u8 {
    let after = match moves {
        Moves::Yes => "; the machine is stopped",
        Moves::No => "",
    };
    out::say(format_args!(
        "jogterm send: {e}: nothing more is sent{after}"
    ));
    1
}

async fn wait_outcome(session: &mut Session, text: &str, canonical: &str) -> Outcome {
    loop {
        match session.next_event().await {
            // A read-only session waits while a program runs
            // (`docs/device.md`, "Sessions that do not move"): said, not an
            // outcome.
            Some(Event::Notice(t))
                if t.starts_with(BUSY_NOTICE) || t.starts_with(ANSWERS_AGAIN_NOTICE) =>
            {
                out::say(format_args!("jogterm send: {t}"));
            }
            Some(e) => {
                if let Some(outcome) = outcome_of(&e, text, canonical) {
                    return outcome;
                }
            }
            None => return Outcome::LinkFailed("the device task ended".into()),
        }
    }
}

/// Whether `event` ends the wait for the raw line `text` (`canonical` as the
/// driver names it).
fn outcome_of(event: &Event, text: &str, canonical: &str) -> Option<Outcome> {
    match event {
        Event::Reply {
            command,
            text: t,
            kind,
        } if command == canonical => Some(Outcome::Answered {
            text: t.clone(),
            kind: *kind,
        }),
        Event::Fault(f) if f.command == canonical => Some(fault_outcome(f.clone())),
        Event::Refused { request, reason }
            if *request
                == describe(&Request::Raw {
                    line: text.to_owned(),
                }) =>
        {
            Some(Outcome::Refused(reason.clone()))
        }
        Event::Link(LinkState::Lost { reason }) => Some(Outcome::LinkFailed(reason.clone())),
        _ => None,
    }
}

fn fault_outcome(f: crate::device::api::ControllerFault) -> Outcome {
    if f.code == "timeout" || f.recovery == Recovery::CheckLink {
        Outcome::LinkFailed(format!("{} to {}: {}", f.code, f.command, f.meaning))
    } else {
        Outcome::ControllerError {
            code: f.code,
            meaning: f.meaning,
            recovery: f.recovery,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(a: &[&str]) -> Vec<String> {
        a.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn control_bytes_have_three_spellings() {
        for s in ["\\xFD", "0xfd", "SoftStop", "softstop"] {
            assert_eq!(control_byte(s), Some(ControlByte::SoftStop), "{s}");
        }
        assert_eq!(control_byte("break"), Some(ControlByte::Break));
        assert_eq!(control_byte("0xFE"), Some(ControlByte::Reset));
        assert_eq!(control_byte("0x41"), None);
        assert_eq!(control_byte("@0P"), None);
    }

    #[test]
    fn the_axis_setting_is_followed_through_the_list() {
        let items = plan(&args(&["@07", "@0A 5000,900,0,900,0,900,0,900", "@0P"])).expect("ok");
        assert_eq!(
            items[1],
            Item::Line {
                text: "@0A 5000,900,0,900,0,900,0,900".into(),
                canonical: "@0A5000,900,0,900,0,900,0,900".into(),
                may_move: true
            }
        );
        let err = plan(&args(&["@01", "@0A5000,900,0,900"])).expect_err("refused");
        assert_eq!(
            err,
            "command 2 `@0A5000,900,0,900`: `A` with X takes 1 steps,speed pair (x), got 2"
        );
        // Before an axis setting, the controller's own setting decides.
        assert!(plan(&args(&["@0A5000,900"])).is_ok());
        let err = plan(&args(&["@0P", "@0Q"])).expect_err("refused");
        assert!(err.starts_with("command 2 `@0Q`:"), "{err}");
    }

    #[test]
    fn lines_after_store_are_program_lines_until_9() {
        let items = plan(&args(&[
            "@07",
            "@0i",
            "0100,900,0,900,0,900,0,900",
            "9",
            "@0S",
        ]))
        .expect("ok");
        assert!(
            matches!(&items[2], Item::Line { canonical, .. } if canonical == "0100,900,0,900,0,900,0,900")
        );
        assert!(matches!(&items[4], Item::Line { may_move: true, .. }));
        let err = plan(&args(&["@07", "@0i", "@0P"])).expect_err("refused");
        assert!(err.contains("a program line after @0i"), "{err}");
    }

    #[test]
    fn emcu_lines_are_checked_and_batches_awaited() {
        let items = emcu_plan(&args(&["#E1,800", "L1,x500\\x01", "@LX", "@B", "@X"])).expect("ok");
        let names: Vec<String> = items
            .iter()
            .map(|i| match i {
                Item::Line { canonical, .. } => canonical.clone(),
                Item::AwaitIdle => "wait".into(),
                Item::Control(c) => format!("{c:?}"),
            })
            .collect();
        assert_eq!(
            names,
            [
                "wait",
                "#E1,800",
                "wait",
                "L1,x500<01>",
                "@LX",
                "@B",
                "@X",
                "wait"
            ]
        );
        // Job lines after `@F` run nothing: no waits until the 0x01 line.
        let items = emcu_plan(&args(&["@F", "#E1,800", "L1,x5\\x01", "@J"])).expect("ok");
        let waits: Vec<bool> = items.iter().map(|i| *i == Item::AwaitIdle).collect();
        assert_eq!(waits, [true, false, false, false, true, false, true]);
        let err = emcu_plan(&args(&["@X", "L1,q5"])).expect_err("refused");
        assert!(err.starts_with("command 2 `L1,q5`:"), "{err}");
        let err = emcu_plan(&args(&["@X\\x01"])).expect_err("refused");
        assert!(err.contains("master command"), "{err}");
    }
}
