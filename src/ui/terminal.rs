//! The one owner of the terminal: raw mode, the alternate screen, a hidden
//! cursor, bracketed paste (a paste arrives as text, `Event::Paste`, never as
//! keys that could jog) and (where the terminal supports it) the kitty
//! keyboard flags that report key releases, all undone by a guard on drop,
//! on error and in the panic hook.
//!
//! Restoring ignores every error: it may run on a terminal that has hung up,
//! where writes fail, and a failing `eprintln!` would turn a clean exit into
//! an abort (`docs/field-notes.md`, "Order on hang-up"). The panic hook
//! first runs the registered emergency stop, then restores, then prints the
//! panic as usual.

use std::io::{self, Stdout, Write};
use std::mem::ManuallyDrop;
use std::ops::{Deref, DerefMut};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, Once};

use ratatui::Terminal;
use ratatui::backend::CrosstermBackend;
use ratatui::crossterm::cursor::{Hide, Show};
use ratatui::crossterm::event::{
    DisableBracketedPaste, EnableBracketedPaste, KeyboardEnhancementFlags,
    PopKeyboardEnhancementFlags, PushKeyboardEnhancementFlags,
};
use ratatui::crossterm::execute;
use ratatui::crossterm::terminal::{
    Clear, ClearType, EndSynchronizedUpdate, EnterAlternateScreen, LeaveAlternateScreen,
    disable_raw_mode, enable_raw_mode, supports_keyboard_enhancement,
};

mod whole_frames;

pub use whole_frames::WholeFrames;

/// The console's backend: crossterm on stdout, each frame one update.
pub type ConsoleBackend = WholeFrames<CrosstermBackend<Stdout>, Stdout>;

/// The environment variable that skips the keyboard protocol query (it
/// blocks up to 2 s on a terminal that does not answer, such as a test pty).
pub const NO_KEYBOARD_QUERY_ENV: &str = "JOGTERM_NO_KEYBOARD_QUERY";

/// Writes stop bytes without the async machinery (panic hook, hang-up).
pub type EmergencyFn = Arc<dyn Fn() + Send + Sync>;

static ACTIVE: AtomicBool = AtomicBool::new(false);
static KEYBOARD_PUSHED: AtomicBool = AtomicBool::new(false);
static PASTE_ENABLED: AtomicBool = AtomicBool::new(false);
static EMERGENCY: Mutex<Option<EmergencyFn>> = Mutex::new(None);
static HOOK: Once = Once::new();

#[derive(Debug, Clone, Copy, Default)]
pub struct TerminalOptions {
    /// Ask the terminal whether it speaks the kitty keyboard protocol and
    /// switch on key release reports if it does.
    pub keyboard_query: bool,
}

impl TerminalOptions {
    /// Query unless the environment says not to.
    pub fn from_env() -> Self {
        let skip =
            std::env::var_os(NO_KEYBOARD_QUERY_ENV).is_some_and(|v| !v.is_empty() && v != "0");
        Self {
            keyboard_query: !skip,
        }
    }
}

/// Holds the terminal in TUI mode; dropping it gives the terminal back.
#[derive(Debug)]
pub struct TerminalGuard {
    _private: (),
}

/// The console's terminal. Dropping it writes nothing: ratatui's own drop
/// shows a hidden cursor and `eprintln!`s when that fails, which on a
/// terminal that has hung up panics (`docs/field-notes.md`, "Order on
/// hang-up") and turned a hang-up's clean exit into status 101. The guard's
/// [`restore`] shows the cursor, ignoring every error; the terminal's
/// buffers are left to the process' end (one per process).
pub struct Tui(ManuallyDrop<Terminal<ConsoleBackend>>);

impl Deref for Tui {
    type Target = Terminal<ConsoleBackend>;

    fn deref(&self) -> &Self::Target {
        &self.0
    }
}

impl DerefMut for Tui {
    fn deref_mut(&mut self) -> &mut Self::Target {
        &mut self.0
    }
}

impl TerminalGuard {
    /// Enter TUI mode on stdout. On failure everything done so far is undone.
    pub fn enter(options: TerminalOptions) -> io::Result<(TerminalGuard, Tui)> {
        install_panic_hook();
        enable_raw_mode()?;
        ACTIVE.store(true, Ordering::SeqCst);
        // From here the guard exists, so an error below restores on drop.
        let guard = TerminalGuard { _private: () };
        let mut stdout = io::stdout();
        execute!(stdout, EnterAlternateScreen, Hide)?;
        // Pastes as text: without it a terminal types pasted text as keys,
        // and ten pasted `6` were ten jog steps (issue 13). A terminal that
        // does not know the mode ignores it; bursts are caught then
        // (`ui::typing`).
        PASTE_ENABLED.store(true, Ordering::SeqCst);
        execute!(stdout, EnableBracketedPaste)?;
        if options.keyboard_query && supports_keyboard_enhancement().unwrap_or(false) {
            execute!(
                stdout,
                PushKeyboardEnhancementFlags(
                    KeyboardEnhancementFlags::DISAMBIGUATE_ESCAPE_CODES
                        | KeyboardEnhancementFlags::REPORT_EVENT_TYPES
                        | KeyboardEnhancementFlags::REPORT_ALL_KEYS_AS_ESCAPE_CODES
                        | KeyboardEnhancementFlags::REPORT_ALTERNATE_KEYS
                )
            )?;
            KEYBOARD_PUSHED.store(true, Ordering::SeqCst);
        }
        // A fresh screen, cleared directly: `Terminal::clear` would ask the
        // terminal for the cursor position, a round trip over SSH that a
        // terminal which does not answer turns into a 2 s wait and an error.
        execute!(stdout, Clear(ClearType::All))?;
        let terminal = Terminal::new(WholeFrames::new(
            CrosstermBackend::new(io::stdout()),
            io::stdout(),
        ))?;
        Ok((guard, Tui(ManuallyDrop::new(terminal))))
    }

    /// Whether key release events will arrive (kitty keyboard protocol).
    pub fn reports_key_releases(&self) -> bool {
        KEYBOARD_PUSHED.load(Ordering::SeqCst)
    }
}

impl Drop for TerminalGuard {
    fn drop(&mut self) {
        restore();
    }
}

/// Give the terminal back, ignoring every error. Safe to call more than once
/// and from the panic hook.
pub fn restore() {
    if !ACTIVE.swap(false, Ordering::SeqCst) {
        return;
    }
    let mut stdout = io::stdout();
    if KEYBOARD_PUSHED.swap(false, Ordering::SeqCst) {
        let _ = execute!(stdout, PopKeyboardEnhancementFlags);
    }
    // A shell left in bracketed paste mode would see `ESC[200~` around
    // every paste.
    if PASTE_ENABLED.swap(false, Ordering::SeqCst) {
        let _ = execute!(stdout, DisableBracketedPaste);
    }
    // A panic in the middle of a frame leaves its update open, and a
    // terminal that knows the mode would hold the screen until it gives up.
    let _ = execute!(stdout, EndSynchronizedUpdate, LeaveAlternateScreen, Show);
    let _ = disable_raw_mode();
    let _ = stdout.flush();
}

/// Register what the panic hook runs before it restores the terminal (the
/// device's emergency stop); `None` clears it.
pub fn set_emergency(stop: Option<EmergencyFn>) {
    let mut slot = EMERGENCY.lock().unwrap_or_else(|p| p.into_inner());
    *slot = stop;
}

/// Run the registered emergency stop, if any. Never blocks on the lock: a
/// panic while it is held must not deadlock the hook.
pub fn run_emergency() {
    let stop = match EMERGENCY.try_lock() {
        Ok(slot) => slot.clone(),
        Err(std::sync::TryLockError::Poisoned(p)) => p.into_inner().clone(),
        Err(std::sync::TryLockError::WouldBlock) => None,
    };
    if let Some(stop) = stop {
        stop();
    }
}

fn install_panic_hook() {
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            // Stop the machine first, then give the terminal back so the
            // panic message lands on a usable screen.
            run_emergency();
            restore();
            previous(info);
        }));
    });
}
