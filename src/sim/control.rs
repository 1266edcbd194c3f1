//! The simulator's control language, typed on its stdin (`jogterm sim --pty`)
//! and documented in `docs/simulator.md`: a line parser with errors that say
//! which line and what was expected, and the loop that applies the lines to a
//! running shell.
//!
//! ```text
//! set <input> on|off|open|closed|1|0     press <input>
//! pulse <input> <ms>                     chatter <input> <changes> <every-ms>
//! after <ms> set|press|pulse|chatter …
//! fault drop-byte [<index>]              fault corrupt-byte [<index>]
//! fault withhold                         fault garbage <text> | hex:<hex>
//! fault delay <ms>                       fault close [<reopen-after-ms>]
//! fault stream <bytes>                  fault stall
//! memory <commands>
//! show      show received [times]      help      quit
//! ```

use std::io::{self, BufRead, Write};
use std::time::Duration;

use super::engine::MAX_CHATTER_CHANGES;
use super::fault::{ByteIndex, Fault, MAX_STREAM};
use super::shell::{ShellControl, ShellError};
use super::{InputControl, Timed, TimedControl};

/// The longest delay or reopen time accepted: ten minutes.
pub const MAX_MILLIS: u64 = 600_000;

/// One parsed control line.
#[derive(Debug, Clone, PartialEq)]
pub enum ControlCommand {
    Input(InputControl),
    /// `pulse`, `chatter`, `after`.
    Timed(TimedControl),
    /// Input controls joined by `;`, taken at one instant.
    Together(Vec<TimedControl>),
    Fault(Fault),
    /// `memory <commands>`: the program store takes this many commands.
    Memory(usize),
    Show,
    /// `show received`: the bytes the device received, readable.
    ShowReceived,
    /// `show received times`: each read with its wall-clock time.
    ShowReceivedTimes,
    Help,
    Quit,
}

/// A line that could not be parsed: its number (from 1) and what was wrong.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("line {line}: {message}")]
pub struct ControlParseError {
    pub line: usize,
    pub message: String,
}

const COMMANDS: &str =
    "set, press, value, pulse, chatter, after, fault, memory, show, help or quit";
const LEVELS: &str = "on, off, open, closed, 1 or 0";
const FAULTS: &str = "drop-byte, corrupt-byte, withhold, garbage, delay, stream, close or stall";

/// Parse one line. Blank lines and lines starting with `#` are `Ok(None)`.
pub fn parse_line(text: &str, line: usize) -> Result<Option<ControlCommand>, ControlParseError> {
    let fail = |message: String| ControlParseError { line, message };
    let text = text.strip_suffix('\r').unwrap_or(text);
    let Some((word, rest)) = next_word(text) else {
        return Ok(None);
    };
    if word.starts_with('#') {
        return Ok(None);
    }
    // Input controls joined by `;` are taken at one instant.
    if text.contains(';') && parse_timed(word, rest).is_some() {
        let all = text
            .split(';')
            .map(|part| {
                let (word, rest) = next_word(part)
                    .ok_or_else(|| "an empty command between two `;`".to_owned())?;
                parse_timed(word, rest).unwrap_or_else(|| {
                    Err(format!(
                        "`{word}` cannot be joined with `;`: only set, press, pulse, chatter and after"
                    ))
                })
            })
            .collect::<Result<Vec<_>, _>>()
            .map_err(fail)?;
        return Ok(Some(ControlCommand::Together(all)));
    }
    if let Some(timed) = parse_timed(word, rest) {
        return match timed.map_err(fail)? {
            TimedControl {
                delay,
                what: Timed::Input(control),
            } if delay.is_zero() => Ok(Some(ControlCommand::Input(control))),
            timed => Ok(Some(ControlCommand::Timed(timed))),
        };
    }
    let command = match word.to_ascii_lowercase().as_str() {
        "value" => {
            let usage = "`value` needs an analogue input and a number: value <input> <number>";
            let (name, rest) = next_word(rest).ok_or_else(|| fail(usage.to_owned()))?;
            let (number, rest) = next_word(rest).ok_or_else(|| fail(usage.to_owned()))?;
            let value = number
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| fail(format!("`{number}` is not a number: {usage}")))?;
            end_of_line(rest, "the number").map_err(fail)?;
            ControlCommand::Input(InputControl::Value {
                name: name.to_owned(),
                value,
            })
        }
        "fault" => ControlCommand::Fault(parse_fault(rest).map_err(fail)?),
        "memory" => {
            let usage = "`memory` needs a number of commands: memory <commands>";
            let (number, rest) = next_word(rest).ok_or_else(|| fail(usage.to_owned()))?;
            let commands = number
                .parse::<usize>()
                .map_err(|_| fail(format!("`{number}` is not a number of commands: {usage}")))?;
            end_of_line(rest, "the number").map_err(fail)?;
            ControlCommand::Memory(commands)
        }
        "show" => match next_word(rest) {
            None => ControlCommand::Show,
            Some((what, rest)) if what.eq_ignore_ascii_case("received") => match next_word(rest) {
                None => ControlCommand::ShowReceived,
                Some((times, rest)) if times.eq_ignore_ascii_case("times") => {
                    end_of_line(rest, "`show received times`").map_err(fail)?;
                    ControlCommand::ShowReceivedTimes
                }
                Some(_) => {
                    end_of_line(rest, "`show received`").map_err(fail)?;
                    ControlCommand::ShowReceived
                }
            },
            Some((what, _)) => {
                return Err(fail(format!(
                    "unknown `show {what}`: expected `show` or `show received`"
                )));
            }
        },
        "help" => {
            end_of_line(rest, "`help`").map_err(fail)?;
            ControlCommand::Help
        }
        "quit" | "exit" => {
            end_of_line(rest, "`quit`").map_err(fail)?;
            ControlCommand::Quit
        }
        _ => {
            return Err(fail(format!(
                "unknown command `{word}`: expected {COMMANDS}"
            )));
        }
    };
    Ok(Some(command))
}

/// `set`, `press`, `pulse`, `chatter`, and any of them `after` a time;
/// `None` for another command word.
fn parse_timed(word: &str, rest: &str) -> Option<Result<TimedControl, String>> {
    if !word.eq_ignore_ascii_case("after") {
        return parse_input(word, rest).map(|what| {
            what.map(|what| TimedControl {
                delay: Duration::ZERO,
                what,
            })
        });
    }
    let usage = "`after` needs a time and a command: after <ms> set|press|pulse|chatter …";
    let parsed = (|| {
        let (ms, rest) = next_word(rest).ok_or_else(|| usage.to_owned())?;
        let delay = parse_millis(ms)?;
        let (inner, rest) = next_word(rest).ok_or_else(|| usage.to_owned())?;
        let what =
            parse_input(inner, rest).ok_or_else(|| format!("`{inner}` cannot wait: {usage}"))??;
        Ok(TimedControl { delay, what })
    })();
    Some(parsed)
}

/// `set`, `press`, `pulse` and `chatter` (also after `after`); `None` for
/// another command word.
fn parse_input(word: &str, rest: &str) -> Option<Result<Timed, String>> {
    let parsed = match word.to_ascii_lowercase().as_str() {
        "set" => parse_set(rest),
        "press" => next_word(rest)
            .ok_or_else(|| "`press` needs an input: press <input>".to_owned())
            .and_then(|(name, rest)| {
                end_of_line(rest, "the input")?;
                Ok(Timed::Input(InputControl::Press {
                    name: name.to_owned(),
                }))
            }),
        "pulse" => parse_pulse(rest),
        "chatter" => parse_chatter(rest),
        _ => return None,
    };
    Some(parsed)
}

fn parse_set(rest: &str) -> Result<Timed, String> {
    let usage = "`set` needs an input and a level: set <input> on|off|open|closed|1|0";
    let (name, rest) = next_word(rest).ok_or_else(|| usage.to_owned())?;
    let (level, rest) = next_word(rest).ok_or_else(|| usage.to_owned())?;
    let level =
        parse_level(level).ok_or_else(|| format!("unknown level `{level}`: expected {LEVELS}"))?;
    end_of_line(rest, "the level")?;
    Ok(Timed::Input(InputControl::Set {
        name: name.to_owned(),
        level,
    }))
}

fn parse_pulse(rest: &str) -> Result<Timed, String> {
    let usage = "`pulse` needs an input and a time: pulse <input> <ms>";
    let (name, rest) = next_word(rest).ok_or_else(|| usage.to_owned())?;
    let (ms, rest) = next_word(rest).ok_or_else(|| usage.to_owned())?;
    let hold = parse_millis(ms)?;
    end_of_line(rest, "the time")?;
    Ok(Timed::Pulse {
        name: name.to_owned(),
        hold,
    })
}

fn parse_chatter(rest: &str) -> Result<Timed, String> {
    let usage = "`chatter` needs an input, a number of changes and a time: chatter <input> <changes> <every-ms>";
    let (name, rest) = next_word(rest).ok_or_else(|| usage.to_owned())?;
    let (n, rest) = next_word(rest).ok_or_else(|| usage.to_owned())?;
    let changes = n
        .parse::<u32>()
        .ok()
        .filter(|n| (1..=MAX_CHATTER_CHANGES).contains(n))
        .ok_or_else(|| {
            format!("`{n}` is not a number of changes: expected 1 to {MAX_CHATTER_CHANGES}")
        })?;
    let (ms, rest) = next_word(rest).ok_or_else(|| usage.to_owned())?;
    let every = parse_millis(ms)?;
    if every.is_zero() {
        return Err(format!(
            "`{ms}`: the changes need at least 1 ms between them"
        ));
    }
    end_of_line(rest, "the time")?;
    Ok(Timed::Chatter {
        name: name.to_owned(),
        changes,
        every,
    })
}

fn parse_fault(text: &str) -> Result<Fault, String> {
    let Some((kind, rest)) = next_word(text) else {
        return Err(format!("`fault` needs a kind: expected {FAULTS}"));
    };
    match kind.to_ascii_lowercase().as_str() {
        "drop-byte" => Ok(Fault::DropByte(parse_index(rest, "drop-byte")?)),
        "corrupt-byte" => Ok(Fault::CorruptByte(parse_index(rest, "corrupt-byte")?)),
        "withhold" => {
            end_of_line(rest, "`withhold`")?;
            Ok(Fault::Withhold)
        }
        "garbage" => parse_garbage(rest).map(Fault::Garbage),
        "delay" => {
            let (ms, rest) = next_word(rest)
                .ok_or_else(|| "`fault delay` needs a time: fault delay <ms>".to_owned())?;
            let ms = parse_millis(ms)?;
            end_of_line(rest, "the time")?;
            Ok(Fault::Delay(ms))
        }
        "stream" => {
            let usage = "`fault stream` needs a number of bytes: fault stream <bytes>";
            let (n, rest) = next_word(rest).ok_or_else(|| usage.to_owned())?;
            let bytes = n
                .parse::<usize>()
                .ok()
                .filter(|n| (1..=MAX_STREAM).contains(n))
                .ok_or_else(|| {
                    format!("`{n}` is not a number of bytes: expected 1 to {MAX_STREAM}")
                })?;
            end_of_line(rest, "the number of bytes")?;
            Ok(Fault::Stream(bytes))
        }
        "close" => {
            let reopen_after = match next_word(rest) {
                None => None,
                Some((ms, rest)) => {
                    let ms = parse_millis(ms)?;
                    end_of_line(rest, "the reopen time")?;
                    Some(ms)
                }
            };
            Ok(Fault::Close { reopen_after })
        }
        "stall" => {
            end_of_line(rest, "`stall`")?;
            Ok(Fault::Stall)
        }
        _ => Err(format!("unknown fault `{kind}`: expected {FAULTS}")),
    }
}

fn parse_index(text: &str, fault: &str) -> Result<ByteIndex, String> {
    let Some((word, rest)) = next_word(text) else {
        return Ok(ByteIndex::Middle);
    };
    let index = if word.eq_ignore_ascii_case("middle") {
        ByteIndex::Middle
    } else {
        let i = word.parse::<usize>().map_err(|_| {
            format!("`{word}` is not a byte index: expected a number from 0, or `middle` (fault {fault} [<index>])")
        })?;
        ByteIndex::At(i)
    };
    end_of_line(rest, "the index")?;
    Ok(index)
}

/// The rest of the line is the garbage: literal text (blanks inside and at
/// the end included), or `hex:` and hex digit pairs (blanks between pairs
/// allowed).
fn parse_garbage(text: &str) -> Result<Vec<u8>, String> {
    let usage =
        "`fault garbage` needs bytes: fault garbage <text> or fault garbage hex:<hex digits>";
    if text.is_empty() {
        return Err(usage.to_owned());
    }
    let Some(hex) = text
        .get(..4)
        .filter(|p| p.eq_ignore_ascii_case("hex:"))
        .and_then(|_| text.get(4..))
    else {
        return Ok(text.as_bytes().to_vec());
    };
    let digits: Vec<char> = hex.chars().filter(|c| !c.is_whitespace()).collect();
    if let Some(bad) = digits.iter().find(|c| !c.is_ascii_hexdigit()) {
        return Err(format!("`{bad}` in hex:{hex} is not a hex digit"));
    }
    if digits.is_empty() {
        return Err(usage.to_owned());
    }
    if !digits.len().is_multiple_of(2) {
        return Err(format!(
            "hex:{hex} has an odd number of digits: expected two per byte"
        ));
    }
    Ok(digits
        .chunks(2)
        .filter_map(|pair| {
            let s: String = pair.iter().collect();
            u8::from_str_radix(&s, 16).ok()
        })
        .collect())
}

fn parse_millis(word: &str) -> Result<Duration, String> {
    match word.parse::<u64>() {
        Ok(ms) if ms <= MAX_MILLIS => Ok(Duration::from_millis(ms)),
        _ => Err(format!(
            "`{word}` is not a time in ms: expected a whole number from 0 to {MAX_MILLIS}"
        )),
    }
}

fn parse_level(word: &str) -> Option<bool> {
    // `closed` = 1 (healthy), `open` = 0 (tripped): see `InputControl::Set`.
    match word.to_ascii_lowercase().as_str() {
        "on" | "closed" | "1" => Some(true),
        "off" | "open" | "0" => Some(false),
        _ => None,
    }
}

/// The first blank-separated word and the rest after the blanks that follow it.
fn next_word(text: &str) -> Option<(&str, &str)> {
    let text = text.trim_start();
    if text.is_empty() {
        return None;
    }
    let end = text.find(char::is_whitespace).unwrap_or(text.len());
    let (word, rest) = text.split_at(end);
    Some((word, rest.trim_start()))
}

fn end_of_line(rest: &str, after: &str) -> Result<(), String> {
    match next_word(rest) {
        None => Ok(()),
        Some((extra, _)) => Err(format!(
            "unexpected `{extra}` after {after}: expected the end of the line"
        )),
    }
}

/// The text `help` prints, with the device's input names.
pub fn help_text(input_names: &[&str]) -> String {
    let inputs = if input_names.is_empty() {
        "(this device has none)".to_owned()
    } else {
        input_names.join(", ")
    };
    format!(
        "commands:\n\
         \x20 set <input> on|off|open|closed|1|0   set an input (closed = 1, open = 0)\n\
         \x20 press <input>                        press and release a button\n\
         \x20 pulse <input> <ms>                   flip an input, flip it back <ms> later\n\
         \x20 chatter <input> <n> <every-ms>       flip an input n times, one flip every <every-ms>\n\
         \x20 after <ms> set|press|pulse|chatter … do it <ms> from now\n\
         \x20 <control>; <control> …               set, press, pulse, chatter, after at one instant\n\
         \x20 value <input> <number>               set an analogue input (EMP adc1-3: mV)\n\
         \x20 fault drop-byte [<index>|middle]     leave one byte out of the next message\n\
         \x20 fault corrupt-byte [<index>|middle]  flip bit 7 of one byte of the next message\n\
         \x20 fault withhold                       do not send the next message\n\
         \x20 fault garbage <text>|hex:<hex>       send these bytes now, unasked\n\
         \x20 fault delay <ms>                     send the next message <ms> later\n\
         \x20 fault stream <bytes>                 instead of the next message, <bytes> of U unbroken\n\
         \x20 fault close [<reopen-after-ms>]      close the line (a pty may reopen)\n\
         \x20 fault stall                          the next long action stays busy (EMP)\n\
         \x20 memory <commands>                    the program store takes this many commands\n\
         \x20 show                                 device state, line, counters\n\
         \x20 show received                        the bytes the device received\n\
         \x20 show received times                  each read of them with its time (s since 1970)\n\
         \x20 help                                 this text\n\
         \x20 quit                                 end the simulator\n\
         inputs: {inputs}"
    )
}

/// Read control lines from `input` until it ends or `quit`; print `ok` or the
/// output of each command on `out`, and `error: line N: …` on `err`.
///
/// Returns an error only when `input` or `out` fail. Errors writing to `err`
/// are ignored: a hung-up stderr must not end the simulator.
pub fn run_control_loop(
    input: impl BufRead,
    out: &mut impl Write,
    err: &mut impl Write,
    shell: &ShellControl,
) -> io::Result<()> {
    for (index, line) in input.split(b'\n').enumerate() {
        let number = index + 1;
        let bytes = line?;
        let Ok(text) = std::str::from_utf8(&bytes) else {
            let _ = writeln!(err, "error: line {number}: not valid UTF-8 text");
            continue;
        };
        let command = match parse_line(text, number) {
            Ok(Some(command)) => command,
            Ok(None) => continue,
            Err(e) => {
                let _ = writeln!(err, "error: {e}");
                continue;
            }
        };
        let result = match command {
            ControlCommand::Quit => return Ok(()),
            ControlCommand::Input(control) => shell.input(control).map(|()| "ok".to_owned()),
            ControlCommand::Timed(control) => shell.timed(vec![control]).map(|()| "ok".to_owned()),
            ControlCommand::Together(all) => shell.timed(all).map(|()| "ok".to_owned()),
            ControlCommand::Fault(fault) => shell.fault(fault).map(|()| "ok".to_owned()),
            ControlCommand::Memory(n) => shell.program_memory(n).map(|()| "ok".to_owned()),
            ControlCommand::Show => shell.show(),
            ControlCommand::ShowReceived => shell.received().map(|r| r.to_string()),
            ControlCommand::ShowReceivedTimes => shell.received().map(|r| r.timed()),
            ControlCommand::Help => shell.input_names().map(|names| help_text(&names)),
        };
        match result {
            Ok(text) => {
                writeln!(out, "{text}")?;
                out.flush()?;
            }
            Err(ShellError::Stopped) => {
                let _ = writeln!(err, "error: line {number}: the simulator has stopped");
                return Ok(());
            }
            Err(e) => {
                let _ = writeln!(err, "error: line {number}: {e}");
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> ControlCommand {
        match parse_line(text, 1) {
            Ok(Some(c)) => c,
            other => panic!("{text:?} gave {other:?}"),
        }
    }

    fn error(text: &str) -> String {
        match parse_line(text, 7) {
            Err(e) => e.to_string(),
            other => panic!("{text:?} gave {other:?}"),
        }
    }

    fn set(name: &str, level: bool) -> ControlCommand {
        ControlCommand::Input(InputControl::Set {
            name: name.into(),
            level,
        })
    }

    #[test]
    fn pulse_chatter_and_after() {
        let ms = Duration::from_millis;
        assert_eq!(
            parse("pulse limit-x1 1000"),
            ControlCommand::Timed(TimedControl {
                delay: Duration::ZERO,
                what: Timed::Pulse {
                    name: "limit-x1".into(),
                    hold: ms(1000)
                }
            })
        );
        assert_eq!(
            parse("CHATTER in0.3 12 15"),
            ControlCommand::Timed(TimedControl {
                delay: Duration::ZERO,
                what: Timed::Chatter {
                    name: "in0.3".into(),
                    changes: 12,
                    every: ms(15)
                }
            })
        );
        assert_eq!(
            parse("after 30 set estop2 open"),
            ControlCommand::Timed(TimedControl {
                delay: ms(30),
                what: Timed::Input(InputControl::Set {
                    name: "estop2".into(),
                    level: false
                })
            })
        );
        assert_eq!(
            parse("after 5 pulse stop 200"),
            ControlCommand::Timed(TimedControl {
                delay: ms(5),
                what: Timed::Pulse {
                    name: "stop".into(),
                    hold: ms(200)
                }
            })
        );
        assert_eq!(
            error("pulse limit-x1"),
            "line 7: `pulse` needs an input and a time: pulse <input> <ms>"
        );
        assert_eq!(
            error("chatter a 0 10"),
            "line 7: `0` is not a number of changes: expected 1 to 10000"
        );
        assert_eq!(
            error("chatter a 3 0"),
            "line 7: `0`: the changes need at least 1 ms between them"
        );
        assert_eq!(
            error("after 10 fault withhold"),
            "line 7: `fault` cannot wait: `after` needs a time and a command: after <ms> set|press|pulse|chatter …"
        );
        assert_eq!(
            error("after soon set a on"),
            "line 7: `soon` is not a time in ms: expected a whole number from 0 to 600000"
        );
        assert_eq!(
            error("after 10 set a"),
            "line 7: `set` needs an input and a level: set <input> on|off|open|closed|1|0"
        );
    }

    #[test]
    fn controls_joined_by_semicolons_are_taken_together() {
        let ms = Duration::from_millis;
        assert_eq!(
            parse("set estop1 open; after 30 set estop2 open"),
            ControlCommand::Together(vec![
                TimedControl {
                    delay: Duration::ZERO,
                    what: Timed::Input(InputControl::Set {
                        name: "estop1".into(),
                        level: false
                    })
                },
                TimedControl {
                    delay: ms(30),
                    what: Timed::Input(InputControl::Set {
                        name: "estop2".into(),
                        level: false
                    })
                },
            ])
        );
        assert_eq!(
            error("set a on; fault withhold"),
            "line 7: `fault` cannot be joined with `;`: only set, press, pulse, chatter and after"
        );
        assert_eq!(
            error("set a on;"),
            "line 7: an empty command between two `;`"
        );
        // Garbage may hold a `;`: it is no input control.
        assert_eq!(
            parse("fault garbage a;b"),
            ControlCommand::Fault(Fault::Garbage(b"a;b".to_vec()))
        );
    }

    #[test]
    fn memory_takes_a_number_of_commands() {
        assert_eq!(parse("memory 12"), ControlCommand::Memory(12));
        assert_eq!(parse("MEMORY 0"), ControlCommand::Memory(0));
        assert!(error("memory").contains("needs a number of commands"));
        assert!(error("memory -3").contains("not a number of commands"));
        assert!(error("memory 5 6").contains("unexpected `6`"));
    }

    #[test]
    fn value_carries_a_number() {
        assert_eq!(
            parse("value adc1 -12.5"),
            ControlCommand::Input(InputControl::Value {
                name: "adc1".into(),
                value: -12.5
            })
        );
        assert!(error("value adc1 lots").contains("not a number"));
        assert!(error("value adc1").contains("needs an analogue input and a number"));
        assert!(error("value adc1 1 2").contains("unexpected `2`"));
    }

    #[test]
    fn every_level_word() {
        for (word, level) in [
            ("on", true),
            ("off", false),
            ("closed", true),
            ("open", false),
            ("1", true),
            ("0", false),
            ("ON", true),
            ("Open", false),
        ] {
            assert_eq!(
                parse(&format!("set estop1 {word}")),
                set("estop1", level),
                "{word}"
            );
        }
    }

    #[test]
    fn input_names_are_passed_as_typed() {
        assert_eq!(parse("  set   Hood\tclosed  "), set("Hood", true));
        assert_eq!(
            parse("press start"),
            ControlCommand::Input(InputControl::Press {
                name: "start".into()
            })
        );
    }

    #[test]
    fn every_fault_form() {
        assert_eq!(
            parse("fault drop-byte"),
            ControlCommand::Fault(Fault::DropByte(ByteIndex::Middle))
        );
        assert_eq!(
            parse("fault drop-byte 0"),
            ControlCommand::Fault(Fault::DropByte(ByteIndex::At(0)))
        );
        assert_eq!(
            parse("fault drop-byte middle"),
            ControlCommand::Fault(Fault::DropByte(ByteIndex::Middle))
        );
        assert_eq!(
            parse("fault corrupt-byte"),
            ControlCommand::Fault(Fault::CorruptByte(ByteIndex::Middle))
        );
        assert_eq!(
            parse("fault corrupt-byte 18"),
            ControlCommand::Fault(Fault::CorruptByte(ByteIndex::At(18)))
        );
        assert_eq!(
            parse("fault withhold"),
            ControlCommand::Fault(Fault::Withhold)
        );
        assert_eq!(parse("fault stall"), ControlCommand::Fault(Fault::Stall));
        assert_eq!(
            parse("fault delay 250"),
            ControlCommand::Fault(Fault::Delay(Duration::from_millis(250)))
        );
        assert_eq!(
            parse("fault stream 30000"),
            ControlCommand::Fault(Fault::Stream(30_000))
        );
        assert_eq!(
            parse("fault close"),
            ControlCommand::Fault(Fault::Close { reopen_after: None })
        );
        assert_eq!(
            parse("fault close 300"),
            ControlCommand::Fault(Fault::Close {
                reopen_after: Some(Duration::from_millis(300))
            })
        );
        assert_eq!(
            parse("FAULT Withhold"),
            ControlCommand::Fault(Fault::Withhold)
        );
    }

    #[test]
    fn garbage_text_is_the_rest_of_the_line_verbatim() {
        assert_eq!(
            parse("fault garbage hello  world "),
            ControlCommand::Fault(Fault::Garbage(b"hello  world ".to_vec()))
        );
        assert_eq!(
            parse("fault garbage @0P"),
            ControlCommand::Fault(Fault::Garbage(b"@0P".to_vec()))
        );
        // A CR from a CRLF terminal is the line end, not garbage.
        assert_eq!(
            parse("fault garbage x\r"),
            ControlCommand::Fault(Fault::Garbage(b"x".to_vec()))
        );
    }

    #[test]
    fn garbage_hex_with_or_without_blanks() {
        assert_eq!(
            parse("fault garbage hex:0d0A1aff"),
            ControlCommand::Fault(Fault::Garbage(vec![0x0D, 0x0A, 0x1A, 0xFF]))
        );
        assert_eq!(
            parse("fault garbage HEX: fd ff"),
            ControlCommand::Fault(Fault::Garbage(vec![0xFD, 0xFF]))
        );
    }

    #[test]
    fn show_help_quit_blank_and_comments() {
        assert_eq!(parse("show"), ControlCommand::Show);
        assert_eq!(parse("show received"), ControlCommand::ShowReceived);
        assert_eq!(parse("SHOW Received"), ControlCommand::ShowReceived);
        assert_eq!(parse("help"), ControlCommand::Help);
        assert_eq!(parse("quit"), ControlCommand::Quit);
        assert_eq!(parse("exit"), ControlCommand::Quit);
        assert_eq!(parse_line("", 1), Ok(None));
        assert_eq!(parse_line("   \t ", 1), Ok(None));
        assert_eq!(parse_line("# set hood open", 1), Ok(None));
    }

    #[test]
    fn errors_name_the_line_and_what_was_expected() {
        assert_eq!(
            error("sett hood on"),
            "line 7: unknown command `sett`: expected set, press, value, pulse, chatter, after, fault, memory, show, help or quit"
        );
        assert_eq!(
            error("set"),
            "line 7: `set` needs an input and a level: set <input> on|off|open|closed|1|0"
        );
        assert_eq!(
            error("set hood"),
            "line 7: `set` needs an input and a level: set <input> on|off|open|closed|1|0"
        );
        assert_eq!(
            error("set hood maybe"),
            "line 7: unknown level `maybe`: expected on, off, open, closed, 1 or 0"
        );
        assert_eq!(
            error("set hood on now"),
            "line 7: unexpected `now` after the level: expected the end of the line"
        );
        assert_eq!(
            error("show more"),
            "line 7: unknown `show more`: expected `show` or `show received`"
        );
        assert_eq!(
            error("show received all"),
            "line 7: unexpected `all` after `show received`: expected the end of the line"
        );
        assert_eq!(
            parse("show received times"),
            ControlCommand::ShowReceivedTimes
        );
        assert_eq!(
            error("press"),
            "line 7: `press` needs an input: press <input>"
        );
        assert_eq!(
            error("press a b"),
            "line 7: unexpected `b` after the input: expected the end of the line"
        );
        assert_eq!(
            error("fault"),
            "line 7: `fault` needs a kind: expected drop-byte, corrupt-byte, withhold, garbage, delay, stream, close or stall"
        );
        assert_eq!(
            error("fault melt"),
            "line 7: unknown fault `melt`: expected drop-byte, corrupt-byte, withhold, garbage, delay, stream, close or stall"
        );
        assert_eq!(
            error("fault drop-byte -1"),
            "line 7: `-1` is not a byte index: expected a number from 0, or `middle` (fault drop-byte [<index>])"
        );
        assert_eq!(
            error("fault drop-byte 1 2"),
            "line 7: unexpected `2` after the index: expected the end of the line"
        );
        assert_eq!(
            error("fault withhold now"),
            "line 7: unexpected `now` after `withhold`: expected the end of the line"
        );
        assert_eq!(
            error("fault delay"),
            "line 7: `fault delay` needs a time: fault delay <ms>"
        );
        assert_eq!(
            error("fault delay 1.5"),
            "line 7: `1.5` is not a time in ms: expected a whole number from 0 to 600000"
        );
        assert_eq!(
            error("fault delay 600001"),
            "line 7: `600001` is not a time in ms: expected a whole number from 0 to 600000"
        );
        assert_eq!(
            error("fault close soon"),
            "line 7: `soon` is not a time in ms: expected a whole number from 0 to 600000"
        );
        assert_eq!(
            error("fault close 5 6"),
            "line 7: unexpected `6` after the reopen time: expected the end of the line"
        );
        assert_eq!(
            error("fault garbage"),
            "line 7: `fault garbage` needs bytes: fault garbage <text> or fault garbage hex:<hex digits>"
        );
        assert_eq!(
            error("fault garbage hex:"),
            "line 7: `fault garbage` needs bytes: fault garbage <text> or fault garbage hex:<hex digits>"
        );
        assert_eq!(
            error("fault garbage hex:0g"),
            "line 7: `g` in hex:0g is not a hex digit"
        );
        assert_eq!(
            error("fault garbage hex:abc"),
            "line 7: hex:abc has an odd number of digits: expected two per byte"
        );
    }

    #[test]
    fn help_lists_the_inputs() {
        assert!(help_text(&["hood", "start"]).ends_with("inputs: hood, start"));
        assert!(help_text(&[]).ends_with("(this device has none)"));
    }

    proptest::proptest! {
        #[test]
        fn the_parser_never_panics(text in "\\PC{0,40}") {
            let _ = parse_line(&text, 1);
        }

        #[test]
        fn memory_takes_any_count_and_never_panics(n in proptest::num::usize::ANY, tail in "\\PC{0,20}") {
            proptest::prop_assert_eq!(
                parse_line(&format!("memory {n}"), 1),
                Ok(Some(ControlCommand::Memory(n)))
            );
            let _ = parse_line(&format!("memory {tail}"), 1);
        }

        #[test]
        fn any_bytes_parse_as_hex_garbage(bytes in proptest::collection::vec(proptest::num::u8::ANY, 1..20)) {
            let hex: String = bytes.iter().map(|b| format!("{b:02x} ")).collect();
            let parsed = parse_line(&format!("fault garbage hex:{hex}"), 1);
            proptest::prop_assert_eq!(parsed, Ok(Some(ControlCommand::Fault(Fault::Garbage(bytes)))));
        }
    }
}
