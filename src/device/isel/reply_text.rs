//! Replies as text for `Event::Reply` (the `Raw` requests of the terminal
//! and `jogterm send`): positions in steps, port bits by name, text lines.

use crate::axis::Axis;
use crate::proto::isel::ports::limit_diagnosis_axes;
use crate::proto::isel::{Command, DiagnosisKind, Reply, ReplyCode, TextEnd};

use super::io::describe_input;
use crate::wiring::Wiring;

/// `0 X=256 Y=131087 Z=-2` and the like; port bits under the profile's
/// names (`wiring`).
pub fn reply_text(command: Option<&Command>, reply: &Reply, wiring: &Wiring) -> String {
    match reply {
        Reply::Code(code) => code_text(*code),
        Reply::Positions(p) => {
            let mut parts = vec![
                format!("{}={}", Axis::X, p.x),
                format!("{}={}", Axis::Y, p.y),
                format!("{}={}", Axis::Z, p.z),
            ];
            if let Some(a) = p.a {
                parts.push(format!("{}={a}", Axis::A));
            }
            format!("0 {} (steps)", parts.join(" "))
        }
        Reply::Byte(v) => {
            let meaning = match command {
                Some(Command::ReadPort(port)) => describe_input(*port, *v, wiring),
                Some(Command::Diagnose(d)) => match d.kind() {
                    DiagnosisKind::PositiveLimitSwitches | DiagnosisKind::NegativeLimitSwitches => {
                        let axes = limit_diagnosis_axes(*v);
                        if axes.is_empty() {
                            "no limit switch active".to_owned()
                        } else {
                            format!("limit switch active: {axes}")
                        }
                    }
                    DiagnosisKind::Undocumented => "undocumented diagnosis value".to_owned(),
                },
                _ => String::new(),
            };
            if meaning.is_empty() {
                format!("0 0x{v:02X} ({v:08b})")
            } else {
                format!("0 0x{v:02X} ({v:08b}): {meaning}")
            }
        }
        Reply::Text { lines, end } => {
            let mut out: Vec<String> = lines.iter().map(|l| printable(l)).collect();
            if let TextEnd::Code(code) = end {
                out.push(code_text(*code));
            }
            out.join("\n")
        }
    }
}

/// `0 ok`, `2 limit switch`.
pub fn code_text(code: ReplyCode) -> String {
    format!("{} {}", code.char(), code.name())
}

/// Text lines are Latin-1 and may hold control characters: show those as
/// escapes so they never act on a terminal.
fn printable(line: &str) -> String {
    line.chars()
        .map(|c| {
            if c.is_control() {
                format!("<{:02X}>", c as u32)
            } else {
                c.to_string()
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proto::isel::{Diagnosis, InputPort, Positions};

    #[test]
    fn replies_read_as_text() {
        let w = Wiring::defaults(crate::proto::Protocol::Isel, crate::axis::AxisSet::XYZ, &[]);
        let p = Reply::Positions(Positions {
            x: 256,
            y: 131_087,
            z: -2,
            a: None,
        });
        assert_eq!(reply_text(None, &p, &w), "0 X=256 Y=131087 Z=-2 (steps)");
        assert_eq!(
            reply_text(
                Some(&Command::ReadPort(InputPort::Status1)),
                &Reply::Byte(0x03),
                &w
            ),
            "0 0x03 (00000011): E-stop circuit 1, E-stop circuit 2"
        );
        assert_eq!(
            reply_text(
                Some(&Command::Diagnose(Diagnosis::POSITIVE_LIMITS)),
                &Reply::Byte(0x04),
                &w
            ),
            "0 0x04 (00000100): limit switch active: Z"
        );
        assert_eq!(
            reply_text(None, &Reply::Code(ReplyCode::LimitSwitch), &w),
            "2 limit switch"
        );
        let text = Reply::Text {
            lines: vec!["iMC-S8 \u{1b}V1".into()],
            end: TextEnd::Code(ReplyCode::Ok),
        };
        assert_eq!(reply_text(None, &text, &w), "iMC-S8 <1B>V1\n0 ok");
    }
}
