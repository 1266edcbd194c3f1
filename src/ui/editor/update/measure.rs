//! The new tool measured at a tool change in the console (issue 40, 3;
//! `docs/editor.md`, "Tool changes and pauses"), as `jogterm run` measures
//! it: after F6 at an `M6` of a job with a tool sensor (`probe.tool_sensor`),
//! Z goes up alone, X and Y over to the sensor, Z down to the point above
//! it (`probing::up_over_down`, each leg a go-to sent when the one before
//! has ended, `ui::legs`); Z probes down onto the sensor (`Request::Probe`,
//! the profile's `[probe]` speeds, back up where it began); the tool table
//! takes where it touched (`Effect::ToolMeasured`), and its offset against
//! the reference tool shifts every Z of the pieces after the change
//! (`Sequence::measured`); then back to the change position the same way,
//! and the next piece. Any stop, refusal, fault or lost link ends the job
//! there: nothing resumes.

use crate::axis::Axis;
use crate::device::api::{Event, Frame, JogId, PerAxis, ProbeEnd, Request};
use crate::device::describe::describe;
use crate::gcode::toolchange::Step as Next;
use crate::probing;
use crate::ui::editor::component::Effect;
use crate::ui::editor::job::{MeasureStage, Measuring, Phase};
use crate::ui::legs::{self, Legs};
use crate::ui::traffic_log::NoteLevel;

use super::Step;

/// Probe ids of the measure: apart from the keypad's jogs and limit jogs
/// and the console's touch-off (`ui::probe`, bit 62).
const IDS: u64 = 1 << 61;

/// The go-tos from `here` to `to` (machine steps), up, over and down.
fn go_tos(profile: &crate::config::Profile, here: &PerAxis<i64>, to: &PerAxis<i64>) -> Legs {
    Legs::new(
        probing::up_over_down(profile, here, to)
            .into_iter()
            .map(|leg| legs::Leg {
                target: leg.target,
                request: Request::MoveTo {
                    target: leg.target,
                    frame: Frame::Machine,
                    speed_hz: leg.speed_hz,
                },
            })
            .collect(),
    )
}

impl Step<'_, '_> {
    /// F6 at a tool change with a tool sensor: to the sensor.
    pub(super) fn measure_begin(&mut self, tool: String) {
        let profile = std::sync::Arc::clone(&self.ctx.setup.profile);
        let Some(Ok(sensor)) = profile.probe.tool_sensor_point() else {
            self.measure_failed(
                &tool,
                "the profile has no tool sensor (probe.tool_sensor)".into(),
            );
            return;
        };
        let to = probing::steps_of(&profile, sensor.iter());
        let legs = go_tos(&profile, &self.ctx.positions.xyz_steps(), &to);
        let Some(c) = self.e.chunked.as_mut() else {
            return;
        };
        let Some(p) = c.pieces.as_mut() else {
            return;
        };
        c.phase = Phase::Measuring;
        p.measure = Some(Measuring {
            tool: tool.clone(),
            stage: MeasureStage::ToSensor(legs),
        });
        let point: Vec<String> = sensor
            .iter()
            .map(|(axis, v)| format!("{axis} {}", crate::ui::position::format_amount(v)))
            .collect();
        self.say(
            NoteLevel::Info,
            format!(
                "{tool}: to the tool sensor at machine {}, then Z probes down onto it; Space \
                 ends the job",
                point.join(" ")
            ),
        );
        self.measure_leg(0);
    }

    /// The next go-to of the way to the sensor or back, from leg `from` on;
    /// past the last, the probe or the next piece.
    fn measure_leg(&mut self, from: usize) {
        let positions = self.ctx.positions;
        let at = |axis: Axis| positions.get(axis).map(|r| r.steps);
        let Some(m) = self.measuring() else {
            return;
        };
        let sent = match &mut m.stage {
            MeasureStage::ToSensor(legs) | MeasureStage::Back(legs) => legs.send_from(from, at),
            MeasureStage::Probing(_) => return,
        };
        if let Some((_, request)) = sent {
            self.out.effects.push(Effect::Device(request));
            return;
        }
        match m.stage {
            MeasureStage::ToSensor(_) => self.measure_probe(),
            _ => self.measure_returned(),
        }
    }

    fn measuring(&mut self) -> Option<&mut Measuring> {
        self.e.chunked.as_mut()?.pieces.as_mut()?.measure.as_mut()
    }

    /// Above the sensor: Z probes down onto it.
    fn measure_probe(&mut self) {
        let probe = match probing::probe_move(
            &self.ctx.setup.profile,
            Axis::Z,
            crate::device::api::Dir::Minus,
        ) {
            Ok(p) => p,
            Err(why) => {
                let tool = self.measuring().map(|m| m.tool.clone()).unwrap_or_default();
                self.measure_failed(&tool, why);
                return;
            }
        };
        let Some(c) = self.e.chunked.as_mut() else {
            return;
        };
        let Some(p) = c.pieces.as_mut() else {
            return;
        };
        p.probes += 1;
        let id = JogId(IDS | p.probes);
        if let Some(m) = p.measure.as_mut() {
            m.stage = MeasureStage::Probing(id);
        }
        self.out
            .effects
            .push(Effect::Device(Request::Probe { id, probe }));
    }

    /// The probe ended: the tool's offset into the table and the sequence,
    /// then back to the change position.
    fn measure_probed(&mut self, end: &ProbeEnd) {
        let profile = std::sync::Arc::clone(&self.ctx.setup.profile);
        let Some(tool) = self.measuring().map(|m| m.tool.clone()) else {
            return;
        };
        let what = format!("the measure of {tool}");
        let Some(touched) = probing::touched(end).cloned() else {
            let said = profile
                .axis(Axis::Z)
                .map(|z| probing::end_text(&what, (Axis::Z, z), end))
                .unwrap_or_else(|| what.clone());
            self.measure_failed(&tool, said);
            return;
        };
        let z = probing::units(&profile, Axis::Z, touched.get(Axis::Z).unwrap_or(0));
        // The console's table takes the same measure (`Effect::ToolMeasured`);
        // its offset is worked out here on a copy, by the same rule.
        let mut table = self.ctx.tools.table.clone();
        let offset = table.measured(&tool, z);
        self.out.effects.push(Effect::ToolMeasured {
            tool: tool.clone(),
            z,
        });
        let Some(g) = self.e.gcode.as_ref() else {
            return;
        };
        let Some(w) = g.converted.waits.as_ref() else {
            return;
        };
        let dz0 = w.dz0;
        let path = std::sync::Arc::clone(&w.path);
        let Some(p) = self.e.chunked.as_mut().and_then(|c| c.pieces.as_mut()) else {
            return;
        };
        p.sequence.measured(offset - dz0);
        let (index, to) = match p.sequence.step() {
            Next::Return { index, to } => (index, to),
            other => {
                let text = format!("the job ends: {other:?} is not the console's to do");
                self.job_log_end(crate::joblog::How::Error);
                self.chunked_end(text);
                return;
            }
        };
        let line = p.sequence.plan().first_line(&path, index + 1);
        let said = format!(
            "{what}: touched at machine Z {z:.4}: offset {offset:+.4} mm against the reference \
             tool {}: every Z{} is {offset:+.4} mm from the program's",
            table.reference.as_deref().unwrap_or("-"),
            line.map_or_else(String::new, |l| format!(" from line {l} on")),
        );
        self.say(NoteLevel::Info, said);
        // The probe ends where it began, above the sensor.
        let mut here = self.ctx.positions.xyz_steps();
        if let Some(Ok(sensor)) = profile.probe.tool_sensor_point() {
            for (axis, steps) in probing::steps_of(&profile, sensor.iter()).iter() {
                here.set(axis, steps);
            }
        }
        let back = probing::steps_of(
            &profile,
            [(Axis::X, to.x), (Axis::Y, to.y), (Axis::Z, to.z)],
        );
        let legs = go_tos(&profile, &here, &back);
        if let Some(m) = self.measuring() {
            m.stage = MeasureStage::Back(legs);
        }
        self.measure_leg(0);
    }

    /// Back at the change position: the next piece.
    fn measure_returned(&mut self) {
        let Some(c) = self.e.chunked.as_mut() else {
            return;
        };
        let Some(p) = c.pieces.as_mut() else {
            return;
        };
        p.measure = None;
        p.sequence.returned();
        let line = p
            .sequence
            .plan()
            .waits
            .get(p.piece)
            .map_or(0, |w| w.origin.line);
        c.phase = Phase::Waiting;
        self.pieces_go_on(line);
    }

    fn measure_failed(&mut self, tool: &str, why: String) {
        self.job_log_end(crate::joblog::How::Error);
        self.chunked_end(format!(
            "{tool} was not measured: {why}: the job ends here; nothing resumes"
        ));
    }

    /// A device event while the new tool is measured.
    pub(super) fn measure_event(&mut self, event: &Event) {
        let Some(m) = self.measuring() else {
            return;
        };
        let tool = m.tool.clone();
        match (event, &mut m.stage) {
            (Event::State(s), MeasureStage::ToSensor(legs) | MeasureStage::Back(legs)) => {
                if !legs.ended_by(s.activity) {
                    return;
                }
                let next = legs.current() + 1;
                if let Some(f) = &s.fault {
                    let why = format!("`{}`: {}", f.code, f.meaning);
                    self.measure_failed(&tool, why);
                    return;
                }
                self.measure_leg(next);
            }
            (Event::ProbeEnded { id, end }, MeasureStage::Probing(probing)) if id == probing => {
                self.measure_probed(end);
            }
            (
                Event::Refused { request, reason },
                MeasureStage::ToSensor(legs) | MeasureStage::Back(legs),
            ) if legs
                .current_request()
                .is_some_and(|r| describe(r) == *request) =>
            {
                self.measure_failed(&tool, format!("its move was refused: {reason}"));
            }
            (Event::Fault(f), _) => {
                let why = format!("`{}`: {}", f.code, f.meaning);
                self.measure_failed(&tool, why);
            }
            _ => {}
        }
    }
}
