//! One owner of a machine: the locks jogterm holds while a port is open,
//! and who holds a port when jogterm cannot have it.
//!
//! - A serial device: besides the `TIOCEXCL` + `flock` the port is opened
//!   with, a UUCP lock file `LCK..<name>` with the owner's pid in
//!   `/run/lock` (`/var/lock`), the convention minicom, ser2net and
//!   lockdev keep (Filesystem Hierarchy Standard 3.0, `/var/lock`). It names
//!   the owner, and it keeps jogterm and ser2net (or minicom) on one machine
//!   from sharing a port. A lock whose process has ended is stale and
//!   removed. The name is that of the device the path resolves to, so a
//!   `/dev/serial/by-id/…` link and `/dev/ttyUSB0` are one port.
//! - A serial port server: an `flock` on `jogterm-net-<address>_<port>.lock`
//!   in the same directory (else `$XDG_RUNTIME_DIR`, else the temp
//!   directory), with the owner's pid in it; taken before connecting, so a
//!   second console never reaches a server that would let it in (or, with
//!   ser2net's `kickolduser`, throw the first one out).
//! - When a tty is busy and no lock file names the owner, `/proc/locks`
//!   does (the `flock` of the process that has it).
//!
//! Within one process a port has one lock, shared (reconnects and a second
//! handle of the same process do not lock themselves out; the `flock` on
//! the device still refuses a second open of it).

use std::collections::BTreeMap;
use std::fs::{self, File, OpenOptions};
use std::io::{self, Read, Write};
use std::net::SocketAddr;
use std::os::unix::fs::{MetadataExt, OpenOptionsExt};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, Weak};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

/// Where lock files go, in order of preference.
const LOCK_DIRS: [&str; 2] = ["/run/lock", "/var/lock"];

/// A lock jogterm holds; released when the last handle of the port drops.
#[derive(Debug)]
pub struct OwnerLock {
    path: PathBuf,
    kind: LockKind,
}

#[derive(Debug)]
enum LockKind {
    /// A UUCP lock file we created; removed on drop.
    Uucp,
    /// A file we hold an `flock` on; the lock ends when it is closed.
    Flock(File),
}

impl OwnerLock {
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for OwnerLock {
    fn drop(&mut self) {
        match &self.kind {
            LockKind::Uucp => {
                if read_pid(&self.path) == Some(std::process::id()) {
                    let _ = fs::remove_file(&self.path);
                }
            }
            // Removed while still held, and only if it is still the file we
            // locked: one that another process opened meanwhile is then a
            // file of its own, locked by it alone.
            LockKind::Flock(file) => {
                let ours = file.metadata().ok().map(|m| (m.dev(), m.ino()));
                let there = fs::metadata(&self.path).ok().map(|m| (m.dev(), m.ino()));
                if ours.is_some() && ours == there {
                    let _ = fs::remove_file(&self.path);
                }
            }
        }
        if let Ok(mut held) = HELD.lock() {
            held.retain(|_, weak| weak.strong_count() > 0);
        }
    }
}

/// Who holds a port jogterm could not have.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Holder {
    pub pid: Option<u32>,
    /// The process' name (`/proc/<pid>/comm`).
    pub name: Option<String>,
    /// Where that was read (a lock file, `/proc/locks`).
    pub source: String,
}

impl std::fmt::Display for Holder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match (&self.name, self.pid) {
            (Some(name), Some(pid)) => write!(f, "held by {name} (pid {pid}, {})", self.source),
            (None, Some(pid)) => write!(f, "held by pid {pid} ({})", self.source),
            _ => write!(f, "held by another process ({})", self.source),
        }
    }
}

/// Locks this process holds, by lock path.
static HELD: Mutex<BTreeMap<PathBuf, Weak<OwnerLock>>> = Mutex::new(BTreeMap::new());

fn held_here(path: &Path) -> Option<Arc<OwnerLock>> {
    HELD.lock()
        .ok()
        .and_then(|held| held.get(path).and_then(Weak::upgrade))
}

fn remember(lock: OwnerLock) -> Arc<OwnerLock> {
    let lock = Arc::new(lock);
    if let Ok(mut held) = HELD.lock() {
        held.insert(lock.path.clone(), Arc::downgrade(&lock));
    }
    lock
}

/// The first lock directory this user may write to.
fn lock_dir() -> Option<PathBuf> {
    LOCK_DIRS
        .iter()
        .map(PathBuf::from)
        .find(|d| writable_dir(d))
}

fn writable_dir(dir: &Path) -> bool {
    dir.is_dir() && rustix::fs::access(dir, rustix::fs::Access::WRITE_OK).is_ok()
}

/// The UUCP lock name of a device: its path under `/dev` with `/` as `_`
/// (`/dev/ttyUSB0` → `LCK..ttyUSB0`, `/dev/pts/3` → `LCK..pts_3`).
pub fn uucp_name(device: &Path) -> String {
    let rel = device.strip_prefix("/dev").unwrap_or(device);
    let rel = rel.to_string_lossy();
    let rel = rel.trim_start_matches('/');
    format!("LCK..{}", rel.replace('/', "_"))
}

/// The live owner named by a device's UUCP lock file, if there is one.
pub fn uucp_holder(real: &Path) -> Option<Holder> {
    LOCK_DIRS.iter().find_map(|dir| {
        let path = Path::new(dir).join(uucp_name(real));
        let pid = read_pid(&path).filter(|pid| holds(*pid, &path))?;
        Some(Holder {
            pid: Some(pid),
            name: process_name(pid),
            source: format!("lock file {}", path.display()),
        })
    })
}

/// Lock a serial device for this process. `Ok(None)` when no lock
/// directory is writable (the device's own `flock` still guards it).
pub fn lock_tty(device: &Path) -> Result<Option<Arc<OwnerLock>>, Holder> {
    let Some(dir) = lock_dir() else {
        return Ok(None);
    };
    let real = fs::canonicalize(device).unwrap_or_else(|_| device.to_path_buf());
    lock_tty_in(&dir, &real)
}

fn lock_tty_in(dir: &Path, real: &Path) -> Result<Option<Arc<OwnerLock>>, Holder> {
    let path = dir.join(uucp_name(real));
    if let Some(lock) = held_here(&path) {
        return Ok(Some(lock));
    }
    let me = std::process::id();
    for _ in 0..3 {
        match create_uucp(&path, me) {
            Ok(()) => {
                return Ok(Some(remember(OwnerLock {
                    path,
                    kind: LockKind::Uucp,
                })));
            }
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => {
                match read_pid(&path) {
                    Some(pid) if pid != me && holds(pid, &path) => {
                        return Err(Holder {
                            pid: Some(pid),
                            name: process_name(pid),
                            source: format!("lock file {}", path.display()),
                        });
                    }
                    // Stale (its process ended), unreadable, or ours from a
                    // handle that was dropped meanwhile: take it over.
                    _ => {
                        let _ = fs::remove_file(&path);
                    }
                }
            }
            // Cannot write the lock: go on with the device's own flock.
            Err(_) => break,
        }
    }
    Ok(None)
}

/// Write the lock atomically: a file of our own, then a hard link under
/// the lock's name, which fails if someone else has it.
fn create_uucp(path: &Path, pid: u32) -> io::Result<()> {
    let tmp = path.with_extension(format!("{pid}.tmp"));
    let _ = fs::remove_file(&tmp);
    let mut f = OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(0o644)
        .open(&tmp)?;
    // The ASCII convention: ten characters, right-aligned, newline.
    let written = f.write_all(format!("{pid:>10}\n").as_bytes());
    drop(f);
    let linked = written.and_then(|()| fs::hard_link(&tmp, path));
    let _ = fs::remove_file(&tmp);
    linked
}

fn read_pid(path: &Path) -> Option<u32> {
    let mut text = String::new();
    File::open(path).ok()?.read_to_string(&mut text).ok()?;
    text.trim().parse().ok()
}

/// Whether `pid` still holds the lock file at `path`: it runs (a zombie
/// has closed its port: a console killed by a signal leaves its lock file
/// behind, and its parent may not have reaped it yet), and it is the
/// process that wrote the file, not a later one that was given the same pid
/// (it started before the file was written). Where `/proc` cannot tell, a
/// process that exists holds it.
fn holds(pid: u32, path: &Path) -> bool {
    if !alive(pid) {
        return false;
    }
    let Some(stat) = ProcStat::read(pid) else {
        return true;
    };
    if stat.zombie {
        return false;
    }
    let written = fs::metadata(path).and_then(|m| m.modified()).ok();
    match (stat.started(), written) {
        // A second of slack: the start time has clock-tick resolution and
        // the boot time whole seconds.
        (Some(started), Some(written)) => started <= written + Duration::from_secs(1),
        _ => true,
    }
}

/// What `/proc/<pid>/stat` says of a process that a lock needs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct ProcStat {
    zombie: bool,
    /// Field 22: clock ticks after boot.
    start_ticks: u64,
}

impl ProcStat {
    fn read(pid: u32) -> Option<ProcStat> {
        ProcStat::parse(&fs::read_to_string(format!("/proc/{pid}/stat")).ok()?)
    }

    /// The name (field 2) is in parentheses and may hold spaces and `)`:
    /// the fields after it start after the last `)`.
    fn parse(line: &str) -> Option<ProcStat> {
        let rest = &line[line.rfind(')')? + 1..];
        let mut fields = rest.split_whitespace();
        let state = fields.next()?;
        // After the state (field 3), field 22 is the 19th.
        let start_ticks = fields.nth(18)?.parse().ok()?;
        Some(ProcStat {
            zombie: state == "Z" || state == "X",
            start_ticks,
        })
    }

    /// When the process started, on the wall clock.
    fn started(&self) -> Option<SystemTime> {
        let boot: u64 = fs::read_to_string("/proc/stat")
            .ok()?
            .lines()
            .find_map(|l| l.strip_prefix("btime "))?
            .trim()
            .parse()
            .ok()?;
        let hz = rustix::param::clock_ticks_per_second();
        if hz == 0 {
            return None;
        }
        let after_boot = Duration::from_millis(self.start_ticks.saturating_mul(1000) / hz);
        Some(UNIX_EPOCH + Duration::from_secs(boot) + after_boot)
    }
}

/// Whether a process exists (`kill(pid, 0)`: `EPERM` means it does, as
/// another user's).
fn alive(pid: u32) -> bool {
    let Ok(raw) = i32::try_from(pid) else {
        return false;
    };
    let Some(pid) = rustix::process::Pid::from_raw(raw) else {
        // Pid 0 in a lock file: `kill(0, 0)`, as called before rustix,
        // tested this process's own group and so said "alive". Kept, so
        // that such a lock is not removed as stale.
        return true;
    };
    match rustix::process::test_kill_process(pid) {
        Ok(()) | Err(rustix::io::Errno::PERM) => true,
        Err(_) => false,
    }
}

/// `/proc/<pid>/comm`.
pub fn process_name(pid: u32) -> Option<String> {
    fs::read_to_string(format!("/proc/{pid}/comm"))
        .ok()
        .map(|s| s.trim().to_owned())
        .filter(|s| !s.is_empty())
}

/// Lock a serial port server for this process, before connecting.
pub fn lock_network(addr: &SocketAddr) -> Result<Arc<OwnerLock>, Holder> {
    let dir = lock_dir()
        .or_else(|| std::env::var_os("XDG_RUNTIME_DIR").map(PathBuf::from))
        .unwrap_or_else(std::env::temp_dir);
    lock_network_in(&dir, addr)
}

/// The lock file's name for a server address.
pub fn network_lock_name(addr: &SocketAddr) -> String {
    let ip = addr.ip().to_string().replace(':', "-");
    format!("jogterm-net-{ip}_{}.lock", addr.port())
}

fn lock_network_in(dir: &Path, addr: &SocketAddr) -> Result<Arc<OwnerLock>, Holder> {
    let path = dir.join(network_lock_name(addr));
    if let Some(lock) = held_here(&path) {
        return Ok(lock);
    }
    let unknown = |why: String| Holder {
        pid: None,
        name: None,
        source: why,
    };
    // Another user's lock file opens read-only, which is enough to flock.
    let file = OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .mode(0o644)
        .open(&path)
        .or_else(|_| File::open(&path))
        .map_err(|e| unknown(format!("cannot open the lock {}: {e}", path.display())))?;
    if rustix::fs::flock(&file, rustix::fs::FlockOperation::NonBlockingLockExclusive).is_err() {
        let pid = read_pid(&path);
        return Err(Holder {
            pid,
            name: pid.and_then(process_name),
            source: format!("lock {}", path.display()),
        });
    }
    let _ = file.set_len(0);
    let _ = (&file).write_all(format!("{:>10}\n", std::process::id()).as_bytes());
    Ok(remember(OwnerLock {
        path,
        kind: LockKind::Flock(file),
    }))
}

/// The process that holds an `flock` on `file` (per `/proc/locks`), for a
/// busy tty without a lock file.
pub fn flock_holder(file: &Path) -> Option<Holder> {
    let meta = fs::metadata(file).ok()?;
    let locks = fs::read_to_string("/proc/locks").ok()?;
    flock_holder_in(&locks, meta.dev(), meta.ino())
}

fn flock_holder_in(locks: &str, dev: u64, ino: u64) -> Option<Holder> {
    // `1: FLOCK  ADVISORY  WRITE 3954 fe:00:5415484 0 EOF`: the device as
    // hex major:minor of the file system, then the inode (proc(5)).
    let (major, minor) = (rustix::fs::major(dev), rustix::fs::minor(dev));
    let want = format!("{major:02x}:{minor:02x}:{ino}");
    locks.lines().find_map(|line| {
        let fields: Vec<&str> = line.split_whitespace().collect();
        let at = fields.iter().position(|f| *f == "FLOCK")?;
        let pid: u32 = fields.get(at + 3)?.parse().ok()?;
        (fields.get(at + 4)? == &want.as_str()).then(|| Holder {
            pid: Some(pid),
            name: process_name(pid),
            source: "flock, /proc/locks".into(),
        })
    })
}

/// Processes that have `device` open (`/proc/*/fd`, those this user may
/// read): pid and name.
pub fn openers(device: &Path) -> Vec<(u32, Option<String>)> {
    let Ok(real) = fs::canonicalize(device) else {
        return Vec::new();
    };
    let Ok(procs) = fs::read_dir("/proc") else {
        return Vec::new();
    };
    let mut found = Vec::new();
    for entry in procs.flatten() {
        let Some(pid) = entry
            .file_name()
            .to_str()
            .and_then(|s| s.parse::<u32>().ok())
        else {
            continue;
        };
        let Ok(fds) = fs::read_dir(entry.path().join("fd")) else {
            continue;
        };
        if fds
            .flatten()
            .any(|fd| fs::read_link(fd.path()).is_ok_and(|t| t == real))
        {
            found.push((pid, process_name(pid)));
        }
    }
    found.sort();
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn proc_stat_gives_the_state_and_the_start_time() {
        let line = "4242 (jog term) x) S 1 4242 4242 0 -1 4194560 100 0 0 0 5 3 0 0 20 0 4 0 123456 1000 10";
        assert_eq!(
            ProcStat::parse(line),
            Some(ProcStat {
                zombie: false,
                start_ticks: 123456
            })
        );
        let zombie = line.replace(") S ", ") Z ");
        assert!(ProcStat::parse(&zombie).is_some_and(|s| s.zombie));
        assert_eq!(ProcStat::parse("4242 (jogterm) S 1 2"), None);
        let me = ProcStat::read(std::process::id()).expect("our own stat");
        assert!(!me.zombie);
        let started = me.started().expect("a start time");
        assert!(started <= SystemTime::now(), "{started:?}");
    }

    #[test]
    fn a_lock_of_a_zombie_or_older_than_its_pid_is_stale() {
        let dir = tempfile::tempdir().expect("dir");
        // A child that has ended and is not reaped yet: a zombie.
        let mut child = std::process::Command::new("true")
            .spawn()
            .expect("spawn true");
        let pid = child.id();
        let path = dir.path().join("LCK..ttyTEST_zombie");
        fs::write(&path, format!("{pid:>10}\n")).expect("write");
        let end = std::time::Instant::now() + Duration::from_secs(5);
        while ProcStat::read(pid).is_some_and(|s| !s.zombie) {
            assert!(std::time::Instant::now() < end, "the child never ended");
            std::thread::sleep(Duration::from_millis(5));
        }
        assert!(!holds(pid, &path), "a zombie holds no port");
        let _ = child.wait();

        // Our own pid, in a file written long before this process started:
        // the pid was given again, the writer has gone.
        let old = dir.path().join("LCK..ttyTEST_old");
        fs::write(&old, format!("{:>10}\n", std::process::id())).expect("write");
        let file = File::options().write(true).open(&old).expect("open");
        file.set_modified(UNIX_EPOCH + Duration::from_secs(1_000_000))
            .expect("set mtime");
        assert!(!holds(std::process::id(), &old));
        // Written now, by a process that runs: it holds it.
        fs::write(&old, format!("{:>10}\n", std::process::id())).expect("write");
        assert!(holds(std::process::id(), &old));
    }

    #[test]
    fn uucp_names_follow_the_convention() {
        assert_eq!(uucp_name(Path::new("/dev/ttyUSB0")), "LCK..ttyUSB0");
        assert_eq!(uucp_name(Path::new("/dev/pts/3")), "LCK..pts_3");
        assert_eq!(
            network_lock_name(&"[::1]:2000".parse().expect("addr")),
            "jogterm-net---1_2000.lock"
        );
    }

    #[test]
    fn a_live_holder_is_named_and_a_stale_lock_is_taken_over() {
        let dir = tempfile::tempdir().expect("dir");
        let device = Path::new("/dev/ttyTEST_live");
        // pid 1 is alive in every container and is never us.
        fs::write(dir.path().join("LCK..ttyTEST_live"), "         1\n").expect("write");
        let held = lock_tty_in(dir.path(), device).expect_err("held");
        assert_eq!(held.pid, Some(1));
        assert!(held.to_string().contains("pid 1"), "{held}");
        assert!(held.to_string().contains("LCK..ttyTEST_live"), "{held}");

        let stale = Path::new("/dev/ttyTEST_stale");
        // A pid above the kernel's maximum (4194304) never runs.
        fs::write(dir.path().join("LCK..ttyTEST_stale"), "   9999999\n").expect("write");
        let lock = lock_tty_in(dir.path(), stale)
            .expect("taken over")
            .expect("a lock file");
        let path = dir.path().join("LCK..ttyTEST_stale");
        assert_eq!(read_pid(&path), Some(std::process::id()));
        // Within the process the lock is shared, and removed with the last.
        let again = lock_tty_in(dir.path(), stale)
            .expect("shared")
            .expect("a lock file");
        assert!(Arc::ptr_eq(&lock, &again));
        drop(lock);
        assert!(path.exists());
        drop(again);
        assert!(!path.exists(), "removed with the last handle");
    }

    #[test]
    fn a_network_lock_is_refused_to_a_second_process_with_its_pid() {
        let dir = tempfile::tempdir().expect("dir");
        let addr: SocketAddr = "127.0.0.1:2001".parse().expect("addr");
        let path = dir.path().join(network_lock_name(&addr));
        // Another process holds it: `flock` from a child that keeps it.
        let mut child = std::process::Command::new("sh")
            // One process that takes the lock and keeps it (same pid
            // through the exec), so that killing it releases it.
            .args(["-c", "exec 9>>\"$0\" && flock -n 9 && exec sleep 30"])
            .arg(&path)
            .spawn()
            .expect("sh and flock(1) from util-linux");
        let end = std::time::Instant::now() + std::time::Duration::from_secs(10);
        loop {
            let locks = fs::read_to_string("/proc/locks").unwrap_or_default();
            let ino = fs::metadata(&path).map(|m| m.ino()).unwrap_or(0);
            if ino != 0 && locks.contains(&format!(":{ino} ")) {
                break;
            }
            assert!(std::time::Instant::now() < end, "flock never took it");
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
        let held = lock_network_in(dir.path(), &addr).expect_err("held");
        assert!(held.to_string().contains("lock"), "{held}");
        let meta = fs::metadata(&path).expect("meta");
        let by_proc = flock_holder_in(
            &fs::read_to_string("/proc/locks").expect("locks"),
            meta.dev(),
            meta.ino(),
        )
        .expect("in /proc/locks");
        // The kernel records the process that took the lock: flock(1),
        // the shell's child.
        assert!(
            by_proc.pid.is_some_and(|p| p != std::process::id()),
            "{by_proc:?}"
        );
        let _ = child.kill();
        let _ = child.wait();
        let lock = lock_network_in(dir.path(), &addr).expect("free now");
        assert_eq!(read_pid(lock.path()), Some(std::process::id()));
        drop(lock);
        assert!(!path.exists(), "no lock file left behind");
    }

    #[test]
    fn proc_locks_lines_are_matched_by_device_and_inode() {
        let locks = "1: FLOCK  ADVISORY  WRITE 3954 fe:00:5415484 0 EOF\n\
                     2: POSIX  ADVISORY  WRITE 77 00:05:12 0 EOF\n\
                     3: FLOCK  ADVISORY  WRITE 4242 00:05:12 0 EOF\n";
        let dev = rustix::fs::makedev(0, 5);
        let h = flock_holder_in(locks, dev, 12).expect("found");
        assert_eq!(h.pid, Some(4242));
        assert!(flock_holder_in(locks, dev, 13).is_none());
    }
}
