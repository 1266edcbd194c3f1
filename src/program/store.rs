//! Program files on disk, so that nothing an operator writes is lost
//! (`docs/editor.md`, "Nothing lost"):
//!
//! - [`load`]: a program file, size-capped, with bytes that are not UTF-8
//!   replaced and said so (a later save would write the replacements).
//! - [`save`]: atomic: the text goes to a temporary file in the same
//!   directory, is flushed to the disk (`fsync`), renamed over the target,
//!   and the directory is flushed too. A crash at any moment leaves either
//!   the old file or the new one, never half of one. A symbolic link is
//!   followed (the file it names is replaced, the link stays), the file's
//!   permissions are kept, and a file that changed on disk since it was
//!   opened is not overwritten unless asked ([`StoreError::Changed`]).
//! - [`RecoveryStore`]: unsaved edits, written every few seconds by the
//!   editor (atomically as well) to the user's state directory, one file per
//!   program, and offered back on the next start. They survive `SIGKILL`
//!   because they are written while editing, not on exit.
//!
//! This is the only part of the editor that touches files; the UI asks for
//! it through effects and runs it on a worker thread.

use std::ffi::OsStr;
use std::fmt;
use std::fs::{self, DirBuilder, File, OpenOptions};
use std::io::{self, Read, Write};
use std::os::unix::ffi::OsStrExt;
use std::os::unix::fs::{DirBuilderExt, OpenOptionsExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use thiserror::Error;

use super::model::Language;

/// Largest file the editor opens: far above any program a controller
/// stores (isel 2000 commands, EMCU 256), far below what would hurt.
pub const MAX_FILE_BYTES: u64 = 16 * 1024 * 1024;

/// The environment variable that names the state directory (tests, and
/// operators who want the recovery files elsewhere).
pub const STATE_DIR_ENV: &str = "JOGTERM_STATE_DIR";

/// What the bytes of a file were: length and a 64-bit FNV-1a hash. Enough to
/// tell whether a file changed on disk since it was read; not a security
/// measure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Fingerprint {
    pub len: u64,
    pub hash: u64,
}

impl Fingerprint {
    pub fn of(bytes: &[u8]) -> Fingerprint {
        let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
        for b in bytes {
            hash ^= u64::from(*b);
            hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
        }
        Fingerprint {
            len: bytes.len() as u64,
            hash,
        }
    }

    fn parse(text: &str) -> Option<Fingerprint> {
        let (hash, len) = text.split_once('-')?;
        Some(Fingerprint {
            hash: u64::from_str_radix(hash, 16).ok()?,
            len: len.parse().ok()?,
        })
    }
}

impl fmt::Display for Fingerprint {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:016x}-{}", self.hash, self.len)
    }
}

#[derive(Debug, Error)]
pub enum StoreError {
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
    #[error("{}: {size} bytes is too large for a program (at most {MAX_FILE_BYTES})", path.display())]
    TooLarge { path: PathBuf, size: u64 },
    #[error("{}: not a regular file", path.display())]
    NotAFile { path: PathBuf },
    #[error("{}: there is no folder {}", path.display(), folder.display())]
    NoFolder { path: PathBuf, folder: PathBuf },
    #[error("{} changed on disk since it was opened", path.display())]
    Changed { path: PathBuf },
    #[error("{}: not a jogterm recovery file: {reason}", path.display())]
    BadRecovery { path: PathBuf, reason: String },
}

fn io_error(path: &Path) -> impl FnOnce(io::Error) -> StoreError + '_ {
    move |source| StoreError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// A program file as read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Loaded {
    /// The absolute path it was read from (as given, made absolute; links
    /// are not resolved, so the editor shows the name the operator used).
    pub path: PathBuf,
    pub text: String,
    /// Some bytes were not UTF-8 and were replaced by U+FFFD.
    pub lossy: bool,
    /// Of the bytes on disk.
    pub fingerprint: Fingerprint,
}

/// `path` made absolute against the current directory, without touching
/// the file system beyond that.
pub fn absolute(path: &Path) -> Result<PathBuf, StoreError> {
    std::path::absolute(path).map_err(io_error(path))
}

/// Read a program file; `Ok(None)` when there is none (a new file). A file
/// in a folder that does not exist is an error, not a new file: it could
/// never be saved, and is most likely a mistyped path.
pub fn load(path: &Path) -> Result<Option<Loaded>, StoreError> {
    let path = absolute(path)?;
    let file = match File::open(&path) {
        Ok(f) => f,
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            return match path.parent() {
                Some(folder) if !folder.is_dir() => Err(StoreError::NoFolder {
                    folder: folder.to_path_buf(),
                    path,
                }),
                _ => Ok(None),
            };
        }
        Err(e) => return Err(io_error(&path)(e)),
    };
    let meta = file.metadata().map_err(io_error(&path))?;
    if !meta.is_file() {
        return Err(StoreError::NotAFile { path });
    }
    if meta.len() > MAX_FILE_BYTES {
        return Err(StoreError::TooLarge {
            size: meta.len(),
            path,
        });
    }
    let bytes = read_capped(file, &path)?;
    let fingerprint = Fingerprint::of(&bytes);
    let (text, lossy) = match String::from_utf8(bytes) {
        Ok(text) => (text, false),
        Err(e) => (String::from_utf8_lossy(e.as_bytes()).into_owned(), true),
    };
    Ok(Some(Loaded {
        path,
        text,
        lossy,
        fingerprint,
    }))
}

/// Read at most `MAX_FILE_BYTES` (a file may grow between `metadata` and
/// the read).
fn read_capped(file: File, path: &Path) -> Result<Vec<u8>, StoreError> {
    let mut bytes = Vec::new();
    file.take(MAX_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(io_error(path))?;
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(StoreError::TooLarge {
            size: bytes.len() as u64,
            path: path.to_path_buf(),
        });
    }
    Ok(bytes)
}

/// The fingerprint of the file at `path` now; `None` when there is none.
pub fn fingerprint(path: &Path) -> Result<Option<Fingerprint>, StoreError> {
    match File::open(path) {
        Ok(f) => Ok(Some(Fingerprint::of(&read_capped(f, path)?))),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(io_error(path)(e)),
    }
}

/// Save `text` to `path` atomically and return the fingerprint of what was
/// written. With `expect`, the file must still hold what it held when it was
/// opened (or not exist any more), else nothing is written and
/// [`StoreError::Changed`] says so.
pub fn save(
    path: &Path,
    text: &str,
    expect: Option<Fingerprint>,
) -> Result<Fingerprint, StoreError> {
    let path = absolute(path)?;
    // Replace the file a link names, not the link.
    let target = match fs::canonicalize(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == io::ErrorKind::NotFound => path.clone(),
        Err(e) => return Err(io_error(&path)(e)),
    };
    let existing = match fs::metadata(&target) {
        Ok(meta) if !meta.is_file() => return Err(StoreError::NotAFile { path }),
        Ok(meta) => Some(meta),
        Err(e) if e.kind() == io::ErrorKind::NotFound => None,
        Err(e) => return Err(io_error(&target)(e)),
    };
    if let (Some(expected), Some(_)) = (expect, &existing)
        && fingerprint(&target)? != Some(expected)
    {
        return Err(StoreError::Changed { path });
    }
    let mode = existing.map(|m| m.permissions().mode() & 0o7777);
    write_atomically(&target, text.as_bytes(), mode.unwrap_or(0o666))?;
    Ok(Fingerprint::of(text.as_bytes()))
}

/// Temporary names are unique within the process; the pid makes them
/// unique between processes.
static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Write `bytes` to a temporary file beside `target`, flush it to the disk,
/// rename it over `target`, flush the directory. `mode` is applied before
/// the rename (the umask applies to new files as usual).
pub(crate) fn write_atomically(target: &Path, bytes: &[u8], mode: u32) -> Result<(), StoreError> {
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = target
        .file_name()
        .map(OsStr::to_string_lossy)
        .unwrap_or_default();
    let temp = dir.join(format!(
        ".{name}.jogterm-save-{}-{}",
        std::process::id(),
        TEMP_COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let written = (|| {
        let mut file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .mode(mode)
            .open(&temp)
            .map_err(io_error(&temp))?;
        file.write_all(bytes).map_err(io_error(&temp))?;
        // `mode` on open is filtered by the umask; an existing file's mode
        // is restored exactly.
        file.set_permissions(fs::Permissions::from_mode(mode))
            .map_err(io_error(&temp))?;
        file.sync_all().map_err(io_error(&temp))?;
        fs::rename(&temp, target).map_err(io_error(target))
    })();
    if written.is_err() {
        let _ = fs::remove_file(&temp);
        return written;
    }
    // The rename is durable only once the directory is on the disk too.
    File::open(&dir)
        .and_then(|d| d.sync_all())
        .map_err(io_error(&dir))
}

/// Whose edits a recovery file holds.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum Origin {
    /// A program file (absolute path).
    File(PathBuf),
    /// A program never saved, of one editor session (`tag` tells sessions
    /// apart).
    Untitled { tag: String },
}

impl Origin {
    /// The name the operator knows the program by.
    pub fn describe(&self) -> String {
        match self {
            Origin::File(path) => path.display().to_string(),
            Origin::Untitled { .. } => "an unsaved new program".to_string(),
        }
    }
}

/// Unsaved edits of one program.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Recovery {
    pub origin: Origin,
    pub language: Language,
    /// When the edits were written.
    pub written: SystemTime,
    /// The file's fingerprint when it was last opened or saved: a save of
    /// the recovered text checks that the file has not changed since.
    pub base: Option<Fingerprint>,
    pub text: String,
}

/// First line of every recovery file.
const MAGIC: &str = "jogterm recovery 1";
/// Recovery file names end with this.
pub const RECOVERY_EXTENSION: &str = "jogterm-recovery";

/// jogterm's state directory: `$JOGTERM_STATE_DIR`, else the user's state
/// directory (`~/.local/state/jogterm` on Linux), else the local data
/// directory; `None` without a home directory. Recovery files and work
/// offsets (`crate::offsets::store`) live below it.
pub fn state_dir() -> Option<PathBuf> {
    if let Some(dir) = std::env::var_os(STATE_DIR_ENV).filter(|d| !d.is_empty()) {
        return Some(PathBuf::from(dir));
    }
    let dirs = directories::ProjectDirs::from("", "", "jogterm")?;
    Some(
        dirs.state_dir()
            .map_or_else(|| dirs.data_local_dir().to_path_buf(), Path::to_path_buf),
    )
}

/// The directory of recovery files: `$JOGTERM_STATE_DIR/recovery`, else the
/// user's state directory (`~/.local/state/jogterm/recovery` on Linux), else
/// the local data directory.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecoveryStore {
    dir: PathBuf,
}

impl RecoveryStore {
    pub fn new(dir: impl Into<PathBuf>) -> RecoveryStore {
        RecoveryStore { dir: dir.into() }
    }

    /// Where this user's recovery files live; `None` when there is no home
    /// directory to put them in.
    pub fn from_env() -> Option<RecoveryStore> {
        state_dir().map(|base| RecoveryStore::new(base.join("recovery")))
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The file that holds the edits of `origin`: the program's name (for a
    /// person listing the directory) and a hash of its whole path (so two
    /// programs of the same name do not meet).
    pub fn path_for(&self, origin: &Origin) -> PathBuf {
        let name = match origin {
            Origin::File(path) => {
                let stem = path
                    .file_name()
                    .map(|n| sanitise(&n.to_string_lossy()))
                    .unwrap_or_default();
                let hash = Fingerprint::of(path.as_os_str().as_bytes()).hash;
                format!("{stem}-{hash:016x}.{RECOVERY_EXTENSION}")
            }
            Origin::Untitled { tag } => format!("untitled-{}.{RECOVERY_EXTENSION}", sanitise(tag)),
        };
        self.dir.join(name)
    }

    /// Write `recovery` (atomically, private to the user) and return where.
    pub fn write(&self, recovery: &Recovery) -> Result<PathBuf, StoreError> {
        DirBuilder::new()
            .recursive(true)
            .mode(0o700)
            .create(&self.dir)
            .map_err(io_error(&self.dir))?;
        let path = self.path_for(&recovery.origin);
        write_atomically(&path, encode(recovery).as_bytes(), 0o600)?;
        Ok(path)
    }

    /// Remove the recovery of `origin` (the edits were saved or discarded);
    /// none there is fine.
    pub fn remove(&self, origin: &Origin) -> Result<(), StoreError> {
        let path = self.path_for(origin);
        match fs::remove_file(&path) {
            Ok(()) => Ok(()),
            Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(()),
            Err(e) => Err(io_error(&path)(e)),
        }
    }

    /// The operator declined the recovery of `origin`: it is kept once more
    /// as `….discarded` (replacing an older one), so even a wrong answer
    /// loses nothing.
    pub fn discard(&self, origin: &Origin) -> Result<(), StoreError> {
        let path = self.path_for(origin);
        let mut aside = path.clone().into_os_string();
        aside.push(".discarded");
        match fs::rename(&path, &aside) {
            Ok(()) => Ok(()),
            Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(()),
            Err(e) => Err(io_error(&path)(e)),
        }
    }

    /// The recovery of `origin`, if there is one.
    pub fn read(&self, origin: &Origin) -> Result<Option<Recovery>, StoreError> {
        let path = self.path_for(origin);
        match File::open(&path) {
            Ok(file) => read_recovery(file, &path).map(Some),
            Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(io_error(&path)(e)),
        }
    }

    /// Every recovery in the directory, newest first; files that cannot be
    /// read are listed with their error (and left alone).
    pub fn scan(&self) -> Vec<Result<Recovery, StoreError>> {
        let entries = match fs::read_dir(&self.dir) {
            Ok(entries) => entries,
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Vec::new(),
            Err(e) => return vec![Err(io_error(&self.dir)(e))],
        };
        let mut found: Vec<Result<Recovery, StoreError>> = entries
            .filter_map(Result::ok)
            .map(|entry| entry.path())
            .filter(|path| path.extension() == Some(OsStr::new(RECOVERY_EXTENSION)))
            .map(|path| {
                File::open(&path)
                    .map_err(io_error(&path))
                    .and_then(|f| read_recovery(f, &path))
            })
            .collect();
        found.sort_by_key(|r| std::cmp::Reverse(r.as_ref().ok().map(|r| r.written)));
        found
    }
}

/// A name for a file name: letters, digits, `.`, `-`, `_` kept, the rest `_`,
/// at most 40 characters.
pub fn sanitise(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '_') {
                c
            } else {
                '_'
            }
        })
        .take(40)
        .collect()
}

/// A path on one line: bytes outside printable ASCII, `%` and a leading
/// blank written as `%XX`.
fn encode_path(path: &Path) -> String {
    let mut out = String::new();
    for (i, b) in path.as_os_str().as_bytes().iter().enumerate() {
        let plain = ((0x21..0x7f).contains(b) && *b != b'%') || (*b == b' ' && i > 0);
        if plain {
            out.push(char::from(*b));
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}

fn decode_path(text: &str) -> Option<PathBuf> {
    let bytes = text.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while let Some(&b) = bytes.get(i) {
        if b == b'%' {
            let hex = text.get(i + 1..i + 3)?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(b);
            i += 1;
        }
    }
    Some(PathBuf::from(OsStr::from_bytes(&out)))
}

/// The file format: a header of `key: value` lines, a blank line, then the
/// program text exactly as it was in the editor.
fn encode(recovery: &Recovery) -> String {
    let origin = match &recovery.origin {
        Origin::File(path) => format!("file {}", encode_path(path)),
        Origin::Untitled { tag } => format!("untitled {}", sanitise(tag)),
    };
    let written = recovery
        .written
        .duration_since(UNIX_EPOCH)
        .unwrap_or_default()
        .as_secs();
    let base = recovery
        .base
        .map_or_else(|| "none".to_string(), |f| f.to_string());
    format!(
        "{MAGIC}\norigin: {origin}\nlanguage: {}\nwritten: {written}\nbase: {base}\n\n{}",
        recovery.language, recovery.text
    )
}

fn read_recovery(file: File, path: &Path) -> Result<Recovery, StoreError> {
    let bytes = read_capped(file, path)?;
    let text = String::from_utf8(bytes).map_err(|_| StoreError::BadRecovery {
        path: path.to_path_buf(),
        reason: "not UTF-8".into(),
    })?;
    decode(&text).map_err(|reason| StoreError::BadRecovery {
        path: path.to_path_buf(),
        reason,
    })
}

fn decode(text: &str) -> Result<Recovery, String> {
    let (header, body) = text
        .split_once("\n\n")
        .ok_or_else(|| "no blank line after the header".to_string())?;
    let mut lines = header.lines();
    if lines.next() != Some(MAGIC) {
        return Err(format!("the first line is not `{MAGIC}`"));
    }
    let mut field = |name: &str| -> Result<String, String> {
        let line = lines.next().unwrap_or_default();
        line.strip_prefix(name)
            .and_then(|rest| rest.strip_prefix(": "))
            .map(str::to_string)
            .ok_or_else(|| format!("expected `{name}: …`, got `{line}`"))
    };
    let origin = field("origin")?;
    let origin = if let Some(path) = origin.strip_prefix("file ") {
        Origin::File(decode_path(path).ok_or_else(|| format!("bad path `{path}`"))?)
    } else if let Some(tag) = origin.strip_prefix("untitled ") {
        Origin::Untitled {
            tag: tag.to_string(),
        }
    } else {
        return Err(format!("bad origin `{origin}`"));
    };
    let language = field("language")?;
    let language = Language::ALL
        .into_iter()
        .find(|l| l.name() == language)
        .ok_or_else(|| format!("unknown language `{language}`"))?;
    let written = field("written")?;
    let written = written
        .parse::<u64>()
        .map(|s| UNIX_EPOCH + Duration::from_secs(s))
        .map_err(|_| format!("bad time `{written}`"))?;
    let base = field("base")?;
    let base = match base.as_str() {
        "none" => None,
        other => {
            Some(Fingerprint::parse(other).ok_or_else(|| format!("bad fingerprint `{other}`"))?)
        }
    };
    Ok(Recovery {
        origin,
        language,
        written,
        base,
        text: body.to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn dir() -> tempfile::TempDir {
        tempfile::tempdir().expect("tempdir")
    }

    #[test]
    fn load_reads_text_and_says_when_bytes_were_replaced() {
        let d = dir();
        let path = d.path().join("a.isel");
        assert_eq!(load(&path).expect("ok"), None, "a new file");
        fs::write(&path, b"77\n9\n").expect("write");
        let loaded = load(&path).expect("ok").expect("there");
        assert_eq!((loaded.text.as_str(), loaded.lossy), ("77\n9\n", false));
        assert_eq!(loaded.fingerprint, Fingerprint::of(b"77\n9\n"));
        fs::write(&path, b"; caf\xe9\n").expect("write");
        let loaded = load(&path).expect("ok").expect("there");
        assert!(loaded.lossy);
        assert_eq!(loaded.text, "; caf\u{fffd}\n");
        assert!(matches!(load(d.path()), Err(StoreError::NotAFile { .. })));
        // A new file needs a folder to be saved in.
        let nowhere = d.path().join("no-such-folder").join("a.isel");
        let e = load(&nowhere).expect_err("no folder");
        assert!(matches!(e, StoreError::NoFolder { .. }), "{e}");
        assert!(e.to_string().contains("there is no folder"), "{e}");
    }

    #[test]
    fn save_replaces_the_file_whole_and_keeps_its_mode() {
        let d = dir();
        let path = d.path().join("p.isel");
        fs::write(&path, "old\n").expect("write");
        fs::set_permissions(&path, fs::Permissions::from_mode(0o640)).expect("chmod");
        let before = fingerprint(&path).expect("ok");
        let written = save(&path, "77\n9\n", before).expect("saved");
        assert_eq!(fs::read_to_string(&path).expect("read"), "77\n9\n");
        assert_eq!(written, Fingerprint::of(b"77\n9\n"));
        let mode = fs::metadata(&path).expect("meta").permissions().mode() & 0o777;
        assert_eq!(mode, 0o640);
        let leftovers: Vec<_> = fs::read_dir(d.path())
            .expect("dir")
            .filter_map(Result::ok)
            .map(|e| e.file_name())
            .collect();
        assert_eq!(leftovers, [OsStr::new("p.isel")], "no temporary files left");
    }

    #[test]
    fn save_refuses_a_file_changed_on_disk_unless_told() {
        let d = dir();
        let path = d.path().join("p.isel");
        fs::write(&path, "mine\n").expect("write");
        let opened = fingerprint(&path).expect("ok");
        fs::write(&path, "someone else's\n").expect("write");
        assert!(matches!(
            save(&path, "edited\n", opened),
            Err(StoreError::Changed { .. })
        ));
        assert_eq!(fs::read_to_string(&path).expect("read"), "someone else's\n");
        save(&path, "edited\n", None).expect("overwrite when told");
        assert_eq!(fs::read_to_string(&path).expect("read"), "edited\n");
        // A file deleted meanwhile is simply written again.
        fs::remove_file(&path).expect("rm");
        save(&path, "again\n", opened).expect("saved");
    }

    #[test]
    fn save_through_a_link_replaces_the_target_and_keeps_the_link() {
        let d = dir();
        let target = d.path().join("real.isel");
        let link = d.path().join("link.isel");
        fs::write(&target, "old\n").expect("write");
        std::os::unix::fs::symlink(&target, &link).expect("link");
        save(&link, "new\n", None).expect("saved");
        assert_eq!(fs::read_to_string(&target).expect("read"), "new\n");
        assert!(
            fs::symlink_metadata(&link)
                .expect("meta")
                .file_type()
                .is_symlink()
        );
    }

    #[test]
    fn save_into_a_missing_directory_fails_cleanly() {
        let d = dir();
        let path = d.path().join("no/such/dir/p.isel");
        let err = save(&path, "9\n", None).expect_err("fails");
        assert!(err.to_string().contains("no/such/dir"), "{err}");
    }

    fn recovery(origin: Origin, text: &str) -> Recovery {
        Recovery {
            origin,
            language: Language::Isel,
            written: UNIX_EPOCH + Duration::from_secs(1_763_772_000),
            base: Some(Fingerprint::of(b"base")),
            text: text.to_string(),
        }
    }

    #[test]
    fn recoveries_round_trip_and_are_listed_newest_first() {
        let d = dir();
        let store = RecoveryStore::new(d.path().join("recovery"));
        assert!(store.scan().is_empty(), "no directory yet is no recovery");
        let a = recovery(
            Origin::File(PathBuf::from("/work/odd name%\n.isel")),
            "77\n\n\n9\n",
        );
        let mut b = recovery(
            Origin::Untitled {
                tag: "1234-5".into(),
            },
            "",
        );
        b.written += Duration::from_secs(60);
        b.base = None;
        b.language = Language::Emcu;
        store.write(&a).expect("write");
        store.write(&b).expect("write");
        let mode = fs::metadata(store.path_for(&a.origin))
            .expect("meta")
            .permissions()
            .mode();
        assert_eq!(mode & 0o777, 0o600, "private");
        let found: Vec<Recovery> = store.scan().into_iter().map(|r| r.expect("ok")).collect();
        assert_eq!(found, [b.clone(), a.clone()]);
        assert_eq!(store.read(&a.origin).expect("ok"), Some(a.clone()));
        store.discard(&a.origin).expect("discard");
        assert_eq!(store.read(&a.origin).expect("ok"), None);
        assert_eq!(
            store.scan().len(),
            1,
            "the discarded one is kept aside, not listed"
        );
        store.remove(&b.origin).expect("remove");
        store.remove(&b.origin).expect("removing nothing is fine");
        assert!(store.scan().is_empty());
    }

    #[test]
    fn broken_recovery_files_are_reported_not_fatal() {
        let d = dir();
        let store = RecoveryStore::new(d.path());
        fs::write(d.path().join(format!("x.{RECOVERY_EXTENSION}")), "garbage").expect("write");
        let found = store.scan();
        assert_eq!(found.len(), 1);
        assert!(matches!(&found[0], Err(StoreError::BadRecovery { .. })));
    }

    #[test]
    fn the_same_name_in_two_directories_gets_two_recovery_files() {
        let store = RecoveryStore::new("/r");
        let a = store.path_for(&Origin::File(PathBuf::from("/a/p.isel")));
        let b = store.path_for(&Origin::File(PathBuf::from("/b/p.isel")));
        assert_ne!(a, b);
        assert!(a.to_string_lossy().starts_with("/r/p.isel-"));
    }

    proptest! {
        /// Any text and any path survive the recovery format.
        #[test]
        fn recovery_format_round_trips(
            text in any::<String>(),
            path in proptest::collection::vec(any::<u8>().prop_filter("no NUL", |b| *b != 0), 1..40),
        ) {
            let mut bytes = vec![b'/'];
            bytes.extend(path);
            let origin = Origin::File(PathBuf::from(OsStr::from_bytes(&bytes)));
            let r = recovery(origin, &text);
            prop_assert_eq!(decode(&encode(&r)), Ok(r));
        }

        /// Decoding never panics on any input.
        #[test]
        fn decoding_any_text_never_panics(text in any::<String>()) {
            let _ = decode(&text);
        }
    }
}
