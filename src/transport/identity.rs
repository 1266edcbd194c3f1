//! Which device a serial port path stands for, so that a reconnect never
//! writes into a port that has become another program's or another machine's
//! (issue 37: the console reopened `/dev/pts/7` after that number had gone
//! to another program and wrote its stop bytes and `@0T0` into it; a USB
//! adapter that enumerates again as another `/dev/ttyUSB0` is the same
//! hazard).
//!
//! What identifies a device, best first:
//! - a USB adapter with a serial number: vendor, product and serial, the
//!   same wherever and however often it enumerates;
//! - a path that is a symbolic link to a device without one (a
//!   `/dev/serial/by-id` name, a simulator's `--link`): the name itself,
//!   which whoever keeps the link (udev, the simulator) points at the device
//!   it means;
//! - anything else (a pty, a built-in port, an adapter without a serial):
//!   the device node. The kernel makes a node anew for every pty it hands
//!   out and for every adapter plugged in; its device number and inode may
//!   be reused, its change time is not (`docs/device.md`, "Reconnecting").
//!   The change time has the kernel's coarse resolution (a few ms): a node
//!   made again within the same tick would pass for the same; a pty number
//!   handed on after a lost line is made long after the first.

use std::fmt;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

/// The identity of the device behind a port path.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PortIdentity {
    /// A USB adapter with a serial number.
    Usb { vid: u16, pid: u16, serial: String },
    /// A link whose target is no USB adapter with a serial number.
    Link { path: PathBuf },
    /// The device node itself.
    Node {
        node: PathBuf,
        rdev: u64,
        ino: u64,
        ctime: (i64, i64),
    },
}

impl fmt::Display for PortIdentity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PortIdentity::Usb { vid, pid, serial } => {
                write!(f, "USB adapter {vid:04x}:{pid:04x} serial {serial}")
            }
            PortIdentity::Link { path } => write!(f, "the device {} names", path.display()),
            PortIdentity::Node {
                node,
                ctime: (s, ns),
                ..
            } => write!(f, "device node {} made at {s}.{ns:09}", node.display()),
        }
    }
}

/// The identity of the device `path` names now.
pub fn identify(path: &Path) -> std::io::Result<PortIdentity> {
    let node = std::fs::canonicalize(path)?;
    if let Some(usb) = usb_identity(&node) {
        return Ok(usb);
    }
    if std::fs::symlink_metadata(path)?.file_type().is_symlink() {
        return Ok(PortIdentity::Link {
            path: path.to_path_buf(),
        });
    }
    let meta = std::fs::metadata(&node)?;
    Ok(PortIdentity::Node {
        node,
        rdev: meta.rdev(),
        ino: meta.ino(),
        ctime: (meta.ctime(), meta.ctime_nsec()),
    })
}

/// The USB adapter behind `node`, when it is one with a serial number.
fn usb_identity(node: &Path) -> Option<PortIdentity> {
    let ports = serialport::available_ports().ok()?;
    ports.into_iter().find_map(|p| {
        let same = std::fs::canonicalize(&p.port_name).is_ok_and(|n| n == node);
        match p.port_type {
            serialport::SerialPortType::UsbPort(usb) if same => {
                usb.serial_number.map(|serial| PortIdentity::Usb {
                    vid: usb.vid,
                    pid: usb.pid,
                    serial,
                })
            }
            _ => None,
        }
    })
}

/// Whether `path` still names the device it named at first (`first`):
/// `Err` says what it is now, for the operator.
pub fn still_the_same(path: &Path, first: &PortIdentity) -> Result<(), String> {
    match identify(path) {
        Ok(now) if now == *first => Ok(()),
        Ok(now) => Err(format!(
            "{} is another device now ({now}; it was {first}): nothing is written to it; \
             jogterm waits for its controller's port to come back",
            path.display()
        )),
        Err(e) => Err(format!("{}: {e}", path.display())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::fd::OwnedFd;

    /// A pty pair (`posix_openpt`, then the slave opened by the name the
    /// kernel gives it: thread-safe, unlike `TTYPort::pair`) and the path of
    /// its slave.
    fn pty() -> (OwnedFd, OwnedFd, PathBuf) {
        use rustix::fs::{Mode, OFlags};
        use rustix::pty::{OpenptFlags, grantpt, openpt, ptsname, unlockpt};
        use std::os::unix::ffi::OsStringExt;
        let master = openpt(OpenptFlags::RDWR | OpenptFlags::NOCTTY | OpenptFlags::CLOEXEC)
            .expect("posix_openpt");
        grantpt(&master).expect("grantpt");
        unlockpt(&master).expect("unlockpt");
        let name = ptsname(&master, Vec::new()).expect("ptsname");
        let path = PathBuf::from(std::ffi::OsString::from_vec(name.into_bytes()));
        let slave = rustix::fs::open(
            &path,
            OFlags::RDWR | OFlags::NOCTTY | OFlags::CLOEXEC,
            Mode::empty(),
        )
        .expect("the slave");
        (master, slave, path)
    }

    /// The kernel's pty numbers are reused; each pty's node is new.
    #[test]
    fn a_new_pty_of_the_same_number_is_another_device() {
        let mut seen: Vec<(PathBuf, PortIdentity)> = Vec::new();
        // Open and close ptys until a number comes round again (the lowest
        // free one is handed out, so at once unless other tests take it).
        for _ in 0..64 {
            let (master, slave, path) = pty();
            let id = identify(&path).expect("identify");
            assert_eq!(identify(&path).expect("again"), id, "stable while open");
            assert!(matches!(id, PortIdentity::Node { .. }), "{id}");
            if let Some((_, before)) = seen.iter().find(|(p, _)| *p == path) {
                assert_ne!(*before, id, "{}", path.display());
                let said = still_the_same(&path, before).expect_err("another device");
                assert!(said.contains("another device now"), "{said}");
                return;
            }
            seen.push((path, id));
            drop((master, slave));
            // The change time is the kernel's coarse clock (a few ms): two
            // ptys made within one tick look alike. A number that comes
            // round to another program after a lost line does so much later.
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        panic!("no pty number came round in 64 ptys: {seen:?}");
    }

    #[test]
    fn a_link_is_the_device_it_names() {
        let (_master, _slave, target) = pty();
        let dir = tempfile::tempdir().expect("tempdir");
        let link = dir.path().join("machine");
        std::os::unix::fs::symlink(&target, &link).expect("link");
        let id = identify(&link).expect("identify");
        assert_eq!(id, PortIdentity::Link { path: link.clone() });
        assert!(still_the_same(&link, &id).is_ok());
    }
}
