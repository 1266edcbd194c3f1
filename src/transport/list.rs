//! The machine's serial ports, for `jogterm ports`: each device with its
//! stable `/dev/serial/by-id` names, what sysfs says about the adapter
//! (USB vendor and product), and whether some process has it now.
//! serialport is built without libudev, so the list comes from sysfs.
//!
//! A by-id name (`/dev/serial/by-id/usb-FTDI_FT232R_USB_UART_A12345-if00-port0`)
//! stays the same when the adapter is plugged into another socket or the
//! machine has a second one; `/dev/ttyUSB0` does not. Profiles should name
//! ports that way (`docs/network.md`, "Local ports").

use std::fs;
use std::path::{Path, PathBuf};

use super::error::TransportError;
use super::lock;

/// One serial port the system knows of.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PortInfo {
    /// The device path, e.g. `/dev/ttyUSB0`.
    pub path: String,
    /// How it is attached, e.g. `USB 0403:6001 FTDI FT232R USB UART (serial A12345)`.
    pub description: String,
    /// The links in `/dev/serial/by-id` that point at it: the names to use.
    pub by_id: Vec<String>,
    /// Whether a process has it now.
    pub in_use: PortUse,
}

/// Whether a port is in use.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PortUse {
    Free,
    /// Held: a lock file, an `flock`, or a process with it open; who.
    Held(String),
}

impl std::fmt::Display for PortUse {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PortUse::Free => f.write_str("free"),
            PortUse::Held(who) => f.write_str(who),
        }
    }
}

/// Where the stable names live.
pub const BY_ID_DIR: &str = "/dev/serial/by-id";

/// The serial ports present now, sorted by path.
pub fn list_ports() -> Result<Vec<PortInfo>, TransportError> {
    let ports = serialport::available_ports().map_err(|e| TransportError::List {
        message: e.to_string(),
    })?;
    let links = by_id_links(Path::new(BY_ID_DIR));
    let mut out: Vec<PortInfo> = ports
        .into_iter()
        .map(|p| {
            let path = PathBuf::from(&p.port_name);
            PortInfo {
                description: describe(&p.port_type),
                by_id: names_for(&path, &links),
                in_use: port_use(&path),
                path: p.port_name,
            }
        })
        .collect();
    out.sort_by(|a, b| a.path.cmp(&b.path));
    Ok(out)
}

/// Every link in `dir` with the device it resolves to.
fn by_id_links(dir: &Path) -> Vec<(String, PathBuf)> {
    let Ok(entries) = fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut links: Vec<(String, PathBuf)> = entries
        .flatten()
        .filter_map(|e| {
            let target = fs::canonicalize(e.path()).ok()?;
            Some((e.path().display().to_string(), target))
        })
        .collect();
    links.sort();
    links
}

fn names_for(device: &Path, links: &[(String, PathBuf)]) -> Vec<String> {
    let real = fs::canonicalize(device).unwrap_or_else(|_| device.to_path_buf());
    links
        .iter()
        .filter(|(_, target)| *target == real)
        .map(|(name, _)| name.clone())
        .collect()
}

/// Who has the port: its UUCP lock file, an `flock` on it, or a process
/// with it open (as far as this user may see).
pub fn port_use(device: &Path) -> PortUse {
    let real = fs::canonicalize(device).unwrap_or_else(|_| device.to_path_buf());
    if let Some(holder) = lock::uucp_holder(&real) {
        return PortUse::Held(holder.to_string());
    }
    if let Some(holder) = lock::flock_holder(&real) {
        return PortUse::Held(holder.to_string());
    }
    match lock::openers(&real).as_slice() {
        [] => PortUse::Free,
        [(pid, name), ..] => PortUse::Held(format!(
            "open by {} (pid {pid})",
            name.as_deref().unwrap_or("a process")
        )),
    }
}

fn describe(kind: &serialport::SerialPortType) -> String {
    use serialport::SerialPortType as T;
    match kind {
        T::UsbPort(usb) => {
            let mut s = format!("USB {:04x}:{:04x}", usb.vid, usb.pid);
            for part in [&usb.manufacturer, &usb.product].into_iter().flatten() {
                s.push(' ');
                s.push_str(part);
            }
            if let Some(serial) = &usb.serial_number {
                s.push_str(&format!(" (serial {serial})"));
            }
            s
        }
        T::PciPort => "PCI".to_owned(),
        T::BluetoothPort => "Bluetooth".to_owned(),
        T::Unknown => "unknown".to_owned(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn usb_ports_are_described_with_ids_names_and_serial() {
        let usb = serialport::SerialPortType::UsbPort(serialport::UsbPortInfo {
            vid: 0x0403,
            pid: 0x6001,
            serial_number: Some("A12345".into()),
            manufacturer: Some("FTDI".into()),
            product: Some("FT232R USB UART".into()),
        });
        assert_eq!(
            describe(&usb),
            "USB 0403:6001 FTDI FT232R USB UART (serial A12345)"
        );
        assert_eq!(describe(&serialport::SerialPortType::PciPort), "PCI");
    }

    #[test]
    fn listing_does_not_fail_on_this_machine() {
        // Containers often have no serial ports at all; the list may be empty.
        let ports = list_ports().expect("sysfs listing works");
        assert!(ports.windows(2).all(|w| w[0].path <= w[1].path));
    }

    #[test]
    fn by_id_links_name_the_device_they_resolve_to() {
        let dir = tempfile::tempdir().expect("dir");
        let devices = dir.path().join("dev");
        fs::create_dir(&devices).expect("mkdir");
        let tty = devices.join("ttyUSB0");
        fs::write(&tty, b"").expect("device stand-in");
        fs::write(devices.join("ttyUSB1"), b"").expect("device stand-in");
        let by_id = dir.path().join("by-id");
        fs::create_dir(&by_id).expect("mkdir");
        let name = by_id.join("usb-FTDI_FT232R_USB_UART_A12345-if00-port0");
        std::os::unix::fs::symlink("../dev/ttyUSB0", &name).expect("link");
        std::os::unix::fs::symlink("../dev/ttyUSB1", by_id.join("usb-other")).expect("link");
        let links = by_id_links(&by_id);
        assert_eq!(names_for(&tty, &links), [name.display().to_string()]);
        // Asked by its by-id name, the same device.
        assert_eq!(names_for(&name, &links), [name.display().to_string()]);
        assert!(by_id_links(&dir.path().join("none")).is_empty());
    }

    #[test]
    fn a_file_this_process_has_open_is_in_use_by_it() {
        let file = tempfile::NamedTempFile::new().expect("file");
        let state = port_use(file.path());
        let PortUse::Held(who) = state else {
            panic!("{state:?}");
        };
        assert!(
            who.contains(&format!("pid {}", std::process::id())),
            "{who}"
        );
        let path = file.path().to_path_buf();
        drop(file);
        assert_eq!(port_use(&path), PortUse::Free);
    }
}
