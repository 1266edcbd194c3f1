//! Requests in words, for `Event::Refused` and logs.

use super::api::{Frame, PerAxis, Request};

fn axes_values<T: std::fmt::Display + Copy>(values: &PerAxis<T>) -> String {
    values
        .iter()
        .map(|(a, v)| format!("{a}={v}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// A raw line's characters as the bytes they stand for: a control
/// character U+00FD is the byte 0xFD (`isel::raw`), not its UTF-8 form.
fn latin1(line: &str) -> Vec<u8> {
    line.chars()
        .map(|c| u8::try_from(u32::from(c)).unwrap_or(b'?'))
        .collect()
}

/// `step X=10`, `raw @0P`, `home XYZ` …
pub fn describe(request: &Request) -> String {
    match request {
        Request::Jog { id, axes, .. } => {
            let dirs: Vec<String> = axes
                .iter()
                .map(|(a, d)| format!("{a}{}", if d.sign() > 0 { '+' } else { '-' }))
                .collect();
            format!("jog {} (#{})", dirs.join(" "), id.0)
        }
        Request::LimitJog { id, axis, dir } => {
            format!("jog off limit {axis}{} (#{})", dir.symbol(), id.0)
        }
        Request::Probe { id, probe } => {
            format!("probe {}{} (#{})", probe.axis, probe.dir.symbol(), id.0)
        }
        Request::JogRenew { id, .. } => format!("jog renewal (#{})", id.0),
        Request::JogRelease { id } => format!("jog release (#{})", id.0),
        Request::Step { delta, .. } => format!("step {}", axes_values(delta)),
        Request::MoveTo { target, frame, .. } => format!(
            "move to {} ({})",
            axes_values(target),
            match frame {
                Frame::Machine => "machine",
                Frame::Work => "work",
            }
        ),
        Request::Home { axes } => format!("home {axes}"),
        Request::SetZero { axes } => format!("set zero {axes}"),
        Request::SetOutput { output, value } => match output.bit {
            Some(bit) => format!("output {}.{bit} = {value}", output.group),
            None => format!("output {} = {value}", output.group),
        },
        Request::Raw { line } => format!("raw {}", crate::traffic::readable(&latin1(line))),
        Request::Upload { lines, .. } => format!("upload ({} lines)", lines.len()),
        Request::RunProgram => "run program".to_owned(),
        Request::Checkout { line, resume, .. } => match resume {
            Some(_) => format!(
                "check-out resume {}",
                crate::traffic::readable(&latin1(line))
            ),
            None => format!("check-out {}", crate::traffic::readable(&latin1(line))),
        },
        Request::Initialise => "initialise".to_owned(),
        Request::Reset => "reset".to_owned(),
        Request::Poll { .. } => "poll settings".to_owned(),
        Request::Shutdown => "shutdown".to_owned(),
        Request::Hold { lease } => format!("hold for {} ms", lease.as_millis()),
        Request::HoldEnd => "hold ended".to_owned(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axis::{Axis, AxisSet};
    use crate::device::api::{Dir, JogId};

    #[test]
    fn requests_read_as_words() {
        let step = Request::Step {
            delta: PerAxis::new().with(Axis::X, 10).with(Axis::Z, -5),
            speed_hz: PerAxis::new(),
        };
        assert_eq!(describe(&step), "step X=10 Z=-5");
        let jog = Request::Jog {
            id: JogId(7),
            axes: vec![(Axis::X, Dir::Plus), (Axis::Y, Dir::Minus)],
            speed_hz: PerAxis::new(),
            lease: std::time::Duration::from_millis(100),
        };
        assert_eq!(describe(&jog), "jog X+ Y- (#7)");
        assert_eq!(describe(&Request::Home { axes: AxisSet::XYZ }), "home XYZ");
        assert_eq!(
            describe(&Request::Raw {
                line: "@0A 5\r".into()
            }),
            "raw @0A 5<CR>"
        );
        assert_eq!(
            describe(&Request::Raw {
                line: "\u{fd}".into()
            }),
            "raw <FD>"
        );
    }
}
