//! The plain-text replies: `@0V`/`@0?` (version, manual 2.2.26), `@0H`
//! (status, 2.2.12) and `@0h` (limit switches, 2.2.12). Lines never start
//! with a digit: a reader takes a digit at a line start for the closing
//! reply code (`docs/protocols.md`, isel).

use crate::axis::{Axis, AxisSet};
use crate::proto::isel::ports::LimitSwitchSetting;

/// The version lines.
pub fn version() -> Vec<String> {
    vec![
        "isel iMC-S8 simulator".to_owned(),
        format!(
            "jogterm {} (simulated controller, 4 axes, program memory 2000 commands)",
            env!("CARGO_PKG_VERSION")
        ),
    ]
}

/// What `@0H` reports, gathered by the controller.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Status {
    pub axes: Option<AxisSet>,
    pub referenced: AxisSet,
    pub test_mode: bool,
    pub three_d: bool,
    pub start_stop: u32,
    pub acceleration: u32,
    pub reference_speeds: [u32; 4],
    pub ports: [u8; 4],
    pub outputs: [u8; 4],
    pub program: &'static str,
    pub device: u8,
    /// Port 2 cannot tell an open hood in setup mode.
    pub hood_closed: bool,
}

fn on_off(on: bool) -> &'static str {
    if on { "on" } else { "off" }
}

fn axes_text(set: AxisSet) -> String {
    if set.is_empty() {
        "none".to_owned()
    } else {
        set.to_string()
    }
}

/// The `@0H` lines.
pub fn status(s: &Status) -> Vec<String> {
    let [p0, p1, p2, p3] = s.ports;
    let bit = |byte: u8, n: u8| byte >> n & 1 == 1;
    let closed = |ok: bool| if ok { "closed" } else { "OPEN" };
    vec![
        format!(
            "Device {}, axes {}, referenced {}, test mode {}, 3D {}",
            s.device,
            s.axes.map_or_else(|| "not set".to_owned(), axes_text),
            axes_text(s.referenced),
            on_off(s.test_mode),
            on_off(s.three_d),
        ),
        format!(
            "Start-stop {} Hz, acceleration {} Hz/ms, reference speeds {} Hz",
            s.start_stop,
            s.acceleration,
            s.reference_speeds.map(|v| v.to_string()).join("/"),
        ),
        format!(
            "E-stop circuit 1 {}, circuit 2 {}, over-temperature {}, power {}",
            closed(bit(p1, 0)),
            closed(bit(p1, 1)),
            if bit(p1, 2) { "YES" } else { "no" },
            if bit(p2, 1) { "ok" } else { "FAIL" },
        ),
        format!(
            "Hood {}, key switch {}, spindle {}, start key {}, stop key {}, probe {}",
            if s.hood_closed { "closed" } else { "OPEN" },
            if bit(p2, 7) { "setup" } else { "automatic" },
            on_off(bit(p2, 0)),
            on_off(bit(p1, 3)),
            on_off(bit(p1, 4)),
            on_off(bit(p1, 5)),
        ),
        format!("Inputs: port0 {p0:02X} port1 {p1:02X} port2 {p2:02X} port3 {p3:02X}"),
        format!(
            "Outputs: user {:02X} analog {:02X} control {:02X} signal {:02X}",
            s.outputs[0], s.outputs[1], s.outputs[2], s.outputs[3]
        ),
        format!("Program: {}", s.program),
    ]
}

/// One axis for `@0h`: the active state, enable and level of switch 1, 2.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AxisSwitches {
    pub axis: Axis,
    pub active: [bool; 2],
    pub settings: [LimitSwitchSetting; 2],
}

/// The `@0h` lines.
pub fn limit_switches(axes: &[AxisSwitches]) -> Vec<String> {
    axes.iter()
        .map(|a| {
            let one = |n: usize| {
                let s = a.settings.get(n).copied().unwrap_or_default();
                format!(
                    "switch {} {} ({}, {})",
                    n + 1,
                    if a.active.get(n).copied().unwrap_or(false) {
                        "ACTIVE"
                    } else {
                        "off"
                    },
                    if s.enabled { "enabled" } else { "disabled" },
                    if s.low_active {
                        "low-active"
                    } else {
                        "high-active"
                    },
                )
            };
            format!("Axis {}: {}, {}", a.axis, one(0), one(1))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_line_starts_with_a_digit() {
        let s = Status {
            axes: None,
            referenced: AxisSet::EMPTY,
            test_mode: false,
            three_d: true,
            start_stop: 300,
            acceleration: 100,
            reference_speeds: [2000; 4],
            ports: [0, 3, 0x62, 0],
            outputs: [0, 0, 8, 0],
            program: "none",
            device: 0,
            hood_closed: true,
        };
        let mut lines = status(&s);
        lines.extend(version());
        lines.extend(limit_switches(&[AxisSwitches {
            axis: Axis::Y,
            active: [true, false],
            settings: [LimitSwitchSetting::default(); 2],
        }]));
        for line in &lines {
            assert!(
                line.bytes().next().is_some_and(|b| b.is_ascii_alphabetic()),
                "{line}"
            );
        }
        assert!(lines.iter().any(|l| l.contains("Hood closed")));
        assert!(
            lines
                .iter()
                .any(|l| l.starts_with("Axis Y: switch 1 ACTIVE"))
        );
    }
}
