//! One DRS-500-ECS drive: what it does with each request and what it sends
//! back, built on the EMP core's typed requests and replies.
//!
//! State follows the manual's commands: switched on (`02`/`04`), the operating
//! mode of `22` (none until then, and again after `24`, `2A 03` and `20 05`,
//! which leave the motor without current), the sample rate (`20 19`), the
//! position counter, I/O, ADC, EEPROM and RTC. The axis itself is a
//! [`Servo`]. The decisions this follows are in `docs/protocols.md` (EMP).

use std::time::{Duration, Instant};

use super::analog::{self, Analog};
use super::clock::RtcClock;
use super::config::DriveConfig;
use super::servo::{LongAction, Outcome, Servo, Switches};
use crate::axis::Axis;
use crate::proto::emp::request::{I2C_15_KHZ, code};
use crate::proto::emp::{
    AdcPolarity, Command, DriveAddress, ErrorCode, Frame, Gain, IdentText, IdentityQuery, Inputs,
    JoystickChannel, JoystickParameters, Limits, OperatingMode, Outputs, Position, ReloadValue,
    Reply, ReplyBody, RequestError, SubMode, Velocity,
};

/// Processing time between the end of a request and its reply: "1,6 ms
/// Verarbeitung in der Steuerung" (EMP manual, "Chronologischer
/// Befehlsumfang").
pub const PROCESSING_TIME: Duration = Duration::from_micros(1600);

/// Processing time of `50` with the I²C bus at 15 kHz: the round trip grows
/// from 10.8 ms to 14 ms ("kann sich die Datenübertragungszeit allerdings auf
/// 14 ms erhöhen, wenn die interne I2C-Busfrequenz von 96 kHz auf 15 kHz
/// reduziert wird"), so processing takes 3.2 ms more.
pub const SLOW_ADC_PROCESSING_TIME: Duration = Duration::from_micros(4800);

/// One `LOOPCycles` unit of `20 02`: "01" = 10 ms.
const JOYSTICK_LOOP: Duration = Duration::from_millis(10);

/// The HMI EEPROM: 64 KiB, erased (FF) when the simulator starts.
const EEPROM_SIZE: usize = 1 << 16;

/// Joystick parameters before any `20 02`: a reading every loop, bipolar,
/// factor 1, the 64 mV dead band of Beispiel 5.
const DEFAULT_JOYSTICK: JoystickParameters = JoystickParameters {
    loop_cycles: 1,
    polarity: AdcPolarity::Bipolar,
    multiplier: Gain::X1,
    hysteresis_mv: 0x40,
};

/// What a velocity-type mode is following.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum SetPoint {
    /// PV / IV: counts per sample.
    Velocity(Velocity),
    /// PWM / TPWM `2A 02`: torque against the load model.
    Torque(Velocity),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Joystick {
    channel: JoystickChannel,
    sub_mode: SubMode,
    /// Following the joystick. In IV only after the host's first `2A 00`
    /// (Beispiel 5: "wenn aber im IV-Betrieb, dann MotorMove vom PC mit V=01
    /// initiieren").
    following: bool,
    /// When the next reading takes effect.
    due: Option<Instant>,
}

/// Everything one drive shows, for `describe` and tests.
#[derive(Debug, Clone, PartialEq)]
pub struct DriveSnapshot {
    pub ds: DriveAddress,
    pub axis: Option<Axis>,
    pub on: bool,
    /// `None`: no mode set, the motor has no current.
    pub mode: Option<OperatingMode>,
    /// The position counter `2C` reads.
    pub counter: Position,
    /// Where the axis physically is, counts from machine 0.
    pub physical: f64,
    /// Counts per second, signed.
    pub speed: f64,
    /// `idle`, `running`, `positioning` or `homing`.
    pub activity: &'static str,
    pub limits: Limits,
    pub inputs: Inputs,
    pub outputs: Outputs,
    pub last_error: ErrorCode,
    pub reload: ReloadValue,
    /// Analogue channels 1-3 in mV.
    pub analog_mv: [f64; 3],
}

#[derive(Debug, Clone)]
pub(crate) struct Drive {
    cfg: DriveConfig,
    on: bool,
    mode: Option<OperatingMode>,
    reload: ReloadValue,
    /// Counter = round(physical) + offset.
    offset: i64,
    servo: Servo,
    set_point: Option<SetPoint>,
    joystick: Option<Joystick>,
    joystick_params: JoystickParameters,
    last_error: ErrorCode,
    inputs: Inputs,
    outputs: Outputs,
    analog: Analog,
    i2c_slow: bool,
    eeprom: Vec<u8>,
    rtc: RtcClock,
    /// `fault stall` is armed for this drive's next long action.
    pub(crate) stall_next: bool,
}

/// A counter value as the 25-bit register holds it: it wraps like the
/// encoder's counter (decision 3's range, -2^24 to 2^24 - 1).
fn wrap_25(counter: i64) -> Position {
    let wrapped = (counter + (1 << 24)).rem_euclid(1 << 25) - (1 << 24);
    Position::new(wrapped).unwrap_or(Position::ZERO)
}

impl Drive {
    pub(crate) fn new(cfg: DriveConfig, reload: ReloadValue) -> Drive {
        let switches = Switches {
            limit_plus: cfg.limit_plus,
            limit_minus: cfg.limit_minus,
            reference_cam: cfg.reference_cam,
        };
        Drive {
            servo: Servo::new(cfg.start_position, switches, cfg.accel),
            // The counter starts at 0 where the axis stands at power-up.
            offset: -(cfg.start_position.round() as i64),
            analog: Analog::new(cfg.adc_unipolar),
            on: false,
            mode: None,
            reload,
            set_point: None,
            joystick: None,
            joystick_params: DEFAULT_JOYSTICK,
            last_error: ErrorCode::NONE,
            inputs: Inputs::NONE,
            outputs: Outputs::NONE,
            i2c_slow: false,
            eeprom: vec![0xFF; EEPROM_SIZE],
            rtc: RtcClock::new(),
            stall_next: false,
            cfg,
        }
    }

    pub(crate) fn ds(&self) -> DriveAddress {
        self.cfg.ds
    }

    /// The simulator has seen time for the first time: the RTC starts.
    pub(crate) fn start_clock(&mut self, now: Instant) {
        self.rtc.start(now);
    }

    /// How long the drive works on a request before it answers.
    pub(crate) fn processing_time(&self, command: Option<&Command>) -> Duration {
        match command {
            Some(Command::ReadAdc(_)) if self.i2c_slow => SLOW_ADC_PROCESSING_TIME,
            _ => PROCESSING_TIME,
        }
    }

    pub(crate) fn counter(&self, t: Instant) -> Position {
        wrap_25(self.servo.position(t).round() as i64 + self.offset)
    }

    fn ready(&self, body: ReplyBody) -> Reply {
        Reply::Ready {
            ds: self.cfg.ds,
            body,
        }
    }

    fn busy(&self, body: ReplyBody) -> Reply {
        Reply::Busy {
            ds: self.cfg.ds,
            body,
        }
    }

    fn reject(&mut self, cmd: u8, error: ErrorCode) -> Reply {
        self.last_error = error;
        Reply::Rejected {
            ds: self.cfg.ds,
            cmd: cmd & !1,
        }
    }

    /// A frame for this drive that is no valid request: `EE`, and `0A` tells
    /// why (decision 2). Before "unit on" the reason is always that.
    pub(crate) fn reject_frame(&mut self, frame: &Frame, error: &RequestError) -> Reply {
        self.last_error = if self.on {
            ErrorCode::from(error)
        } else {
            ErrorCode::NOT_ON
        };
        Reply::rejecting(frame).unwrap_or(Reply::Rejected {
            ds: self.cfg.ds,
            cmd: frame.cmd & !1,
        })
    }

    /// Carry out a request at `t` (when processing ends) and answer it.
    pub(crate) fn execute(&mut self, command: Command, t: Instant) -> Vec<Reply> {
        // "Ohne diesen Einschalt-Befehl werden keine Kommandos angenommen";
        // `0A` still answers, or nobody could learn why (decision 2), unless
        // the drive is the variant that takes the manual literally.
        let taken_while_off = match command {
            Command::On(_) => true,
            Command::LastError => !self.cfg.rejects_0a_before_on,
            _ => false,
        };
        if !self.on && !taken_while_off {
            return vec![self.reject(command.cmd(), ErrorCode::NOT_ON)];
        }
        match self.run(command, t) {
            Ok(replies) => replies,
            Err(error) => {
                // A stop, move or mode change that cannot be done still ends
                // what ran (the host's correlator counts it as ended,
                // docs/protocols.md EMP); the axis brakes and holds.
                if command.ends_motion() {
                    self.set_point = None;
                    self.servo.brake(t, self.cfg.accel);
                }
                vec![self.reject(command.cmd(), error)]
            }
        }
    }

    fn run(&mut self, command: Command, t: Instant) -> Result<Vec<Reply>, ErrorCode> {
        let pos = self.counter(t);
        let one = |reply| Ok(vec![reply]);
        match command {
            Command::Identify(query) => {
                let text = match query {
                    IdentityQuery::Version => {
                        IdentText::version(self.cfg.version.0, self.cfg.version.1)
                    }
                    IdentityQuery::DeviceNumber => IdentText::device_number(self.cfg.device_number),
                };
                // The configuration was checked, so the text can be built.
                one(Reply::Identity(text.map_err(|_| ErrorCode::BAD_PARAMETER)?))
            }
            Command::On(_) => {
                self.on = true;
                self.last_error = ErrorCode::NONE;
                one(self.ready(ReplyBody::On))
            }
            Command::Off => {
                // "funktionell abgeschaltet aber nicht strommäßig getrennt":
                // the counter and the outputs stay, the motor loses current.
                self.cut_current(t);
                self.on = false;
                one(self.ready(ReplyBody::Off))
            }
            Command::Hold => {
                // The mode stays selected (unlike 2A 03 and 20 05 the manual
                // asks for no new mode); a joystick lets go of the axis.
                self.set_point = None;
                if self.joystick.take().is_some() {
                    self.mode = Some(OperatingMode::JoystickOff);
                }
                self.servo.brake(t, self.cfg.accel);
                one(self.ready(ReplyBody::Hold))
            }
            Command::LastError => one(self.ready(ReplyBody::LastError(self.last_error))),
            Command::JoystickParameters(p) => {
                self.joystick_params = p;
                one(self.ready(ReplyBody::Settings))
            }
            Command::SetPosition(p) => {
                // "ACHTUNG! Der Regler wird abgeschaltet und die Betriebsart
                // muss erneut gesetzt werden."
                self.cut_current(t);
                self.offset = i64::from(p.increments()) - self.servo.position(t).round() as i64;
                one(self.ready(ReplyBody::PositionSet(p)))
            }
            Command::SampleRate(r) => {
                self.reload = r;
                // A running velocity set-point changes speed with the rate.
                if let Some(sp @ SetPoint::Velocity(_)) = self.set_point
                    && self.servo.follows_set_point()
                {
                    let speed = self.speed_of(sp);
                    self.servo.run(t, speed);
                }
                one(self.ready(ReplyBody::Settings))
            }
            Command::MotorEnable(mode) => {
                // A new mode starts from rest with no set-point.
                self.set_point = None;
                self.servo.brake(t, self.cfg.accel);
                self.mode = Some(mode);
                self.joystick = match mode {
                    OperatingMode::Joystick { channel, sub_mode } => {
                        let following = sub_mode != SubMode::Iv;
                        Some(Joystick {
                            channel,
                            sub_mode,
                            following,
                            due: following.then(|| t + self.joystick_period()),
                        })
                    }
                    _ => None,
                };
                one(self.ready(ReplyBody::MotorEnabled(pos)))
            }
            Command::MotorDisable => {
                self.cut_current(t);
                one(self.ready(ReplyBody::MotorDisabled))
            }
            Command::Home { fast, slow } => {
                if !matches!(
                    self.mode,
                    Some(
                        OperatingMode::Pv
                            | OperatingMode::Iv
                            | OperatingMode::Pwm
                            | OperatingMode::Tpwm
                    )
                ) {
                    return Err(ErrorCode::WRONG_MODE);
                }
                self.set_point = None;
                let fast = self.velocity_speed(fast.value().into(), false).abs();
                let slow = self.velocity_speed(slow.value().into(), false).abs();
                let mut replies = vec![self.busy(ReplyBody::Homing(pos))];
                if std::mem::take(&mut self.stall_next) {
                    self.servo.stall(t);
                } else if self.servo.home(t, fast, slow) {
                    replies.push(self.homed(t));
                }
                Ok(replies)
            }
            Command::Drive { velocity, target } => match self.mode {
                Some(OperatingMode::Pv | OperatingMode::Iv) => {
                    self.follow(t, SetPoint::Velocity(velocity))?;
                    one(self.ready(ReplyBody::Moved(pos)))
                }
                Some(OperatingMode::Pwm) => {
                    self.follow(t, SetPoint::Torque(velocity))?;
                    one(self.ready(ReplyBody::Moved(pos)))
                }
                Some(OperatingMode::Joystick { sub_mode, .. }) => {
                    // The host's value holds until the next reading; in IV it
                    // starts the controller (Beispiel 5: "Der Motor fährt kurz
                    // an und bleibt dann stehen").
                    let set_point = match sub_mode {
                        SubMode::Pwm => SetPoint::Torque(velocity),
                        SubMode::Pv | SubMode::Iv => SetPoint::Velocity(velocity),
                    };
                    self.follow(t, set_point)?;
                    let period = self.joystick_period();
                    if let Some(j) = self.joystick.as_mut() {
                        j.following = true;
                        j.due = Some(t + period);
                    }
                    one(self.ready(ReplyBody::Moved(pos)))
                }
                Some(OperatingMode::Tpwm) => {
                    if velocity.is_stop() {
                        // Positioning at speed 0 would never arrive.
                        return Err(ErrorCode::BAD_PARAMETER);
                    }
                    let speed = f64::from(velocity.value()).abs();
                    self.position_to(t, target, speed)
                }
                Some(OperatingMode::JoystickOff) | None => Err(ErrorCode::WRONG_MODE),
            },
            Command::MoveTo { vmax, target } => {
                if self.mode != Some(OperatingMode::Tpwm) {
                    return Err(ErrorCode::WRONG_MODE);
                }
                self.position_to(t, target, f64::from(vmax.value()))
            }
            Command::Torque(torque) => {
                if self.mode != Some(OperatingMode::Tpwm) {
                    return Err(ErrorCode::WRONG_MODE);
                }
                self.follow(t, SetPoint::Torque(torque))?;
                one(self.ready(ReplyBody::Moved(pos)))
            }
            Command::FastStop => {
                // "Danach ist der Motor stromlos und muss erneut mit seiner
                // Betriebsart geladen werden."
                self.cut_current(t);
                one(self.ready(ReplyBody::Moved(pos)))
            }
            Command::ReadPosition => one(self.ready(ReplyBody::Position(pos))),
            Command::ReadInputs => one(self.ready(ReplyBody::Inputs {
                limits: self.servo.switches(t),
                inputs: self.inputs,
            })),
            Command::WriteOutputs(outputs) => {
                self.outputs = outputs;
                one(self.ready(ReplyBody::Outputs {
                    limits: self.servo.switches(t),
                    outputs,
                }))
            }
            Command::EepromRead { address, .. } => {
                let byte = self.eeprom.get(usize::from(address)).copied();
                one(self.ready(ReplyBody::EepromData(byte.ok_or(ErrorCode::BAD_PARAMETER)?)))
            }
            Command::EepromWrite { address, data, .. } => {
                let cell = self.eeprom.get_mut(usize::from(address));
                *cell.ok_or(ErrorCode::BAD_PARAMETER)? = data;
                one(self.ready(ReplyBody::EepromDone))
            }
            Command::I2cFrequency(setting) => {
                self.i2c_slow = setting == I2C_15_KHZ;
                one(self.ready(ReplyBody::EepromDone))
            }
            Command::ReadAdc(mode) => one(self.ready(ReplyBody::Adc(self.analog.read(mode)))),
            Command::ReadTime => {
                let time = self.rtc.time(t).map_err(|_| ErrorCode::BAD_PARAMETER)?;
                one(self.ready(ReplyBody::Time(time)))
            }
            Command::ReadDate => {
                let date = self.rtc.date(t).map_err(|_| ErrorCode::BAD_PARAMETER)?;
                one(self.ready(ReplyBody::Date(date)))
            }
            Command::WriteTime(time) => {
                self.rtc.set_time(t, time);
                one(self.ready(ReplyBody::RtcDone))
            }
            Command::WriteDate(date) => {
                self.rtc.set_date(t, date);
                one(self.ready(ReplyBody::RtcDone))
            }
        }
    }

    /// The motor loses its current (`04`, `24`, `2A 03`, `20 05`): the
    /// self-locking spindle stops the axis hard, and the mode must be set
    /// again.
    fn cut_current(&mut self, t: Instant) {
        self.servo.brake(t, self.cfg.fast_decel);
        self.mode = None;
        self.joystick = None;
        self.set_point = None;
    }

    fn joystick_period(&self) -> Duration {
        JOYSTICK_LOOP * u32::from(self.joystick_params.loop_cycles)
    }

    fn pv(&self) -> bool {
        matches!(
            self.mode,
            Some(OperatingMode::Pv)
                | Some(OperatingMode::Joystick {
                    sub_mode: SubMode::Pv,
                    ..
                })
        )
    }

    /// Counts per second of a velocity byte: |v| counts per sample at the
    /// sample rate 12.5 MHz / RelVal (the manual's "Berechnung", see
    /// `proto::emp::feed`), clipped at the motor's top speed.
    fn velocity_speed(&self, v: f64, pv: bool) -> f64 {
        let droop = if pv { 1.0 - self.cfg.pv_droop } else { 1.0 };
        let speed = v * self.reload.frequency_hz() * droop;
        speed.clamp(-self.cfg.max_speed, self.cfg.max_speed)
    }

    /// Counts per second under a torque: the load's friction holds torques up
    /// to `friction`; above it the speed grows by `torque_gain` per unit.
    fn torque_speed(&self, torque: Velocity) -> f64 {
        let t = f64::from(torque.value());
        let excess = t.abs() - f64::from(self.cfg.friction);
        if excess <= 0.0 {
            return 0.0;
        }
        t.signum() * (excess * self.cfg.torque_gain).min(self.cfg.max_speed)
    }

    fn speed_of(&self, set_point: SetPoint) -> f64 {
        match set_point {
            SetPoint::Velocity(v) => self.velocity_speed(f64::from(v.value()), self.pv()),
            SetPoint::Torque(v) => self.torque_speed(v),
        }
    }

    /// Follow a set-point, unless it points into an active limit switch.
    fn follow(&mut self, t: Instant, set_point: SetPoint) -> Result<(), ErrorCode> {
        let speed = self.speed_of(set_point);
        if speed != 0.0 && self.servo.blocks(t, speed.signum()) {
            return Err(ErrorCode::LIMIT_SWITCH);
        }
        self.servo.run(t, speed);
        self.set_point = Some(set_point);
        Ok(())
    }

    /// TP: position to `target` (counter value) at `speed` counts per sample.
    fn position_to(
        &mut self,
        t: Instant,
        target: Position,
        speed: f64,
    ) -> Result<Vec<Reply>, ErrorCode> {
        let here = self.servo.position(t);
        let goal = (i64::from(target.increments()) - self.offset) as f64;
        if goal != here && self.servo.blocks(t, (goal - here).signum()) {
            return Err(ErrorCode::LIMIT_SWITCH);
        }
        self.set_point = None;
        let speed = self.velocity_speed(speed, false).abs();
        let pos = self.counter(t);
        let mut replies = vec![self.busy(ReplyBody::Moved(pos))];
        if std::mem::take(&mut self.stall_next) {
            self.servo.stall(t);
        } else if self.servo.position_to(t, goal, speed, self.cfg.accel) {
            replies.push(self.ready(ReplyBody::Moved(self.counter(t))));
        }
        Ok(replies)
    }

    /// The reference point is reached: the counter becomes 0 there.
    fn homed(&mut self, t: Instant) -> Reply {
        self.offset = -(self.servo.position(t).round() as i64);
        self.ready(ReplyBody::Homing(self.counter(t)))
    }

    /// When the drive next needs `on_event`.
    pub(crate) fn next_event(&self) -> Option<Instant> {
        let joystick = self.joystick.and_then(|j| j.due);
        match (self.servo.next_event(), joystick) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// Handle what is due at `t`; a long action's end is answered.
    pub(crate) fn on_event(&mut self, t: Instant) -> Option<Reply> {
        let servo_due = self.servo.next_event().filter(|s| *s <= t);
        if let Some(j) = self.joystick
            && let Some(due) = j.due.filter(|d| *d <= t)
            && servo_due.is_none_or(|s| due <= s)
        {
            self.read_joystick(j, due);
            return None;
        }
        let outcome = self.servo.on_event(t)?;
        match outcome {
            Outcome::StoppedAtLimit => {
                self.set_point = None;
                self.last_error = ErrorCode::LIMIT_SWITCH;
                None
            }
            Outcome::Finished {
                action: LongAction::Homing,
                ok: true,
            } => {
                let at = servo_due.unwrap_or(t);
                Some(self.homed(at))
            }
            Outcome::Finished {
                action: LongAction::Positioning,
                ok: true,
            } => {
                let at = servo_due.unwrap_or(t);
                Some(self.ready(ReplyBody::Moved(self.counter(at))))
            }
            Outcome::Finished { action, ok: false } => {
                let cmd = match action {
                    LongAction::Homing => code::HOME,
                    LongAction::Positioning => code::MOVE,
                };
                Some(self.reject(cmd, ErrorCode::LIMIT_SWITCH))
            }
        }
    }

    fn read_joystick(&mut self, mut j: Joystick, at: Instant) {
        j.due = None;
        self.joystick = Some(j);
        if !j.following {
            return;
        }
        let v = analog::joystick_velocity(self.analog.joystick(j.channel), &self.joystick_params);
        let set_point = match j.sub_mode {
            SubMode::Pwm => SetPoint::Torque(v),
            SubMode::Pv | SubMode::Iv => SetPoint::Velocity(v),
        };
        // Pushing into an active limit switch does nothing.
        if self.follow(at, set_point).is_err() {
            self.servo.run(at, 0.0);
            self.set_point = None;
        }
    }

    /// Where the axis physically is at `t`, counts from machine 0.
    pub(crate) fn physical(&self, t: Instant) -> f64 {
        self.servo.position(t)
    }

    /// An operator sets input `n` (1-4).
    pub(crate) fn input(&self, n: u8) -> bool {
        self.inputs.get(n)
    }

    pub(crate) fn set_input(&mut self, n: u8, on: bool) {
        self.inputs = self.inputs.with(n, on);
    }

    /// An operator changes analogue channel 1-3; a joystick on it is read at
    /// its next loop.
    pub(crate) fn set_analog(&mut self, channel: usize, mv: f64, now: Instant) -> bool {
        if !self.analog.set(channel, mv) {
            return false;
        }
        let period = self.joystick_period();
        if let Some(j) = self.joystick.as_mut()
            && j.following
        {
            j.due.get_or_insert(now + period);
        }
        true
    }

    pub(crate) fn analog_mv(&self, channel: usize) -> f64 {
        self.analog.millivolts(channel)
    }

    pub(crate) fn snapshot(&self, t: Instant) -> DriveSnapshot {
        DriveSnapshot {
            ds: self.cfg.ds,
            axis: self.cfg.axis,
            on: self.on,
            mode: self.mode,
            counter: self.counter(t),
            physical: self.servo.position(t),
            speed: self.servo.velocity(t),
            activity: self.servo.activity_name(),
            limits: self.servo.switches(t),
            inputs: self.inputs,
            outputs: self.outputs,
            last_error: self.last_error,
            reload: self.reload,
            analog_mv: [1, 2, 3].map(|c| self.analog.millivolts(c)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_counter_wraps_at_25_bits() {
        assert_eq!(wrap_25(0).increments(), 0);
        assert_eq!(wrap_25(-1).to_word(), 0x01FF_FFFF);
        assert_eq!(wrap_25(1 << 24), Position::MIN);
        assert_eq!(wrap_25((1 << 24) - 1), Position::MAX);
        assert_eq!(wrap_25(-(1 << 24) - 1), Position::MAX);
    }
}
