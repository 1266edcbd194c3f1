//! The terminal guard in a real pseudo-terminal: after a normal exit, an
//! error and a panic, the terminal is back in cooked mode (ICANON, ECHO), on
//! the main screen, with a visible cursor and bracketed paste off again
//! (on while the TUI runs, so a paste is text, not keys); on a panic the emergency stop
//! runs before the terminal is restored; after a hang-up leaving panics not.
//!
//! Each case runs this test binary again as a child in a pty, running only
//! the ignored `child` test with the case in `JOGTERM_GUARD_CASE`.

use crate::ui_pty;

use std::io::Write;
use std::sync::Arc;
use std::time::Duration;

use jogterm::ui::terminal::{TerminalGuard, TerminalOptions, Tui, set_emergency};
use ratatui::text::Line;
use ui_pty::{PtyRun, contains, rfind};

const CASE_ENV: &str = "JOGTERM_GUARD_CASE";
const LEAVE_ALTERNATE: &[u8] = b"\x1b[?1049l";
const SHOW_CURSOR: &[u8] = b"\x1b[?25h";

/// `icanon=1 echo=1` when the terminal on stdin is cooked again.
fn termios_line() -> String {
    // SAFETY: tcgetattr fills the struct for a valid fd or fails.
    let mut t: libc::termios = unsafe { std::mem::zeroed() };
    let ok = unsafe { libc::tcgetattr(0, &mut t) } == 0;
    format!(
        "TERMIOS ok={} icanon={} echo={}",
        u8::from(ok),
        u8::from(t.c_lflag & libc::ICANON != 0),
        u8::from(t.c_lflag & libc::ECHO != 0)
    )
}

fn in_tui() -> Result<(), String> {
    let (guard, mut terminal) =
        TerminalGuard::enter(TerminalOptions::default()).map_err(|e| e.to_string())?;
    terminal
        .draw(|f| f.render_widget(Line::from("IN THE TUI"), f.area()))
        .map_err(|e| e.to_string())?;
    let case = std::env::var(CASE_ENV).unwrap_or_default();
    match case.as_str() {
        "error" => Err("a failure inside the TUI".to_string()),
        "panic" => panic!("a bug inside the TUI"),
        "hangup" => leave_after_a_hang_up(guard, terminal),
        _ => {
            drop(guard);
            Ok(())
        }
    }
}

/// The terminal goes away under the TUI (the parent closes the pty master):
/// once a write fails, leave as the console does, dropping the terminal and
/// the guard on a dead terminal; exit 0 unless that panicked.
fn leave_after_a_hang_up(guard: TerminalGuard, terminal: Tui) -> ! {
    // SAFETY: ignoring SIGHUP, whose default action would end this child
    // before the drops under test (the console catches it).
    unsafe { libc::signal(libc::SIGHUP, libc::SIG_IGN) };
    let mut out = std::io::stdout();
    let _ = out.write_all(b"WAITING-FOR-HANGUP");
    let _ = out.flush();
    let end = std::time::Instant::now() + Duration::from_secs(30);
    while out.write_all(b".").and_then(|()| out.flush()).is_ok() {
        if std::time::Instant::now() > end {
            std::process::exit(3);
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    // The drops the console's way out runs (`process::exit` runs none):
    // ratatui's `Terminal` drop is what panicked here before `Tui` wrapped it.
    #[allow(clippy::drop_non_drop)]
    drop(terminal);
    drop(guard);
    std::process::exit(0)
}

#[test]
#[ignore = "the child process of the terminal guard tests"]
fn child() {
    if std::env::var(CASE_ENV).is_err() {
        return;
    }
    set_emergency(Some(Arc::new(|| {
        let mut out = std::io::stdout();
        let _ = out.write_all(b"EMERGENCY-STOP-RAN\r\n");
        let _ = out.flush();
    })));
    // Runs after the guard's hook has restored the terminal.
    let previous = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        println!("{}", termios_line());
        previous(info);
    }));
    let result = in_tui();
    println!("{}", termios_line());
    if let Err(e) = result {
        println!("ERROR {e}");
        std::process::exit(1);
    }
}

/// The `child` test's full name in this test binary (`ui_terminal::child`:
/// the crate name left out), for `--exact`.
fn child_test_name() -> String {
    let module = module_path!().split_once("::").map_or("", |(_, m)| m);
    format!("{module}::child")
}

/// This test binary again in a pty, running only the `child` test with
/// `case`.
fn spawn_child(case: &str) -> PtyRun {
    let exe = std::env::current_exe().expect("test binary");
    let child = child_test_name();
    PtyRun::spawn(
        &exe,
        &[
            "--ignored",
            "--exact",
            &child,
            "--nocapture",
            "--test-threads=1",
        ],
        &[(CASE_ENV, case), ("RUST_BACKTRACE", "0")],
    )
}

fn run_case(case: &str) -> (Option<u32>, Vec<u8>, String) {
    let mut run = spawn_child(case);
    let code = run.wait_exit(Duration::from_secs(30));
    run.drain(Duration::from_secs(5));
    let output = run.output();
    let screen = run.screen();
    assert!(
        !screen.screen().alternate_screen(),
        "{case}: still on the alternate screen"
    );
    assert!(
        !screen.screen().hide_cursor(),
        "{case}: cursor still hidden"
    );
    assert!(
        !screen.screen().bracketed_paste(),
        "{case}: bracketed paste left on (a shell would see ESC[200~)"
    );
    (code, output, screen.screen().contents())
}

fn assert_restored(case: &str, output: &[u8], screen: &str) {
    let leave = rfind(output, LEAVE_ALTERNATE)
        .unwrap_or_else(|| panic!("{case}: the alternate screen was never left"));
    // What the alternate screen showed just before it was left.
    let mut tui = vt100::Parser::new(
        std::num::NonZeroU16::MIN.saturating_add(23),
        std::num::NonZeroU16::MIN.saturating_add(79),
        0,
    );
    tui.process(&output[..leave]);
    assert!(
        tui.screen().alternate_screen(),
        "{case}: TUI on the alternate screen"
    );
    assert!(
        tui.screen().contents().contains("IN THE TUI"),
        "{case}: the TUI never drew"
    );
    // Switched on with the TUI (and off again on the way out, before the
    // alternate screen is left: `run_case` checks the end).
    assert!(
        contains(&output[..leave], b"\x1b[?2004h"),
        "{case}: pastes would arrive as keys (bracketed paste never on)"
    );
    assert!(contains(output, SHOW_CURSOR), "{case}: cursor shown");
    let after = &output[leave..];
    assert!(
        contains(after, b"TERMIOS ok=1 icanon=1 echo=1"),
        "{case}: terminal not cooked again:\n{screen}"
    );
}

#[test]
fn the_terminal_is_restored_on_a_normal_exit() {
    let (code, output, screen) = run_case("exit");
    assert_eq!(code, Some(0), "{screen}");
    assert_restored("exit", &output, &screen);
    assert!(!contains(&output, b"EMERGENCY-STOP-RAN"));
}

#[test]
fn the_terminal_is_restored_on_an_error() {
    let (code, output, screen) = run_case("error");
    assert_eq!(code, Some(1), "{screen}");
    assert_restored("error", &output, &screen);
    assert!(
        screen.contains("ERROR a failure inside the TUI"),
        "{screen}"
    );
}

#[test]
fn the_terminal_is_restored_on_a_panic_after_the_emergency_stop() {
    let (code, output, screen) = run_case("panic");
    assert_ne!(code, Some(0), "{screen}");
    assert_restored("panic", &output, &screen);
    assert!(screen.contains("a bug inside the TUI"), "{screen}");
    let stop = rfind(&output, b"EMERGENCY-STOP-RAN").expect("emergency stop ran");
    let leave = rfind(&output, LEAVE_ALTERNATE).expect("left the alternate screen");
    assert!(
        stop < leave,
        "the stop bytes go out before the terminal is restored"
    );
}

#[test]
fn leaving_after_a_hang_up_does_not_panic() {
    let mut run = spawn_child("hangup");
    if let Err(screen) = run.wait_for("WAITING-FOR-HANGUP", Duration::from_secs(30)) {
        panic!("the child never drew:\n{screen}");
    }
    run.close_master();
    // ratatui's own drop `eprintln!`s when it cannot show the cursor, which
    // panics on a hung-up stderr (status 101): `Tui` drops without it.
    assert_eq!(run.wait_exit(Duration::from_secs(30)), Some(0));
}
