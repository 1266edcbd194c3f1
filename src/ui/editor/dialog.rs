//! The editor's popups: forms (open, save as, go to, find, the circle
//! helper, a taught dwell or output), the question about unsaved changes,
//! and yes/no questions whose answer the editor carries out itself.

use std::path::PathBuf;

use crate::program::store::{Origin, Recovery};
use crate::ui::keymap::Mode;
use crate::ui::line_edit::LineEdit;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FormKind {
    Open,
    SaveAs,
    GoTo,
    Find,
    Circle,
    Dwell,
    Output,
}

impl FormKind {
    pub fn title(self) -> &'static str {
        match self {
            FormKind::Open => "Open a program",
            FormKind::SaveAs => "Save the program as",
            FormKind::GoTo => "Go to",
            FormKind::Find => "Find",
            FormKind::Circle => "Insert an arc (manual 2.3)",
            FormKind::Dwell => "Teach a dwell",
            FormKind::Output => "Teach an output",
        }
    }
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Field {
    pub label: String,
    pub edit: LineEdit,
}

impl Field {
    pub fn new(label: impl Into<String>, value: &str) -> Field {
        let mut edit = LineEdit::default();
        value.chars().for_each(|c| edit.insert(c));
        Field {
            label: label.into(),
            edit,
        }
    }

    pub fn text(&self) -> &str {
        self.edit.text()
    }
}

/// A form: labelled one-line fields, one focused; what is wrong with the
/// answer, and what it will do (the circle's commands) while it is typed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Form {
    pub kind: FormKind,
    pub fields: Vec<Field>,
    pub focus: usize,
    pub error: Option<String>,
    pub note: Option<String>,
    /// What follows a successful save (save as, on the way out).
    pub then: Option<Then>,
}

impl Form {
    pub fn new(kind: FormKind, fields: Vec<Field>) -> Form {
        Form {
            kind,
            fields,
            focus: 0,
            error: None,
            note: None,
            then: None,
        }
    }

    pub fn field(&self, i: usize) -> &str {
        self.fields.get(i).map_or("", Field::text)
    }

    pub fn focused(&mut self) -> Option<&mut LineEdit> {
        self.fields.get_mut(self.focus).map(|f| &mut f.edit)
    }

    pub fn step(&mut self, delta: isize) {
        let n = self.fields.len().max(1) as isize;
        self.focus = (self.focus as isize + delta).rem_euclid(n) as usize;
    }
}

/// What to do once unsaved changes are dealt with.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Then {
    Quit,
    Open(PathBuf),
    Restore(Box<Recovery>),
}

/// What a yes or no to a question does.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Answer {
    Nothing,
    /// Upload, erasing the stored program first or not.
    Upload {
        erase: bool,
    },
    /// Start the stored program.
    Run,
    /// Run the converted G-code job in parts (`update::job`).
    RunInParts,
    /// Run the converted G-code job with waits in pieces, waiting between
    /// them for the operator (`update::pieces`).
    RunPieces,
    /// Stream the converted G-code job (`update::stream`).
    Stream,
    /// Start a check-out, from the program's start or from a line.
    Checkout {
        from: Option<usize>,
    },
    /// Save to `path` whatever is there now (a file that changed on disk,
    /// that exists, or that held bytes that were not UTF-8).
    Overwrite {
        path: PathBuf,
        then: Option<Then>,
    },
    /// Put recovered edits into the editor.
    Restore(Box<Recovery>),
    /// Put recovered edits aside (`….discarded`).
    Discard(Origin),
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Question {
    pub title: String,
    pub text: String,
    pub yes: Answer,
    pub no: Answer,
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Dialog {
    Form(Form),
    /// Save, discard or go back, then `Then`.
    Unsaved(Then),
    Ask(Question),
}

impl Dialog {
    /// The keymap mode while it is open.
    pub fn mode(&self) -> Mode {
        match self {
            Dialog::Form(_) => Mode::Form,
            Dialog::Unsaved(_) => Mode::Unsaved,
            Dialog::Ask(_) => Mode::Confirm,
        }
    }
}
