//! The parsed program: its lines, their commands with spans, and the map
//! between source lines and the controller's command indices.

use std::fmt;
use std::ops::Range;
use std::path::Path;

use crate::proto::Protocol;
use crate::proto::emcu;
use crate::proto::isel::{CncCommand, NoteKind, ReplyCode};

use super::flow::{self, Flow};
use super::source::{self, Shape, Span};
use super::{emcu_line, isel_line};

/// Commands an isel controller's program memory holds by default
/// (`docs/decisions.md` isel 9; more answer `6`).
pub const ISEL_CAPACITY: usize = crate::proto::isel::PROGRAM_CAPACITY;

/// The two program languages: isel CNC programs (manual chapter 3) and EMCU
/// jobs (buffered commands of manual 1.5, stored with `@F`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Language {
    Isel,
    Emcu,
}

impl Language {
    pub const ALL: [Language; 2] = [Language::Isel, Language::Emcu];

    pub fn name(self) -> &'static str {
        match self {
            Language::Isel => "isel",
            Language::Emcu => "emcu",
        }
    }

    /// Commands the controller stores: isel 2000, EMCU 256
    /// ([`emcu::job::JOB_CAPACITY`]).
    pub fn capacity(self) -> usize {
        match self {
            Language::Isel => ISEL_CAPACITY,
            Language::Emcu => emcu::job::JOB_CAPACITY,
        }
    }

    /// The language a file extension names (`docs/programs.md`): `isel`,
    /// `cnc` for isel programs, `emcu`, `job` for EMCU jobs, in any case.
    pub fn from_extension(extension: &str) -> Option<Language> {
        match extension.to_ascii_lowercase().as_str() {
            "isel" | "cnc" => Some(Language::Isel),
            "emcu" | "job" => Some(Language::Emcu),
            _ => None,
        }
    }

    /// The controller family that stores programs of this language.
    pub fn protocol(self) -> Protocol {
        match self {
            Language::Isel => Protocol::Isel,
            Language::Emcu => Protocol::Emcu,
        }
    }

    /// The language of a family's programs; EMP drives store none.
    pub fn of_protocol(protocol: Protocol) -> Option<Language> {
        match protocol {
            Protocol::Isel => Some(Language::Isel),
            Protocol::Emcu => Some(Language::Emcu),
            Protocol::Emp => None,
        }
    }

    /// Why a program in this language cannot be taught on or stored into a
    /// `protocol` controller, if it cannot (the editor's teach-in and
    /// upload say it).
    pub fn wrong_machine(self, protocol: Protocol) -> Option<String> {
        if self.protocol() == protocol {
            return None;
        }
        Some(match protocol {
            // There is no EMP language: there is nothing to store.
            Protocol::Emp => {
                "EMP drives store no programs (EMP manual: every command runs at once)".to_string()
            }
            // Both families' names take "an".
            Protocol::Isel | Protocol::Emcu => format!(
                "the program is an {self} program and the machine has an {protocol} controller"
            ),
        })
    }

    pub fn from_path(path: &Path) -> Option<Language> {
        path.extension()
            .and_then(|e| e.to_str())
            .and_then(Language::from_extension)
    }
}

impl fmt::Display for Language {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A command of either language.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum Command {
    Isel(CncCommand),
    Emcu(emcu::Command),
}

impl Command {
    pub fn as_isel(&self) -> Option<&CncCommand> {
        match self {
            Command::Isel(c) => Some(c),
            Command::Emcu(_) => None,
        }
    }

    pub fn as_emcu(&self) -> Option<&emcu::Command> {
        match self {
            Command::Emcu(c) => Some(c),
            Command::Isel(_) => None,
        }
    }
}

impl fmt::Display for Command {
    /// The canonical text the controller is sent (without its line end).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Command::Isel(c) => c.fmt(f),
            Command::Emcu(c) => c.fmt(f),
        }
    }
}

/// A line the controller would refuse.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SyntaxError {
    pub message: String,
    /// Bytes of the line.
    pub cols: Range<usize>,
    /// The reply code an isel controller answers while storing the line
    /// (EMCU has no error replies, `docs/decisions.md` EMCU 4).
    pub reply: Option<ReplyCode>,
}

/// Something accepted that the formatter writes differently (isel only:
/// spaces after the code, the table spellings `F M O P W Y Z`, CCW as `1`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Note {
    pub kind: NoteKind,
    pub cols: Range<usize>,
}

/// One command line: what it says and where its parts are.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Statement {
    /// The controller's command index (0-based, comments and blanks not
    /// counted): isel jump offsets count in it, and an upload error for
    /// command N is about the statement with index N.
    pub index: usize,
    /// The command text without blanks around it and without its comment.
    pub code: Range<usize>,
    /// The trailing comment, from its `;`.
    pub comment: Option<Range<usize>>,
    /// The parameters, in order (empty when the line does not parse).
    pub params: Vec<Range<usize>>,
    pub notes: Vec<Note>,
    pub command: Result<Command, SyntaxError>,
}

/// What a source line holds.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LineKind {
    Blank,
    /// A whole-line comment, from its marker to its last non-blank byte.
    Comment(Range<usize>),
    Statement(Statement),
}

/// One source line and what it holds.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Line {
    text: String,
    kind: LineKind,
}

impl Line {
    pub fn text(&self) -> &str {
        &self.text
    }

    pub fn kind(&self) -> &LineKind {
        &self.kind
    }

    pub fn statement(&self) -> Option<&Statement> {
        match &self.kind {
            LineKind::Statement(s) => Some(s),
            _ => None,
        }
    }

    /// The text of a range of this line (empty when out of range).
    pub fn slice(&self, cols: Range<usize>) -> &str {
        self.text.get(cols).unwrap_or_default()
    }
}

/// What a family parser made of one command text.
pub(crate) struct Parsed {
    pub command: Result<Command, SyntaxError>,
    pub params: Vec<Range<usize>>,
    pub notes: Vec<Note>,
}

/// A line's content without positions, for comparing programs: two programs
/// with equal items send the same commands and keep the same comments.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Item<'a> {
    Blank,
    Comment(&'a str),
    Command {
        /// The command, or the text of a line that does not parse.
        command: Result<&'a Command, &'a str>,
        comment: Option<&'a str>,
    },
}

/// A program of one [`Language`], line by line.
///
/// Every line parses on its own, so an editor can re-parse only the lines
/// that changed ([`Program::replace_lines`]); the command indices are then
/// renumbered, which is cheap.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Program {
    language: Language,
    lines: Vec<Line>,
    /// Command index to line.
    commands: Vec<usize>,
}

impl Program {
    /// Parse a whole text. Never fails: lines the controller would refuse
    /// hold their [`SyntaxError`].
    pub fn parse(language: Language, text: &str) -> Program {
        let mut lines = Vec::with_capacity(text.bytes().filter(|b| *b == b'\n').count() + 1);
        lines.extend(source::lines(text).map(|l| parse_line(language, l)));
        let mut program = Program {
            language,
            lines,
            commands: Vec::new(),
        };
        program.renumber();
        program
    }

    pub fn language(&self) -> Language {
        self.language
    }

    pub fn lines(&self) -> &[Line] {
        &self.lines
    }

    pub fn line(&self, line: usize) -> Option<&Line> {
        self.lines.get(line)
    }

    /// How many commands the controller would store (comments and blank
    /// lines not counted, lines that do not parse counted).
    pub fn command_count(&self) -> usize {
        self.commands.len()
    }

    /// The source line of command `index`.
    pub fn line_of(&self, index: usize) -> Option<usize> {
        self.commands.get(index).copied()
    }

    /// The command index of a source line; `None` for comments and blanks.
    pub fn index_of(&self, line: usize) -> Option<usize> {
        self.lines
            .get(line)
            .and_then(Line::statement)
            .map(|s| s.index)
    }

    /// Command `index` and its line.
    pub fn statement(&self, index: usize) -> Option<(usize, &Statement)> {
        let line = self.line_of(index)?;
        self.lines
            .get(line)
            .and_then(Line::statement)
            .map(|s| (line, s))
    }

    /// The statements in index order, with their lines.
    pub fn statements(&self) -> impl Iterator<Item = (usize, &Statement)> + '_ {
        self.commands.iter().filter_map(|&line| {
            self.lines
                .get(line)
                .and_then(Line::statement)
                .map(|s| (line, s))
        })
    }

    /// The span of a statement's command text.
    pub fn span_of(&self, index: usize) -> Option<Span> {
        self.statement(index)
            .map(|(line, s)| Span::new(line, s.code.clone()))
    }

    /// Replace the source lines `range` by the lines of `text` (an editor's
    /// edit) and re-parse only those. `range` is clamped to the program.
    pub fn replace_lines(&mut self, range: Range<usize>, text: &str) {
        let end = range.end.min(self.lines.len());
        let start = range.start.min(end);
        let language = self.language;
        let new = source::lines(text).map(|l| parse_line(language, l));
        self.lines.splice(start..end, new);
        self.renumber();
    }

    /// The command lines to store, canonical and without comments (what the
    /// upload sends, each followed by its line end), or the first line that
    /// does not parse.
    pub fn upload_lines(&self) -> Result<Vec<String>, (Span, &SyntaxError)> {
        self.statements()
            .map(|(line, s)| match &s.command {
                Ok(c) => Ok(c.to_string()),
                Err(e) => Err((Span::new(line, e.cols.clone()), e)),
            })
            .collect()
    }

    /// Where the isel jump, branch or loop of command `index` leads: the
    /// command index of its target (`3 0,5` at i: i + 5; `3 6,-5` at i: the
    /// first command it repeats, i − 5), when that is inside the program.
    /// `None` for other commands, EMCU jobs, and targets outside.
    pub fn jump_target(&self, index: usize) -> Option<usize> {
        let command = self.statement(index)?.1.command.as_ref().ok()?.as_isel();
        match flow::flow_of(command, index) {
            Flow::Jump(t) | Flow::Branch(t) | Flow::Loop { start: t } => {
                flow::inside(t, self.command_count())
            }
            Flow::Next | Flow::End => None,
        }
    }

    /// The source text: every line as read, ended by LF, so that
    /// [`Program::parse`] reads the same lines back. A line that itself ends
    /// with a CR (read from `CR CR LF`) is ended by CR LF: the one CR before
    /// an LF is taken as part of the line end ([`source::lines`]).
    pub fn text(&self) -> String {
        let mut out = String::with_capacity(self.lines.iter().map(|l| l.text.len() + 2).sum());
        for line in &self.lines {
            out.push_str(&line.text);
            if line.text.ends_with('\r') {
                out.push('\r');
            }
            out.push('\n');
        }
        out
    }

    /// The content of every line without positions.
    pub fn items(&self) -> Vec<Item<'_>> {
        self.lines
            .iter()
            .map(|line| match &line.kind {
                LineKind::Blank => Item::Blank,
                LineKind::Comment(cols) => Item::Comment(line.slice(cols.clone())),
                LineKind::Statement(s) => Item::Command {
                    command: s.command.as_ref().map_err(|_| line.slice(s.code.clone())),
                    comment: s.comment.clone().map(|c| line.slice(c)),
                },
            })
            .collect()
    }

    fn renumber(&mut self) {
        self.commands.clear();
        for (number, line) in self.lines.iter_mut().enumerate() {
            if let LineKind::Statement(s) = &mut line.kind {
                s.index = self.commands.len();
                self.commands.push(number);
            }
        }
    }
}

fn parse_line(language: Language, text: &str) -> Line {
    let kind = match source::shape(text) {
        Shape::Blank => LineKind::Blank,
        Shape::Comment(cols) => LineKind::Comment(cols),
        Shape::Code { code, comment } => {
            let code_text = text.get(code.clone()).unwrap_or_default();
            let mut parsed = match language {
                Language::Isel => isel_line::parse(code_text, code.start),
                Language::Emcu => emcu_line::parse(code_text, code.start),
            };
            // The cores count bytes; a span must cover whole characters so
            // that an editor can slice the line with it.
            if let Err(e) = &mut parsed.command {
                e.cols = on_char_boundaries(text, e.cols.clone());
            }
            LineKind::Statement(Statement {
                index: 0,
                code,
                comment,
                params: parsed.params,
                notes: parsed.notes,
                command: parsed.command,
            })
        }
    };
    Line {
        text: text.to_string(),
        kind,
    }
}

/// `cols` widened to whole characters of `text`.
fn on_char_boundaries(text: &str, cols: Range<usize>) -> Range<usize> {
    let mut start = cols.start.min(text.len());
    while !text.is_char_boundary(start) {
        start -= 1;
    }
    let mut end = cols.end.clamp(start, text.len());
    while !text.is_char_boundary(end) {
        end += 1;
    }
    start..end
}
