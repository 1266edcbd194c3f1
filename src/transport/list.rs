//! Listing the machine's serial ports, for `--list-ports`. serialport is built
//! without libudev, so on Linux the list comes from sysfs.

use super::error::TransportError;

/// One serial port the system knows of.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PortInfo {
    /// The device path to open, e.g. `/dev/ttyUSB0`.
    pub path: String,
    /// How it is attached, e.g. `USB 0403:6001 FTDI FT232R USB UART (serial A12345)`.
    pub description: String,
}

/// The serial ports present now, sorted by path.
pub fn list_ports() -> Result<Vec<PortInfo>, TransportError> {
    let ports = serialport::available_ports().map_err(|e| TransportError::List {
        message: e.to_string(),
    })?;
    let mut out: Vec<PortInfo> = ports
        .into_iter()
        .map(|p| PortInfo {
            description: describe(&p.port_type),
            path: p.port_name,
        })
        .collect();
    out.sort_by(|a, b| a.path.cmp(&b.path));
    Ok(out)
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
}
