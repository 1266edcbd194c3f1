//! The work offsets file on disk: one per profile and port, in jogterm's
//! state directory (`$JOGTERM_STATE_DIR/offsets`, else
//! `~/.local/state/jogterm/offsets`: the directory the editor's recovery
//! files live in, `program::store::state_dir`). One file per port, so that
//! the built-in simulator's offsets never reach a machine on a real port,
//! nor one machine's those of another that shares its profile.
//!
//! Written atomically (`program::store::save`: a temporary file, `fsync`,
//! rename) on a thread of its own ([`Writer`]), so a slow disk never holds
//! up the console's loop and with it a stop. A file that was refused at
//! start is put aside (renamed, never deleted) before the first write
//! replaces it.

use std::fs::{self, DirBuilder};
use std::io::Read;
use std::os::unix::fs::DirBuilderExt;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{self, Sender};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use crate::config::{Origin, Source};
use crate::program::store::{self as files, Fingerprint};

use super::WorkOffsets;
use super::file::{self, Identity, Loaded};

/// A file bigger than this is no offsets file jogterm wrote (six systems of
/// four axes are well under 2 KiB).
const MAX_BYTES: u64 = 64 * 1024;

/// The name a profile was chosen by, for the file name: the stem of its
/// most specific file (`--profile mill`, `profiles/mill.toml`: `mill`), or
/// the shipped profile's name.
pub fn profile_key(sources: &[Source]) -> String {
    match sources.first().map(|s| &s.origin) {
        Some(Origin::File(path)) => path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "profile".into()),
        Some(Origin::Embedded(name)) => (*name).to_string(),
        None => "profile".into(),
    }
}

/// A name part for a file name; a hash of the whole text is added when the
/// text had to be changed (`/dev/ttyUSB0`), so two ports never share a file.
fn name_part(text: &str) -> String {
    let clean = files::sanitise(text);
    if clean == text {
        clean
    } else {
        format!(
            "{clean}-{:08x}",
            Fingerprint::of(text.as_bytes()).hash as u32
        )
    }
}

/// Where the session's offsets live and whose they are.
#[derive(Debug, Clone, PartialEq)]
pub struct OffsetsFile {
    pub path: PathBuf,
    pub identity: Identity,
}

/// What the console starts with.
#[derive(Debug, Clone, PartialEq)]
pub struct Startup {
    pub offsets: WorkOffsets,
    /// Something to tell the operator: the file was refused, or there is
    /// none for this port while there are for others.
    pub note: Option<String>,
    /// The file on disk was refused: put it aside before writing.
    pub refused: bool,
}

impl OffsetsFile {
    /// The file of the session `identity` in the offsets directory `dir`.
    pub fn in_dir(dir: &Path, identity: Identity) -> OffsetsFile {
        let name = format!(
            "{}@{}.toml",
            name_part(&identity.profile),
            name_part(&identity.port)
        );
        OffsetsFile {
            path: dir.join(name),
            identity,
        }
    }

    /// The session's file in the user's state directory; `None` without one.
    pub fn from_env(identity: Identity) -> Option<OffsetsFile> {
        files::state_dir().map(|d| OffsetsFile::in_dir(&d.join("offsets"), identity))
    }

    /// Read the file at start. No file: every system at the reference point
    /// (machine coordinates). A file that cannot be read, is broken, or
    /// belongs to another machine: the same, and the note says why.
    pub fn load(&self) -> Startup {
        let fresh = |note: Option<String>, refused: bool| Startup {
            offsets: WorkOffsets::default(),
            note,
            refused,
        };
        let text = match read_capped(&self.path) {
            Ok(Some(text)) => text,
            Ok(None) => return fresh(self.elsewhere(), false),
            Err(why) => {
                return fresh(
                    Some(format!(
                        "work offsets not applied: {why}; G54-G59 start at the reference point"
                    )),
                    true,
                );
            }
        };
        let source = Source {
            origin: Origin::File(self.path.clone()),
            text,
        };
        match file::decode(&source, &self.identity) {
            Loaded::Offsets(offsets) => Startup {
                offsets,
                note: None,
                refused: false,
            },
            Loaded::Refused(why) => fresh(
                Some(format!(
                    "work offsets refused, not applied: {why}. G54-G59 start at the reference \
                     point; the file is kept and put aside when an offset is set"
                )),
                true,
            ),
        }
    }

    /// Files of the same profile for other ports, named in a note: the
    /// port may have been renamed (a USB adapter plugged elsewhere).
    fn elsewhere(&self) -> Option<String> {
        let dir = self.path.parent()?;
        let prefix = format!("{}@", name_part(&self.identity.profile));
        let mut others: Vec<String> = fs::read_dir(dir)
            .ok()?
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with(&prefix) && n.ends_with(".toml"))
            .collect();
        others.sort();
        (!others.is_empty()).then(|| {
            format!(
                "no work offsets saved for port {} yet (G54-G59 at the reference point); \
                 saved for other ports of this profile: {} in {}",
                self.identity.port,
                others.join(", "),
                dir.display()
            )
        })
    }

    /// What to write for `offsets`; `put_aside` for a file refused at start.
    pub fn job(&self, offsets: &WorkOffsets, put_aside: bool) -> SaveJob {
        SaveJob {
            what: "work offsets",
            path: self.path.clone(),
            text: file::encode(offsets, &self.identity),
            put_aside,
        }
    }
}

/// The file's text, `None` when there is none; an error in words.
fn read_capped(path: &Path) -> Result<Option<String>, String> {
    let file = match fs::File::open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(format!("{}: {e}", path.display())),
    };
    let mut bytes = Vec::new();
    file.take(MAX_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    if bytes.len() as u64 > MAX_BYTES {
        return Err(format!(
            "{}: more than {MAX_BYTES} bytes, not an offsets file",
            path.display()
        ));
    }
    String::from_utf8(bytes)
        .map(Some)
        .map_err(|_| format!("{}: not text (UTF-8)", path.display()))
}

/// One write of the offsets file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SaveJob {
    /// What the file keeps, in words for a failed write ("work offsets").
    pub what: &'static str,
    pub path: PathBuf,
    pub text: String,
    /// Rename the file there now (refused at start) before writing.
    pub put_aside: bool,
}

/// How a write went: where it went, or why it failed, in words.
pub type Saved = Result<PathBuf, String>;

/// Carry out `job` (blocking): the directory made (private to the user),
/// a refused file renamed to `….refused-<seconds>`, the text written
/// atomically.
pub fn save(job: &SaveJob) -> Saved {
    let dir = job.path.parent().unwrap_or(Path::new("."));
    DirBuilder::new()
        .recursive(true)
        .mode(0o700)
        .create(dir)
        .map_err(|e| format!("{}: {e}", dir.display()))?;
    if job.put_aside && job.path.exists() {
        let secs = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| d.as_secs());
        let mut aside = job.path.clone().into_os_string();
        aside.push(format!(".refused-{secs}"));
        fs::rename(&job.path, &aside).map_err(|e| format!("{}: {e}", job.path.display()))?;
    }
    files::save(&job.path, &job.text, None).map_err(|e| e.to_string())?;
    Ok(job.path.clone())
}

/// The thread that writes the offsets file, in the order asked.
pub struct Writer {
    jobs: Option<Sender<SaveJob>>,
    thread: Option<JoinHandle<()>>,
}

impl Writer {
    /// Start the thread; `report` hears how each write went, with what
    /// the file keeps.
    pub fn spawn(report: impl Fn(&'static str, Saved) + Send + 'static) -> std::io::Result<Writer> {
        let (tx, rx) = mpsc::channel::<SaveJob>();
        let thread = thread::Builder::new()
            .name("jogterm-offsets".into())
            .spawn(move || {
                while let Ok(job) = rx.recv() {
                    report(job.what, save(&job));
                }
            })?;
        Ok(Writer {
            jobs: Some(tx),
            thread: Some(thread),
        })
    }

    /// Hand a write over; never blocks.
    pub fn submit(&self, job: SaveJob) {
        if let Some(jobs) = &self.jobs {
            let _ = jobs.send(job);
        }
    }

    /// No more writes: finish those handed over, waiting at most `bound`.
    pub fn finish(mut self, bound: Duration) {
        self.jobs = None;
        let until = Instant::now() + bound;
        while Instant::now() < until && self.thread.as_ref().is_some_and(|t| !t.is_finished()) {
            thread::sleep(Duration::from_millis(5));
        }
        if let Some(t) = self.thread.take().filter(|t| t.is_finished()) {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axis::Axis;
    use crate::config::{ConfigDirs, load_profile};
    use crate::offsets::System;

    fn identity(port: &str) -> Identity {
        let mut profile = load_profile("default", &ConfigDirs::builtin_only()).expect("profile");
        profile.connection.port = port.into();
        Identity::of("default", &profile)
    }

    #[test]
    fn one_file_per_profile_and_port() {
        let dir = Path::new("/state/offsets");
        let sim = OffsetsFile::in_dir(dir, identity("sim"));
        assert_eq!(sim.path, dir.join("default@sim.toml"));
        let usb0 = OffsetsFile::in_dir(dir, identity("/dev/ttyUSB0"));
        let usb1 = OffsetsFile::in_dir(dir, identity("/dev/ttyUSB1"));
        let name = usb0
            .path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned());
        assert!(
            name.as_deref()
                .is_some_and(|n| n.starts_with("default@_dev_ttyUSB0-")),
            "{name:?}"
        );
        assert_ne!(usb0.path, usb1.path);
    }

    #[test]
    fn offsets_are_saved_read_back_and_a_refused_file_put_aside() {
        let dir = tempfile::tempdir().expect("tempdir");
        let offsets_dir = dir.path().join("offsets");
        let file = OffsetsFile::in_dir(&offsets_dir, identity("sim"));
        // Nothing yet.
        let start = file.load();
        assert_eq!(start.offsets, WorkOffsets::default());
        assert_eq!((start.note, start.refused), (None, false));
        let mut t = WorkOffsets::default();
        t.set(System::ALL[1], Axis::X, 4000);
        t.select(System::ALL[1]);
        assert_eq!(save(&file.job(&t, false)), Ok(file.path.clone()));
        assert_eq!(file.load().offsets, t);
        // Another port of the same profile: nothing, and a note of the other.
        let usb = OffsetsFile::in_dir(&offsets_dir, identity("/dev/ttyUSB0"));
        let start = usb.load();
        assert_eq!(start.offsets, WorkOffsets::default());
        let note = start.note.unwrap_or_default();
        assert!(note.contains("default@sim.toml"), "{note}");
        // Other steps per unit: refused, kept until a write puts it aside.
        let mut finer = identity("sim");
        if let Some(x) = finer.axes.first_mut() {
            x.steps_per_unit = 800.0;
        }
        let finer = OffsetsFile::in_dir(&offsets_dir, finer);
        let start = finer.load();
        assert!(start.refused);
        assert_eq!(start.offsets, WorkOffsets::default());
        let note = start.note.unwrap_or_default();
        assert!(
            note.contains("X at 400 steps per mm, the profile 800"),
            "{note}"
        );
        assert!(file.path.exists());
        assert_eq!(
            save(&finer.job(&WorkOffsets::default(), true)),
            Ok(finer.path.clone())
        );
        let aside: Vec<String> = fs::read_dir(&offsets_dir)
            .expect("dir")
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with("default@sim.toml.refused-"))
            .collect();
        assert_eq!(aside.len(), 1, "{aside:?}");
        assert!(!finer.load().refused);
    }

    #[test]
    fn an_unreadable_file_is_refused_without_a_panic() {
        let dir = tempfile::tempdir().expect("tempdir");
        let file = OffsetsFile::in_dir(dir.path(), identity("sim"));
        for bytes in [vec![0xff, 0xfe, 0x00], vec![b'#'; 70_000]] {
            fs::write(&file.path, &bytes).expect("write");
            let start = file.load();
            assert!(start.refused);
            let note = start.note.unwrap_or_default();
            assert!(note.contains("not applied"), "{note}");
        }
        // A directory where the file should be.
        fs::remove_file(&file.path).expect("remove");
        fs::create_dir(&file.path).expect("dir");
        let start = file.load();
        assert!(start.refused, "{start:?}");
    }

    #[test]
    fn the_writer_writes_in_order_and_reports() {
        let dir = tempfile::tempdir().expect("tempdir");
        let file = OffsetsFile::in_dir(dir.path(), identity("sim"));
        let (tx, rx) = mpsc::channel();
        let writer = Writer::spawn(move |_, saved| {
            let _ = tx.send(saved);
        })
        .expect("writer");
        let mut t = WorkOffsets::default();
        for steps in 1..=5 {
            t.set(System::G54, Axis::Y, steps);
            writer.submit(file.job(&t, false));
        }
        writer.finish(Duration::from_secs(10));
        let reports: Vec<Saved> = rx.try_iter().collect();
        assert_eq!(reports.len(), 5);
        assert!(reports.iter().all(Result::is_ok), "{reports:?}");
        assert_eq!(file.load().offsets.zero(System::G54, Axis::Y), 5);
    }
}
