//! A G-code file opened in the console (issue 40): imported with the
//! session's work offsets, a job outside the soft limits opened with its
//! errors, and checked again (and converted) once the zero is set.

use super::*;
use crate::axis::Axis;
use crate::offsets::System;
use crate::ui::editor::Planes;
use crate::ui::editor::gcode_open::{GcodeJob, check};

/// Carry out the G-code imports among `out`'s effects, as the worker does,
/// and hand their results back.
fn import_all(host: &mut Host, e: &mut Editor, out: Outcome) -> Vec<GcodeJob> {
    let mut asked = Vec::new();
    for effect in out.effects {
        if let Effect::Io(EditorIo::ImportGcode(job)) = effect {
            asked.push((*job).clone());
            let checked = check(*job);
            host.send(e, Input::Msg(EditorMsg::GcodeChecked(Box::new(checked))));
        }
    }
    asked
}

/// A job below the shipped isel profile's Z range with its zero at the
/// reference point: its first cut plunges 1 mm below Z 0.
const JOB: &str = "G21 G90\nG0 X10 Y10 Z5\nG1 Z-1 F100\nG1 X20\nG0 Z5\nM30\n";

fn write_job(dir: &std::path::Path) -> PathBuf {
    let path = dir.join("part.nc");
    std::fs::write(&path, JOB).expect("write");
    path
}

#[test]
fn ctrl_o_on_a_gcode_file_imports_it_with_the_sessions_offsets() {
    let dir = tempfile::tempdir().expect("dir");
    let path = write_job(dir.path());
    let mut host = Host::isel();
    host.offsets.set(System::G54, Axis::Z, 20 * 400);
    let mut e = Editor::new(&host.setup, host.now);
    // The open dialog's path ends in `load`, as Ctrl-O's does.
    let out = host.send(&mut e, Input::Msg(EditorMsg::Open(path.clone())));
    let asked = import_all(&mut host, &mut e, out);
    assert_eq!(asked.len(), 1, "one import");
    assert_eq!(asked[0].offsets, host.offsets);
    let job = e.job.as_ref().expect("the job is open");
    assert!(job.report.errors.is_empty(), "{:?}", job.report.errors);
    assert_eq!(e.planes, Planes::Job);
    assert_eq!(e.language(), crate::program::Language::Isel);
    assert!(
        e.buffer.text().contains("; part.nc:3"),
        "{}",
        e.buffer.text()
    );
    assert!(e.gcode.is_some(), "the run key has the converted job");
    assert_eq!(e.file.path, Some(dir.path().join("part.isel")));
}

#[test]
fn a_job_outside_the_soft_limits_opens_with_its_errors_and_runs_once_the_zero_is_set() {
    let dir = tempfile::tempdir().expect("dir");
    let path = write_job(dir.path());
    let mut host = Host::isel();
    let mut e = Editor::new(&host.setup, host.now);
    let out = host.send(
        &mut e,
        Input::Msg(EditorMsg::OpenGcode {
            path: path.clone(),
            height_map: None,
        }),
    );
    assert_eq!(out.focus, Some(Focus::Editor));
    import_all(&mut host, &mut e, out);
    let job = e.job.as_ref().expect("opened with its errors, not refused");
    assert_eq!(job.report.errors[0].line, 3, "{:?}", job.report.errors);
    assert_eq!(job.report.errors[0].text, "G1 Z-1 F100");
    assert!(e.gcode.is_none(), "nothing to run");
    assert!(
        e.buffer.text().trim().is_empty(),
        "no earlier text passes for it"
    );

    // Nothing changed: the tick asks for nothing.
    host.now += Duration::from_secs(1);
    let out = host.send(&mut e, Input::Tick);
    assert!(import_all(&mut host, &mut e, out).is_empty());

    // `s Z20` in the console: the job is checked again at once, with the
    // text that was opened, and now converts.
    host.offsets.set(System::G54, Axis::Z, 20 * 400);
    std::fs::write(&path, "G21\nthis file changed on disk\n").expect("write");
    host.now += Duration::from_secs(1);
    let out = host.send(&mut e, Input::Tick);
    let asked = import_all(&mut host, &mut e, out);
    assert_eq!(asked.len(), 1);
    assert!(asked[0].source.as_deref() == Some(JOB));
    let job = e.job.as_ref().expect("still open");
    assert!(job.report.errors.is_empty(), "{:?}", job.report.errors);
    assert!(e.gcode.is_some(), "it runs now");
    assert!(e.buffer.text().contains("; part.nc:3"));
}

#[test]
fn a_check_again_keeps_the_operators_edits_of_the_converted_program() {
    let dir = tempfile::tempdir().expect("dir");
    let path = write_job(dir.path());
    let mut host = Host::isel();
    host.offsets.set(System::G54, Axis::Z, 20 * 400);
    let mut e = Editor::new(&host.setup, host.now);
    let out = host.send(&mut e, Input::Msg(EditorMsg::Open(path)));
    import_all(&mut host, &mut e, out);
    host.send(&mut e, Input::Char(';'));
    let edited = e.buffer.text();
    host.offsets.set(System::G54, Axis::Z, 30 * 400);
    host.now += Duration::from_secs(1);
    let out = host.send(&mut e, Input::Tick);
    import_all(&mut host, &mut e, out);
    assert_eq!(e.buffer.text(), edited, "the edit is kept");
    let job = e.job.as_ref().expect("open");
    assert_eq!(job.offsets, host.offsets, "the panel is of the new zero");
}

/// Issue 41 (4): a G-code job streamed from the console is in the job log
/// as `jogterm run` writes it: its start (way, estimate, the file and its
/// text for the hash), each G-code line that ran to its end, how it ended.
#[test]
fn a_job_streamed_from_the_console_goes_into_the_job_log() {
    use crate::device::api::{CheckoutEnd, JogId};
    use crate::joblog::How;
    use crate::ui::editor::io::JobLogEvent;

    fn logged(out: &Outcome) -> Vec<JobLogEvent> {
        out.effects
            .iter()
            .filter_map(|e| match e {
                Effect::Io(EditorIo::JobLog(event)) => Some(event.clone()),
                _ => None,
            })
            .collect()
    }
    fn line(out: &Outcome) -> Option<JogId> {
        requests(out).into_iter().find_map(|r| match r {
            Request::Checkout { id, .. } => Some(*id),
            _ => None,
        })
    }

    let dir = tempfile::tempdir().expect("dir");
    let path = dir.path().join("pockets.nc");
    // Never retracted between the pockets: no place to cut within 30
    // commands, so it is streamed.
    let gcode = crate::ui::editor::job::tests::pockets(12).replace("G0 Z65\nG0 X", "G0 X");
    std::fs::write(&path, &gcode).expect("write");
    let mut host = Host::isel();
    let mut profile = (*host.setup.profile).clone();
    profile.gcode.memory = Some(30);
    host.setup.profile = std::sync::Arc::new(profile);
    let mut e = Editor::new(&host.setup, host.now);
    let out = host.send(&mut e, Input::Msg(EditorMsg::Open(path.clone())));
    import_all(&mut host, &mut e, out);
    host.settle(&mut e);
    assert_eq!(
        e.gcode.as_ref().map(|g| g.converted.ways.chosen),
        Some(crate::gcode::ways::Way::Stream)
    );
    host.send(&mut e, Input::Main(Action::RunProgram));
    let mut out = host.key(&mut e, Action::Confirm);
    let events = logged(&out);
    let Some(JobLogEvent::Start(start)) = events.first() else {
        panic!("the start first: {events:?}");
    };
    assert_eq!(start.file, path);
    assert_eq!(&*start.source, gcode.as_str());
    assert_eq!(start.way, crate::gcode::ways::Way::Stream);
    assert!(start.estimate_s.is_some_and(|s| s > 0.0), "{start:?}");
    assert!(
        start.offset.starts_with("G54 X0.000 Y0.000 Z0.000"),
        "{start:?}"
    );
    // Every line sent runs to its end; the lines logged as done are the
    // G-code lines before the one running, each once, in order.
    let mut done = Vec::new();
    for _ in 0..20 {
        let id = line(&out).expect("a line");
        out = host.send(
            &mut e,
            Input::Device(&Event::Checkout {
                id,
                end: CheckoutEnd::Done { byte: None },
            }),
        );
        for event in logged(&out) {
            if let JobLogEvent::Line(l) = event {
                done.push(l);
            }
        }
        // The line running is logged as its own G-code line (the text's
        // line, not the command's index, which the header's comments
        // shift).
        let at = e.checkout.as_ref().and_then(|c| c.current_line());
        let origin = at.and_then(|l| {
            e.gcode
                .as_ref()?
                .converted
                .program
                .lines
                .get(l)?
                .origin
                .map(|o| o.line)
        });
        if let Some(origin) = origin {
            assert_eq!(e.job_logged, Some(Some(origin)), "at text line {at:?}");
        }
    }
    assert!(done.len() >= 3, "{done:?}");
    assert!(done.windows(2).all(|w| w[0] < w[1]), "{done:?}");
    // The stop key ends it: stopped.
    let id = line(&out).expect("a line");
    let out = host.send(
        &mut e,
        Input::Device(&Event::Checkout {
            id,
            end: CheckoutEnd::Stopped,
        }),
    );
    assert_eq!(logged(&out), [JobLogEvent::End(How::Stopped)]);
}
