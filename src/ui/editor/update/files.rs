//! The editor's files: open, save (atomically, asking before overwriting
//! what changed on disk), the recovery file kept while edits are unsaved,
//! and the offer of recovered edits (`docs/editor.md`, "Nothing lost").
//! Everything on disk is an [`EditorIo`] effect; the results come back as
//! [`EditorMsg`].

use std::path::{Path, PathBuf};
use std::time::{Instant, SystemTime, UNIX_EPOCH};

use crate::program::store::{Fingerprint, Loaded, Origin, Recovery};
use crate::program::{Language, recent};
use crate::ui::traffic_log::NoteLevel;

use crate::ui::editor::dialog::{Answer, Dialog, Then};
use crate::ui::editor::io::{EditorIo, EditorMsg, SaveFailure};
use crate::ui::editor::{AUTOSAVE_EVERY, FileState, NEVER_SAVED};

use super::Step;

impl Step<'_, '_> {
    /// A result of the editor's effects, or a request from outside.
    pub(super) fn message(&mut self, msg: EditorMsg) {
        let now = self.ctx.now;
        match msg {
            EditorMsg::Open(path) => {
                self.open();
                self.load(path);
            }
            EditorMsg::Imported {
                path,
                language,
                text,
                notes,
                gcode,
            } => {
                self.open();
                self.e.replace(language, &text, now);
                self.e.gcode = gcode.map(|converted| crate::ui::editor::job::Gcode {
                    converted: *converted,
                    state: self.e.buffer.state(),
                });
                // Unsaved: the recovery file keeps it until it is saved.
                self.e.file = FileState {
                    path: Some(path),
                    saved: NEVER_SAVED,
                    ..FileState::default()
                };
                for (level, text) in notes {
                    self.say(level, text);
                }
            }
            EditorMsg::OpenGcode { path, height_map } => {
                self.open();
                self.open_gcode(path, height_map);
            }
            EditorMsg::GcodeChecked(checked) => self.gcode_checked(*checked),
            EditorMsg::Scan => {
                if let Some(store) = self.e.store.clone() {
                    self.io(EditorIo::ScanRecoveries { store });
                }
            }
            EditorMsg::Loaded {
                path,
                result,
                recovery,
            } => self.loaded(path, result, recovery),
            EditorMsg::Saved {
                path,
                state,
                result,
                then,
            } => self.saved(path, state, result, then),
            EditorMsg::RecoveryWritten {
                state,
                origin,
                result,
            } => match result {
                Ok(()) => {
                    self.e.file.recovered = Some((state, origin));
                    self.e.file.recovery_failed = false;
                }
                Err(e) => {
                    if !self.e.file.recovery_failed {
                        self.say(
                            NoteLevel::Warning,
                            format!("unsaved edits cannot be kept in a recovery file: {e}"),
                        );
                    }
                    self.e.file.recovery_failed = true;
                }
            },
            EditorMsg::RecoveryGone { result } => {
                if let Err(e) = result {
                    self.say(NoteLevel::Warning, format!("recovery file: {e}"));
                }
            }
            EditorMsg::Recoveries(found) => {
                let own = self.e.origin();
                for r in found {
                    match r {
                        Ok(rec) if rec.origin == own => {}
                        Ok(rec) => {
                            if !self.e.offers.iter().any(|o| o.origin == rec.origin) {
                                self.e.offers.push_back(rec);
                            }
                        }
                        Err(e) => self.say(
                            NoteLevel::Warning,
                            format!("a recovery file is unreadable: {e}"),
                        ),
                    }
                }
                self.offer_next();
            }
            EditorMsg::Linted(result) => {
                let state = self.e.buffer.state();
                let lines = self.e.buffer.line_count();
                self.e.checks.finished(*result, state, lines, now);
            }
            EditorMsg::RecentKept(Ok(())) | EditorMsg::JobLogged(None) => {}
            EditorMsg::JobLogged(Some(note)) => self.say(NoteLevel::Warning, note),
            // Said, and kept for this session: the list is a convenience.
            EditorMsg::RecentKept(Err(why)) => self.say(
                NoteLevel::Warning,
                format!("the list of files opened last was not kept: {why}"),
            ),
        }
    }

    pub(super) fn load(&mut self, path: PathBuf) {
        if crate::gcode::is_gcode_path(&path) {
            self.open_gcode(path, None);
            return;
        }
        let store = self.e.store.clone();
        self.io(EditorIo::Load { path, store });
    }

    fn loaded(
        &mut self,
        path: PathBuf,
        result: Result<Option<Loaded>, String>,
        recovery: Option<Recovery>,
    ) {
        let now = self.ctx.now;
        let language = Language::from_path(&path).unwrap_or_else(|| self.e.language());
        let name = path.display().to_string();
        let text = match result {
            Err(e) => {
                self.say(NoteLevel::Danger, format!("cannot open: {e}"));
                return;
            }
            Ok(Some(l)) => {
                self.remember(&l.path);
                self.e.replace(language, &l.text, now);
                self.e.file = FileState {
                    path: Some(l.path),
                    saved: self.e.buffer.state(),
                    fingerprint: Some(l.fingerprint),
                    lossy: l.lossy,
                    ..FileState::default()
                };
                if l.lossy {
                    self.say(
                        NoteLevel::Warning,
                        format!("{name}: bytes that are not UTF-8 are shown as \u{fffd}"),
                    );
                } else {
                    let lines = self.e.buffer.line_count();
                    self.say(
                        NoteLevel::Info,
                        format!("opened {name} ({lines} lines, {language})"),
                    );
                }
                l.text
            }
            Ok(None) => {
                self.e.replace(language, "", now);
                self.e.file = FileState {
                    path: Some(path),
                    saved: self.e.buffer.state(),
                    ..FileState::default()
                };
                // A warning, not news: a mistyped name also ends here.
                self.say(
                    NoteLevel::Warning,
                    format!(
                        "{name} does not exist: a new, empty {language} program, written when you save"
                    ),
                );
                String::new()
            }
        };
        let Some(rec) = recovery else {
            return;
        };
        if rec.text != text {
            self.e.offers.retain(|o| o.origin != rec.origin);
            self.e.offers.push_front(rec);
            self.offer_next();
            return;
        }
        // The file holds what the recovery does: nothing to recover.
        if let Some(store) = self.e.store.clone() {
            self.io(EditorIo::RemoveRecovery {
                store,
                origin: rec.origin,
            });
        }
    }

    /// `path` opened: first in the list of files opened last, which the
    /// worker keeps in the state directory.
    pub(super) fn remember(&mut self, path: &Path) {
        // The working directory alone, no file system: the worker's
        // `store::absolute` resolved a program's path already.
        let path = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
        self.e.recent = recent::with(&self.e.recent, &path);
        if let Some(dir) = self.e.recent_dir.clone() {
            self.io(EditorIo::KeepRecent {
                dir,
                list: self.e.recent.clone(),
            });
        }
    }

    /// Save to `path` (else the file's own path; an untitled program asks
    /// for one), then `then`. `fresh`: `path` is a new name.
    pub(super) fn save(&mut self, path: Option<PathBuf>, then: Option<Then>, fresh: bool) {
        let Some(path) = path.or_else(|| self.e.file.path.clone()) else {
            let form = self.save_as_form(then);
            self.form(form);
            return;
        };
        if self.e.file.lossy {
            self.ask(
                "Save",
                format!(
                    "{} held bytes that are not UTF-8; they show as \u{fffd} and would be saved \
                     so. Save anyway?",
                    path.display()
                ),
                Answer::Overwrite { path, then },
                Answer::Nothing,
            );
            return;
        }
        let same = self.e.file.path.as_deref() == Some(path.as_path());
        let expect = if same { self.e.file.fingerprint } else { None };
        // A program never read from or written to its path (converted from
        // G-code, or a new file by that name) must not replace a file that
        // is there now without the operator saying so.
        let fresh = fresh || (same && self.e.file.fingerprint.is_none());
        self.save_to(path, then, expect, fresh);
    }

    pub(super) fn save_to(
        &mut self,
        path: PathBuf,
        then: Option<Then>,
        expect: Option<Fingerprint>,
        fresh: bool,
    ) {
        self.e.file.saving = true;
        let text = self.e.buffer.text();
        let state = self.e.buffer.state();
        self.io(EditorIo::Save {
            path,
            text,
            state,
            expect,
            fresh,
            then,
        });
    }

    fn saved(
        &mut self,
        path: PathBuf,
        state: u64,
        result: Result<Fingerprint, SaveFailure>,
        then: Option<Then>,
    ) {
        self.e.file.saving = false;
        let name = path.display().to_string();
        match result {
            Ok(fingerprint) => {
                let old_origin = self.e.origin();
                let f = &mut self.e.file;
                f.path = Some(path);
                f.saved = state;
                f.fingerprint = Some(fingerprint);
                f.lossy = false;
                // A recovery under another name (untitled, or the old file
                // of a save-as) is not needed any more.
                if let Some(store) = self.e.store.clone()
                    && old_origin != self.e.origin()
                {
                    self.io(EditorIo::RemoveRecovery {
                        store,
                        origin: old_origin,
                    });
                }
                // Saved as it stands: its recovery goes now, not at the
                // next tick (a quit may follow at once).
                if !self.e.modified()
                    && let Some(store) = self.e.store.clone()
                    && let Some((_, origin)) = self.e.file.recovered.take()
                {
                    self.e.file.recovery_due = None;
                    self.io(EditorIo::RemoveRecovery { store, origin });
                }
                let lines = self.e.buffer.line_count();
                self.say(NoteLevel::Info, format!("saved {name} ({lines} lines)"));
                if let Some(then) = then {
                    self.continue_with(then);
                }
            }
            Err(SaveFailure::Changed) => self.ask(
                "Save",
                format!(
                    "{name} changed on disk since it was opened. Overwrite it with the editor's \
                     program?"
                ),
                Answer::Overwrite { path, then },
                Answer::Nothing,
            ),
            Err(SaveFailure::Exists) => self.ask(
                "Save as",
                format!("{name} exists. Replace it?"),
                Answer::Overwrite { path, then },
                Answer::Nothing,
            ),
            Err(SaveFailure::Failed(e)) => self.say(
                NoteLevel::Danger,
                format!("not saved: {e}; the edits stay in the editor and the recovery file"),
            ),
        }
    }

    /// Write the edits as they are now to the recovery file (when there is
    /// a store).
    pub(super) fn recovery_write(&mut self) {
        let e = &self.e;
        let Some(store) = e.store.clone() else {
            return;
        };
        let recovery = Recovery {
            origin: e.origin(),
            language: e.language(),
            // Stamped by the worker.
            written: UNIX_EPOCH,
            base: e.file.fingerprint,
            text: e.buffer.text(),
        };
        let state = e.buffer.state();
        self.io(EditorIo::WriteRecovery {
            store,
            recovery,
            state,
        });
    }

    pub(super) fn restore(&mut self, recovery: Recovery) {
        let same_origin = recovery.origin == self.e.origin();
        if self.e.modified() && !same_origin {
            self.show(Dialog::Unsaved(Then::Restore(Box::new(recovery))));
            return;
        }
        let now = self.ctx.now;
        self.e.replace(recovery.language, &recovery.text, now);
        self.e.file = FileState {
            path: match &recovery.origin {
                Origin::File(path) => Some(path.clone()),
                Origin::Untitled { .. } => None,
            },
            saved: NEVER_SAVED,
            fingerprint: recovery.base,
            ..FileState::default()
        };
        self.open();
        let text = format!(
            "recovered edits of {} opened: save them (Ctrl-S) to keep them in the file",
            recovery.origin.describe()
        );
        self.say(NoteLevel::Info, text);
        // Kept under this session's name at once, then the old file goes.
        self.recovery_write();
        if let (Some(store), false) = (self.e.store.clone(), recovery.origin == self.e.origin()) {
            self.io(EditorIo::RemoveRecovery {
                store,
                origin: recovery.origin,
            });
        }
    }

    /// Show the next recovered program on offer, when nothing else is open.
    fn offer_next(&mut self) {
        if !self.dialog_free() {
            return;
        }
        let Some(recovery) = self.e.offers.pop_front() else {
            return;
        };
        let lines = recovery.text.lines().count();
        let text = format!(
            "Unsaved edits of {} ({lines} lines, written {}) were kept when jogterm last ended. \
             Open them in the editor? No puts them aside (….discarded).",
            recovery.origin.describe(),
            utc(recovery.written)
        );
        let origin = recovery.origin.clone();
        self.ask(
            "Recovered edits",
            text,
            Answer::Restore(Box::new(recovery)),
            Answer::Discard(origin),
        );
    }

    /// Time passes: start the lint when it is due, keep the recovery file
    /// up to date, offer recovered edits.
    pub(super) fn tick(&mut self) {
        self.stream_renew();
        self.checkout_tick();
        self.outputs_tick();
        self.recheck_gcode();
        let now = self.ctx.now;
        let (_, start) = self.starts();
        self.e.checks.start_moved(start, now);
        if self.e.checks.wants_lint(now) {
            let job = self.lint_job();
            self.e.checks.started(job.state, job.start, now);
            self.io(EditorIo::Lint(Box::new(job)));
        }
        self.keep_recovery(now);
        self.offer_next();
    }

    fn keep_recovery(&mut self, now: Instant) {
        let Some(store) = self.e.store.clone() else {
            return;
        };
        let state = self.e.buffer.state();
        let origin = self.e.origin();
        let modified = self.e.modified();
        let f = &mut self.e.file;
        if !modified {
            // Saved, or undone back to the file: no recovery is needed.
            f.recovery_due = None;
            if let Some((_, gone)) = f.recovered.take() {
                self.io(EditorIo::RemoveRecovery {
                    store,
                    origin: gone,
                });
            }
            return;
        }
        if f.recovered.as_ref() == Some(&(state, origin)) {
            f.recovery_due = None;
            return;
        }
        let due = f.recovery_due.unwrap_or(now);
        if now < due || f.saving {
            return;
        }
        f.recovery_due = Some(now + AUTOSAVE_EVERY);
        self.recovery_write();
    }
}

/// `2026-11-22 14:02 UTC`.
pub fn utc(time: SystemTime) -> String {
    let secs = time
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_secs()).unwrap_or(i64::MAX));
    let (year, month, day, rem) = crate::gcode::heightmap::civil(secs);
    format!(
        "{year:04}-{month:02}-{day:02} {:02}:{:02} UTC",
        rem / 3600,
        rem % 3600 / 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utc_times_read_like_a_calendar() {
        let t = UNIX_EPOCH + std::time::Duration::from_secs(1_763_820_120);
        assert_eq!(utc(t), "2025-11-22 14:02 UTC");
        assert_eq!(utc(UNIX_EPOCH), "1970-01-01 00:00 UTC");
        let leap = UNIX_EPOCH + std::time::Duration::from_secs(951_782_400);
        assert_eq!(utc(leap), "2000-02-29 00:00 UTC");
    }
}
