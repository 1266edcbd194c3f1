//! Pseudo-terminals for the simulators: creating one (serialised, since
//! `TTYPort::pair()` is not thread-safe, `docs/field-notes.md`), and a
//! stable symlink that follows the current slave device, so a line that is
//! closed and reopened comes back under the same path, like a USB adapter
//! that reappears.

use std::fs;
use std::io;
use std::os::fd::{AsFd, AsRawFd, BorrowedFd, FromRawFd, IntoRawFd, OwnedFd, RawFd};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use rustix::io::FdFlags;
use serialport::{SerialPort, TTYPort};

use crate::transport::fd;

static PAIR_LOCK: Mutex<()> = Mutex::new(());

/// `TTYPort::pair()`, serialised across the process: `(master, slave)`.
/// Tests and tools that need a raw pty pair use this instead of calling
/// `pair()` directly.
pub fn pty_pair() -> Result<(TTYPort, TTYPort), serialport::Error> {
    let _guard = PAIR_LOCK.lock().unwrap_or_else(|p| p.into_inner());
    let (master, slave) = TTYPort::pair()?;
    // `pair()` opens both ends without O_CLOEXEC: a process that another
    // thread spawns (the test binaries run the real jogterm beside in-process
    // ptys) would inherit them and keep the line open after this side closes
    // it, so its other end never sees the hang-up. Only the moment between
    // `pair()`'s opens and these calls is left.
    close_on_exec(master.as_raw_fd())?;
    close_on_exec(slave.as_raw_fd())?;
    Ok((master, slave))
}

fn close_on_exec(fd: RawFd) -> io::Result<()> {
    // TTYPort has `AsRawFd` but not `AsFd`: hence the raw borrow.
    // SAFETY: the caller owns the descriptor and keeps it open for the call.
    let fd = unsafe { BorrowedFd::borrow_raw(fd) };
    let flags = rustix::io::fcntl_getfd(fd)?;
    rustix::io::fcntl_setfd(fd, flags | FdFlags::CLOEXEC)?;
    Ok(())
}

/// The master side of a fresh pty whose slave nobody has open yet.
#[derive(Debug)]
pub(crate) struct PtyMaster {
    pub fd: OwnedFd,
    pub slave_path: PathBuf,
}

/// Create a pty, remember the slave's path and close the slave: the client
/// opens it by path. Until one does, the master reads `EIO` and polls as
/// hung up; that is the "no client" state, not an error.
pub(crate) fn open_master() -> io::Result<PtyMaster> {
    let (master, slave) = pty_pair().map_err(io::Error::from)?;
    let slave_path = slave
        .name()
        .map(PathBuf::from)
        .ok_or_else(|| io::Error::other("the pseudo-terminal has no slave path"))?;
    drop(slave);
    // (TTYPort has no `Into<OwnedFd>`, only `IntoRawFd`.)
    // SAFETY: into_raw_fd hands over sole ownership of the open master fd.
    let fd = unsafe { OwnedFd::from_raw_fd(master.into_raw_fd()) };
    fd::set_nonblocking(fd.as_fd())?;
    Ok(PtyMaster { fd, slave_path })
}

/// A symlink at a fixed path that points at the current slave device.
#[derive(Debug, Clone)]
pub struct StableLink {
    path: PathBuf,
}

impl StableLink {
    pub fn new(path: impl Into<PathBuf>) -> Self {
        Self { path: path.into() }
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Point the link at `target`, replacing an older link atomically
    /// (a new link beside it, then `rename`). Refuses to replace anything
    /// that is not a symlink.
    pub fn point_to(&self, target: &Path) -> io::Result<()> {
        if let Ok(meta) = fs::symlink_metadata(&self.path)
            && !meta.file_type().is_symlink()
        {
            return Err(io::Error::new(
                io::ErrorKind::AlreadyExists,
                "exists and is not a symbolic link; not replacing it",
            ));
        }
        let name = self.path.file_name().ok_or_else(|| {
            io::Error::new(
                io::ErrorKind::InvalidInput,
                "the link path has no file name",
            )
        })?;
        let mut tmp_name = std::ffi::OsString::from(".");
        tmp_name.push(name);
        tmp_name.push(format!(".{}.tmp", std::process::id()));
        let tmp = self.path.with_file_name(tmp_name);
        let _ = fs::remove_file(&tmp);
        std::os::unix::fs::symlink(target, &tmp)?;
        fs::rename(&tmp, &self.path).inspect_err(|_| {
            let _ = fs::remove_file(&tmp);
        })
    }

    /// Remove the link if it still points at `target` (another simulator may
    /// have taken the path over meanwhile).
    pub fn remove_if_pointing_to(&self, target: &Path) {
        if fs::read_link(&self.path).is_ok_and(|t| t == target) {
            let _ = fs::remove_file(&self.path);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn link_is_replaced_atomically_and_removed_only_when_ours() {
        let dir = tempfile::tempdir().expect("tempdir");
        let link = StableLink::new(dir.path().join("sim"));
        link.point_to(Path::new("/dev/pts/98")).expect("first");
        link.point_to(Path::new("/dev/pts/99")).expect("replace");
        assert_eq!(
            fs::read_link(link.path()).expect("link"),
            PathBuf::from("/dev/pts/99")
        );
        link.remove_if_pointing_to(Path::new("/dev/pts/98"));
        assert!(fs::symlink_metadata(link.path()).is_ok(), "not ours: kept");
        link.remove_if_pointing_to(Path::new("/dev/pts/99"));
        assert!(fs::symlink_metadata(link.path()).is_err());
        // No temporary files left behind.
        assert_eq!(fs::read_dir(dir.path()).expect("dir").count(), 0);
    }

    #[test]
    fn both_ends_of_a_pair_are_closed_on_exec() {
        let (master, slave) = pty_pair().expect("pair");
        for fd in [master.as_raw_fd(), slave.as_raw_fd()] {
            // SAFETY: the ports keep the descriptor open for the test.
            let flags = rustix::io::fcntl_getfd(unsafe { BorrowedFd::borrow_raw(fd) });
            assert!(
                flags.is_ok_and(|f| f.contains(FdFlags::CLOEXEC)),
                "{fd}: {flags:?}"
            );
        }
    }

    #[test]
    fn a_regular_file_is_never_replaced() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("file");
        fs::write(&path, b"keep").expect("write");
        let err = StableLink::new(&path)
            .point_to(Path::new("/dev/pts/1"))
            .expect_err("refused");
        assert_eq!(err.kind(), io::ErrorKind::AlreadyExists);
        assert_eq!(fs::read(&path).expect("read"), b"keep");
    }
}
