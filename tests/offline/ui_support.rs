//! Models for the screen tests, built the way the running program builds
//! them: a shipped profile and theme, then `api.rs` events through `update`.
//! The I/O snapshots name their bits as the manuals do (isel from the
//! protocol core's port tables, EMCU `@X` flags and outputs A1/A2, EMP limits,
//! reference switch, I1-I4, O1-O4).

use std::time::{Duration, Instant};

use jogterm::axis::{Axis, AxisSet};
use jogterm::config::{ConfigDirs, Profile, load_profile, load_theme};
use jogterm::device::api::{
    Activity, ControllerFault, Event, IoBit, IoGroup, IoSnapshot, LinkState, MachineState,
    OutputId, PerAxis, PollStats, PositionSample, PositionSource, Recovery,
};
use jogterm::proto::Protocol;
use jogterm::proto::emcu::StatusFlag;
use jogterm::proto::isel::ports::{INPUT_BITS, InputPort, InputRole, OUTPUT_PORTS};
use jogterm::traffic::{Direction, MessageEnd, Owner, TrafficRecord};
use jogterm::ui::keymap::Keymap;
use jogterm::ui::palette::Palette;
use jogterm::ui::{Model, Msg, Screen, Setup, update};
use ratatui::Terminal;
use ratatui::backend::TestBackend;
use ratatui::buffer::Buffer;

pub const THEMES: [&str; 3] = ["dark", "light", "mono16"];
pub const SIZES: [(u16, u16); 2] = [(80, 24), (160, 48)];

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum State {
    Idle,
    Moving,
    EStop,
    Limit,
    LinkLost,
}

impl State {
    pub const ALL: [State; 5] = [
        State::Idle,
        State::Moving,
        State::EStop,
        State::Limit,
        State::LinkLost,
    ];

    pub fn name(self) -> &'static str {
        match self {
            State::Idle => "idle",
            State::Moving => "moving",
            State::EStop => "estop",
            State::Limit => "limit",
            State::LinkLost => "link_lost",
        }
    }
}

/// Some of the isel simulator's inputs, with the levels the simulator built
/// from `profile` reports for them, as a session on it would list them.
pub fn isel_sim_inputs(profile: &Profile) -> Vec<(String, Option<bool>)> {
    let sim = jogterm::sim::registry::build(Protocol::Isel, profile).expect("isel simulator");
    [
        "estop1", "estop2", "start", "stop", "limit-x1", "limit-x2", "hood",
    ]
    .iter()
    .map(|name| (name.to_string(), sim.input_level(name)))
    .collect()
}

/// A fresh model for `protocol` with `theme`, as the TUI starts it: isel on
/// the built-in simulator (the default profile), EMCU and EMP on a port.
pub fn fresh(protocol: Protocol, theme: &str, t0: Instant) -> Model {
    let dirs = ConfigDirs::builtin_only();
    let profile = load_profile(protocol.name(), &dirs).expect("shipped profile");
    let theme = load_theme(theme, &dirs).expect("shipped theme");
    let mut setup = Setup::from_profile(&profile, None);
    if protocol == Protocol::Isel {
        setup.port = "sim".into();
        setup.simulator_inputs = Some(isel_sim_inputs(&profile));
    }
    Model::new(
        setup,
        Keymap::builtin().expect("built-in keys"),
        Palette::from(&theme),
        t0,
    )
}

pub fn send(model: &mut Model, events: impl IntoIterator<Item = Event>) {
    for e in events {
        update(model, Msg::Device(e));
    }
}

fn bit(name: &str, value: bool) -> IoBit {
    IoBit {
        name: name.to_string(),
        value,
        output: None,
        hazardous: false,
        wiring: None,
    }
}

fn output(name: &str, value: bool, group: u16, bit: Option<u8>, hazardous: bool) -> IoBit {
    IoBit {
        name: name.to_string(),
        value,
        output: Some(OutputId { group, bit }),
        hazardous,
        wiring: None,
    }
}

/// Machine flags that shape the I/O: which limit switch and which E-stop
/// circuit are active.
#[derive(Debug, Clone, Copy, Default)]
pub struct Inputs {
    pub estop: bool,
    pub limit: bool,
    pub spindle: bool,
}

pub fn io(protocol: Protocol, at: Instant, inputs: Inputs) -> IoSnapshot {
    let groups = match protocol {
        Protocol::Isel => isel_io(inputs),
        Protocol::Emcu => emcu_io(inputs),
        Protocol::Emp => emp_io(inputs),
    };
    IoSnapshot { at, groups }
}

/// Every input port with all eight bits ("not used" ones included), then
/// every output port (manual 2.2.3, 2.2.4): on/off ports as one bit, ports
/// 0, 100 and 101 bit by bit. Outputs show what was last written.
fn isel_io(inputs: Inputs) -> Vec<IoGroup> {
    let mut groups = Vec::new();
    for port in InputPort::ALL {
        let mut raw = 0u8;
        let bits = INPUT_BITS
            .iter()
            .filter(|b| b.port == port)
            .map(|b| {
                let value = match b.role {
                    InputRole::EmergencyStopCircuit => !(inputs.estop && b.bit == 0),
                    InputRole::PowerOk => true,
                    InputRole::Hood => true,
                    InputRole::Spindle => inputs.spindle,
                    InputRole::LimitSwitch {
                        axis: Axis::X,
                        switch: 2,
                    } => inputs.limit,
                    _ => false,
                };
                if value {
                    raw |= 1 << b.bit;
                }
                bit(b.name, value)
            })
            .collect();
        let title = match port {
            InputPort::User => "user inputs",
            InputPort::Status1 => "safety and keys",
            InputPort::Status2 => "spindle, power, hood",
            InputPort::LimitSwitches => "limit switches",
        };
        groups.push(IoGroup {
            name: format!("in {}: {title}", port.number()),
            raw: Some(raw),
            bits,
            read: None,
        });
    }
    for info in OUTPUT_PORTS.iter() {
        let number = info.port.number();
        let written: Option<u8> = match info.name {
            "motor currents" => Some(1),
            "spindle" => Some(u8::from(inputs.spindle)),
            _ => None,
        };
        let value = written.unwrap_or(0);
        let group = u16::from(number);
        let bits = if info.bits.is_empty() {
            vec![output(
                info.name,
                value != 0,
                group,
                None,
                info.hazard.is_some(),
            )]
        } else {
            info.bits
                .iter()
                .map(|b| {
                    let hazardous =
                        b.hazard.is_some() || (info.hazard.is_some() && b.name != "not used");
                    output(
                        b.name,
                        value & (1 << b.bit) != 0,
                        group,
                        Some(b.bit),
                        hazardous,
                    )
                })
                .collect()
        };
        groups.push(IoGroup {
            name: format!("out {number}: {}", info.name),
            raw: written,
            bits,
            read: None,
        });
    }
    groups
}

fn emcu_io(inputs: Inputs) -> Vec<IoGroup> {
    vec![
        IoGroup {
            name: "@X".into(),
            raw: None,
            bits: StatusFlag::ALL
                .iter()
                .map(|f| {
                    let value = match f {
                        StatusFlag::Error => inputs.limit || inputs.estop,
                        StatusFlag::PositionUnknown => inputs.limit,
                        _ => false,
                    };
                    bit(&f.to_string(), value)
                })
                .collect(),
            read: None,
        },
        IoGroup {
            name: "out".into(),
            raw: None,
            bits: vec![
                output("A1", inputs.spindle, 1, None, true),
                output("A2", false, 2, None, true),
            ],
            read: None,
        },
    ]
}

fn emp_io(inputs: Inputs) -> Vec<IoGroup> {
    let limits = [
        ("limit +", inputs.limit),
        ("limit -", false),
        ("reference switch", false),
    ];
    let raw = limits
        .iter()
        .enumerate()
        .filter(|(_, (_, on))| *on)
        .fold(0u8, |acc, (i, _)| acc | 1 << i);
    vec![
        IoGroup {
            name: "11 limits".into(),
            raw: Some(raw),
            bits: limits.iter().map(|(n, v)| bit(n, *v)).collect(),
            read: None,
        },
        IoGroup {
            name: "11 in".into(),
            raw: Some(0x01),
            bits: (1..=4).map(|i| bit(&format!("I{i}"), i == 1)).collect(),
            read: None,
        },
        IoGroup {
            name: "11 out".into(),
            raw: Some(0x00),
            bits: (1..=4)
                .map(|i| output(&format!("O{i}"), false, 0x11, Some(i - 1), false))
                .collect(),
            read: None,
        },
    ]
}

fn steps(protocol: Protocol, moving: bool) -> PerAxis<i64> {
    let shift = if moving { 1234 } else { 0 };
    match protocol {
        Protocol::Emp => PerAxis::new().with(Axis::X, 1_120_000 + shift * 10),
        _ => PerAxis::new()
            .with(Axis::X, 44_938 + shift)
            .with(Axis::Y, 20_000)
            .with(Axis::Z, -1),
    }
}

/// A conversation as the device task reports it: whole messages, each with
/// whose it is (`TrafficRecord::messages`).
fn traffic(protocol: Protocol) -> Vec<TrafficRecord> {
    let whole = |direction, bytes: &[u8], owner| {
        TrafficRecord::messages(direction, bytes, owner, &[bytes.len()])
    };
    let (sent, received) = (Direction::Sent, Direction::Received);
    match protocol {
        Protocol::Isel => vec![
            whole(sent, b"@07\r", Owner::Setup),
            whole(received, b"0", Owner::Setup),
            whole(sent, b"@0R7\r", Owner::Setup),
            whole(received, b"0", Owner::Setup),
            whole(sent, b"@0P\r", Owner::Poll),
            whole(received, b"000AF8A004E20FFFFFF", Owner::Poll),
        ],
        Protocol::Emcu => vec![
            whole(sent, b"#S200\r", Owner::Setup),
            whole(received, b"\r", Owner::Setup),
            whole(sent, b"$HZYX\x01", Owner::Setup),
            TrafficRecord {
                messages: vec![
                    MessageEnd::new(1, Owner::Setup),
                    MessageEnd::new(3, Owner::Controller),
                ],
                ..TrafficRecord::new(received, &b"\r\x02\r"[..])
            },
            whole(sent, b"@X\r", Owner::Poll),
            whole(received, b"@X000000\r", Owner::Poll),
        ],
        Protocol::Emp => vec![
            whole(sent, b"0211110000000000\x1a", Owner::Setup),
            whole(received, b"0311112200000000\x1a", Owner::Setup),
            whole(sent, b"2C11000000000000\x1a", Owner::Poll),
            whole(received, b"2D11002200111700\x1a", Owner::Poll),
        ],
    }
}

/// A model for `protocol` in `state`, `theme`, at time `t0 + 2 s`.
pub fn model_in(protocol: Protocol, theme: &str, state: State, t0: Instant) -> Model {
    let mut model = fresh(protocol, theme, t0);
    let t1 = t0 + Duration::from_millis(500);
    let t2 = t0 + Duration::from_secs(2);
    let axes: AxisSet = model.setup.axis_set();
    // The work zero (G54) at X 4000 steps, and the controller's there too.
    model
        .keypad
        .offsets
        .table
        .set(jogterm::offsets::System::G54, Axis::X, 4_000);
    let ready = MachineState {
        link_up: true,
        initialised: axes,
        referenced: axes,
        work_zero: PerAxis::new().with(Axis::X, 4_000),
        ..MachineState::default()
    };
    send(
        &mut model,
        [
            Event::Link(LinkState::Connected),
            Event::State(ready.clone()),
        ],
    );
    for record in traffic(protocol) {
        send(&mut model, [Event::Traffic(record)]);
    }
    send(
        &mut model,
        [
            Event::Io(io(protocol, t1, Inputs::default())),
            Event::Position(PositionSample {
                at: t1,
                steps: steps(protocol, false),
                source: PositionSource::Measured,
            }),
            Event::Stats(PollStats {
                position_rate_hz: 79.6,
                wire_limit_hz: 83.5,
            }),
        ],
    );
    let fault = |code: &str, meaning: &str, recovery| ControllerFault {
        command: match protocol {
            Protocol::Isel => "@0A5000,900,0,900,0,900,0,900".into(),
            Protocol::Emcu => "L9,X5000".into(),
            Protocol::Emp => "2A 11 01".into(),
        },
        code: code.into(),
        meaning: meaning.into(),
        recovery,
    };
    match state {
        State::Idle => {}
        State::Moving => {
            let source = if protocol == Protocol::Isel {
                PositionSource::Estimated
            } else {
                PositionSource::Measured
            };
            send(
                &mut model,
                [
                    Event::State(MachineState {
                        activity: Activity::Moving,
                        ..ready.clone()
                    }),
                    Event::Position(PositionSample {
                        at: t2,
                        steps: steps(protocol, true),
                        source,
                    }),
                ],
            );
        }
        State::EStop => {
            let f = fault(
                "9",
                "machine fault / emergency stop",
                Recovery::ClearEmergencyStop,
            );
            send(
                &mut model,
                [
                    Event::Io(io(
                        protocol,
                        t2,
                        Inputs {
                            estop: true,
                            ..Inputs::default()
                        },
                    )),
                    Event::Fault(f.clone()),
                    Event::State(MachineState {
                        estop: true,
                        referenced: AxisSet::EMPTY,
                        fault: Some(f),
                        ..ready.clone()
                    }),
                ],
            );
        }
        State::Limit => {
            let f = fault("2", "limit switch", Recovery::ReinitialiseAndReference);
            send(
                &mut model,
                [
                    Event::Io(io(
                        protocol,
                        t2,
                        Inputs {
                            limit: true,
                            ..Inputs::default()
                        },
                    )),
                    Event::Fault(f.clone()),
                    Event::State(MachineState {
                        limit: true,
                        referenced: AxisSet::EMPTY,
                        fault: Some(f),
                        ..ready.clone()
                    }),
                ],
            );
        }
        State::LinkLost => {
            send(
                &mut model,
                [
                    Event::Link(LinkState::Lost {
                        reason: "the port vanished (read: end of stream)".into(),
                    }),
                    Event::State(MachineState {
                        link_up: false,
                        ..ready.clone()
                    }),
                ],
            );
        }
    }
    update(&mut model, Msg::Tick(t2));
    model
}

pub fn render(model: &Model, width: u16, height: u16) -> Terminal<TestBackend> {
    let mut terminal = Terminal::new(TestBackend::new(width, height)).expect("test backend");
    terminal
        .draw(|f| f.render_widget(Screen(model), f.area()))
        .expect("draw");
    terminal
}

/// The screen as text, one line per row (trailing blanks kept off).
pub fn text(buf: &Buffer) -> String {
    let mut out = String::new();
    for y in 0..buf.area.height {
        let mut line = String::new();
        for x in 0..buf.area.width {
            line.push_str(buf[(x, y)].symbol());
        }
        out.push_str(line.trim_end());
        out.push('\n');
    }
    out
}

/// Every cell position where `needle` starts.
pub fn find(buf: &Buffer, needle: &str) -> Vec<(u16, u16)> {
    let mut hits = Vec::new();
    let chars: Vec<char> = needle.chars().collect();
    for y in 0..buf.area.height {
        for x in 0..buf.area.width {
            let matches = chars.iter().enumerate().all(|(i, c)| {
                let xi = x as usize + i;
                xi < buf.area.width as usize && buf[(xi as u16, y)].symbol().starts_with(*c)
            });
            if matches {
                hits.push((x, y));
            }
        }
    }
    hits
}

/// Carry out the editor's file and lint effects at once (in memory, the
/// lint on this thread) and feed their answers back; the other effects are
/// returned in order.
pub fn carry_out(m: &mut Model, effects: Vec<jogterm::ui::Effect>) -> Vec<jogterm::ui::Effect> {
    use jogterm::ui::Effect;
    use jogterm::ui::editor::io::{EditorIo, EditorMsg, perform};
    let mut rest = Vec::new();
    for effect in effects {
        match effect {
            Effect::Editor(io) => {
                let msg = match io {
                    EditorIo::Lint(job) => EditorMsg::Linted(Box::new(job.run())),
                    other => perform(other),
                };
                let more = update(m, Msg::Editor(msg));
                rest.extend(carry_out(m, more));
            }
            other => rest.push(other),
        }
    }
    rest
}

/// Let time pass until the lint has run on the text as it is.
pub fn settle(m: &mut Model, t0: Instant) {
    for i in 1..=5 {
        let effects = update(m, Msg::Tick(t0 + Duration::from_secs(3 + i)));
        carry_out(m, effects);
    }
}

/// A ready isel machine with `program` loaded in the editor as
/// `/work/part.isel`, linted, the program screen shown.
pub fn editing_isel(program: &str, t0: Instant) -> Model {
    use jogterm::ui::editor::io::EditorMsg;
    let mut m = model_in(Protocol::Isel, "dark", State::Idle, t0);
    let loaded = jogterm::program::store::Loaded {
        path: std::path::PathBuf::from("/work/part.isel"),
        text: program.to_string(),
        fingerprint: jogterm::program::store::Fingerprint::of(program.as_bytes()),
        lossy: false,
    };
    update(
        &mut m,
        Msg::Editor(EditorMsg::Open("/work/part.isel".into())),
    );
    let effects = update(
        &mut m,
        Msg::Editor(EditorMsg::Loaded {
            path: "/work/part.isel".into(),
            result: Ok(Some(loaded)),
            recovery: None,
        }),
    );
    carry_out(&mut m, effects);
    settle(&mut m, t0);
    m
}
