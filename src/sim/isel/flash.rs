//! The controller's parameters of chapter 4 (the `@0I…` init commands) and
//! its flash memory: the stored init values and the stored CNC program.
//!
//! The init values live twice: the working copy the controller runs with
//! (RAM) and the copy in flash. `@0IW` copies RAM to flash, `@0IL` flash to
//! RAM, `@0IX` the built-in defaults to RAM (isel manual 4.2.17-4.2.19); a
//! power-up or a reset (0xFE) loads RAM from flash (manual 4.1).

use crate::axis::AxisSet;
use crate::proto::isel::ports::LimitSwitchSettings;
use crate::proto::isel::{CncCommand, InitCommand, InputPort, OutputPort, PortSignal, PortWatch};

/// Reference speed of every axis until `@0Id` says otherwise, in Hz. The
/// manual gives no default (4.2.1); jogterm's simulator uses this one
/// (`docs/protocols.md`, isel).
pub const DEFAULT_REFERENCE_HZ: u32 = 2000;
/// Start-stop frequency default, Hz (manual 2.2.15).
pub const DEFAULT_START_STOP_HZ: u32 = 300;
/// Acceleration default, Hz/ms (manual 2.2.16).
pub const DEFAULT_ACCELERATION: u32 = 100;
/// `@0IE` default: every limit switch enabled and high-active. The simulated
/// switches are wired to match it (`docs/simulator.md`, isel).
pub const DEFAULT_LIMIT_WORD: u16 = 0x3333;

/// A port watch that is switched off (mask 0, manual 4.2.11).
const WATCH_OFF: PortWatch = PortWatch {
    port: InputPort::User,
    mask: 0,
    value: 0,
};

/// The init values of isel manual chapter 4.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InitValues {
    /// `Id`: default reference speeds X, Y, Z, A in Hz (4.2.1).
    pub reference_speeds: [u32; 4],
    /// `IF`: steps to clear the reference switch after a reference run (4.2.2).
    pub clear_steps: [u32; 4],
    /// `IJ`: default acceleration, Hz/ms (4.2.3).
    pub acceleration: u32,
    /// `Ij`: default start-stop frequency, Hz (4.2.4).
    pub start_stop: u32,
    /// `IO`: IO-only mode (4.2.5).
    pub io_only: bool,
    /// `IE`: enable and active level of every limit switch (4.2.6).
    pub limit_switches: LimitSwitchSettings,
    /// `Ie`: axes whose switch inputs 1 and 2 are swapped (4.2.7).
    pub swap_limits: AxisSet,
    /// `ID`: axes whose direction is inverted (4.2.8).
    pub invert_directions: AxisSet,
    /// `IR`: axes that reference towards their positive side (4.2.9).
    pub invert_reference: AxisSet,
    /// `IT`: rotary axes (4.2.10).
    pub rotary: AxisSet,
    /// `IA`: abort input while a program runs (4.2.11).
    pub abort_input: PortWatch,
    /// `Ia`: error signal output while a program runs (4.2.12).
    pub error_output: PortSignal,
    /// `IH`: hood input while a program runs (4.2.13).
    pub hood_input: PortWatch,
    /// `IN`: external E-stop input while a program runs (4.2.14).
    pub estop_input: PortWatch,
    /// `IC`: 9600 baud from the next power-up (4.2.15).
    pub baud_9600: bool,
    /// `IU`: the user info `@0U` reports (4.2.16).
    pub user_info: String,
}

impl InitValues {
    /// The controller's built-in defaults with the machine's clearing steps
    /// and rotary axes (the simulated controller was commissioned for its
    /// machine, `docs/simulator.md`).
    pub fn factory(clear_steps: [u32; 4], rotary: AxisSet) -> InitValues {
        InitValues {
            reference_speeds: [DEFAULT_REFERENCE_HZ; 4],
            clear_steps,
            acceleration: DEFAULT_ACCELERATION,
            start_stop: DEFAULT_START_STOP_HZ,
            io_only: false,
            limit_switches: LimitSwitchSettings::from_word(DEFAULT_LIMIT_WORD),
            swap_limits: AxisSet::EMPTY,
            invert_directions: AxisSet::EMPTY,
            invert_reference: AxisSet::EMPTY,
            rotary,
            abort_input: WATCH_OFF,
            error_output: PortSignal {
                port: OutputPort::User,
                mask: 0,
                value: 0,
            },
            hood_input: WATCH_OFF,
            estop_input: WATCH_OFF,
            baud_9600: false,
            user_info: String::new(),
        }
    }

    /// Store the value an init command sets. `IL`, `IW` and `IX` move whole
    /// sets of values and are the controller's job; they return `false`.
    pub fn apply(&mut self, command: &InitCommand) -> bool {
        match command {
            InitCommand::DefaultReferenceSpeeds(v) => self.reference_speeds = *v,
            InitCommand::ReferenceClearSteps(v) => self.clear_steps = *v,
            InitCommand::DefaultAcceleration(v) => self.acceleration = *v,
            InitCommand::DefaultStartStop(v) => self.start_stop = *v,
            InitCommand::IoOnly(on) => self.io_only = *on,
            InitCommand::LimitSwitches(word) => {
                self.limit_switches = LimitSwitchSettings::from_word(*word)
            }
            InitCommand::SwapLimitSwitches(m) => self.swap_limits = *m,
            InitCommand::InvertDirections(m) => self.invert_directions = *m,
            InitCommand::InvertReferenceDirections(m) => self.invert_reference = *m,
            InitCommand::RotaryAxes(m) => self.rotary = *m,
            InitCommand::AbortInput(w) => self.abort_input = *w,
            InitCommand::ErrorOutput(s) => self.error_output = *s,
            InitCommand::HoodInput(w) => self.hood_input = *w,
            InitCommand::EmergencyStopInput(w) => self.estop_input = *w,
            InitCommand::Baud9600(on) => self.baud_9600 = *on,
            InitCommand::SetUserInfo(text) => self.user_info = text.clone(),
            InitCommand::LoadFromFlash
            | InitCommand::WriteToFlash
            | InitCommand::RestoreDefaults => return false,
        }
        true
    }

    /// The baud rate a power-up with these values in flash starts with
    /// (manual 4.2.15, `docs/decisions.md` "Serial defaults").
    pub fn baud(&self) -> u32 {
        if self.baud_9600 { 9600 } else { 19200 }
    }
}

/// A CNC program in flash (isel manual 2.2.13, 3.1).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StoredProgram {
    /// The stored commands, the closing `9` included once it arrived.
    pub lines: Vec<CncCommand>,
    /// Closed by `9` without an error: only a valid program runs (3.2.9).
    pub valid: bool,
    /// The reference speeds when `9` arrived: the manual stores "status
    /// information (e.g. the current reference speed)" with the program and
    /// a run starts with them (3.2.9).
    pub reference_speeds: [u32; 4],
}

/// The controller's flash: init values and the program.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Flash {
    pub init: InitValues,
    pub program: Option<StoredProgram>,
}

impl Flash {
    pub fn new(init: InitValues) -> Flash {
        Flash {
            init,
            program: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axis::Axis;

    #[test]
    fn init_commands_set_their_value_and_flash_commands_are_left_to_the_controller() {
        let mut v = InitValues::factory([760; 4], AxisSet::EMPTY);
        assert_eq!(v.baud(), 19200);
        assert!(v.apply(&InitCommand::Baud9600(true)));
        assert_eq!(v.baud(), 9600);
        assert!(v.apply(&InitCommand::LimitSwitches(57343)));
        assert_eq!(v.limit_switches.to_word(), 57343);
        assert!(
            v.apply(&InitCommand::InvertReferenceDirections(AxisSet::from_iter(
                [Axis::Y]
            )))
        );
        assert!(v.invert_reference.contains(Axis::Y));
        for c in [
            InitCommand::LoadFromFlash,
            InitCommand::WriteToFlash,
            InitCommand::RestoreDefaults,
        ] {
            assert!(!v.apply(&c));
        }
        let factory = InitValues::factory([760; 4], AxisSet::EMPTY);
        assert_eq!(factory.limit_switches.to_word(), DEFAULT_LIMIT_WORD);
        assert_eq!(factory.abort_input.mask, 0);
    }
}
