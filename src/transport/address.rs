//! Where a controller is, as `--port` and a profile's `connection.port` say
//! it: a device path, or a serial port server on the network.
//!
//! - `/dev/ttyUSB0`, `/dev/serial/by-id/usb-FTDI_…`: a local serial device
//!   (anything without a `scheme://`);
//! - `tcp://HOST:PORT`: raw TCP, the serial bytes as they are (ser2net's
//!   `accepter: tcp,PORT`, a commercial box's "raw" or "TCP server" mode);
//! - `rfc2217://HOST:PORT`: Telnet with RFC 2217 COM-PORT-OPTION, which also
//!   sets the remote port's baud rate (ser2net's `telnet(rfc2217)`).
//!
//! HOST is a name, an IPv4 address or an IPv6 address in brackets
//! (`tcp://[fe80::1]:2000`).

use std::fmt;
use std::path::PathBuf;

/// How the serial bytes travel over TCP.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum NetMode {
    /// The bytes as they are.
    Raw,
    /// Telnet with RFC 2217 COM-PORT-OPTION.
    Rfc2217,
}

impl NetMode {
    pub fn scheme(self) -> &'static str {
        match self {
            NetMode::Raw => "tcp",
            NetMode::Rfc2217 => "rfc2217",
        }
    }
}

/// A serial port server: host, TCP port and how it speaks.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct NetTarget {
    pub mode: NetMode,
    /// As given, without brackets around an IPv6 address.
    pub host: String,
    pub port: u16,
}

impl NetTarget {
    /// `host:port` as `ToSocketAddrs` takes it (IPv6 in brackets).
    pub fn host_port(&self) -> String {
        if self.host.contains(':') {
            format!("[{}]:{}", self.host, self.port)
        } else {
            format!("{}:{}", self.host, self.port)
        }
    }
}

impl fmt::Display for NetTarget {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}://{}", self.mode.scheme(), self.host_port())
    }
}

/// A parsed port address.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PortAddress {
    Device(PathBuf),
    Network(NetTarget),
}

/// Why an address is not one.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("port `{given}`: {problem}")]
pub struct AddressError {
    pub given: String,
    pub problem: String,
}

impl PortAddress {
    /// Read an address. Anything without `://` is a device path.
    pub fn parse(given: &str) -> Result<PortAddress, AddressError> {
        let fail = |problem: &str| AddressError {
            given: given.to_owned(),
            problem: problem.to_owned(),
        };
        let Some((scheme, rest)) = given.split_once("://") else {
            if given.is_empty() {
                return Err(fail("empty: expected a device path or tcp://HOST:PORT"));
            }
            return Ok(PortAddress::Device(PathBuf::from(given)));
        };
        let mode = match scheme.to_ascii_lowercase().as_str() {
            "tcp" | "socket" => NetMode::Raw,
            "rfc2217" => NetMode::Rfc2217,
            _ => {
                return Err(fail(
                    "unknown scheme: expected tcp://HOST:PORT (raw) or rfc2217://HOST:PORT",
                ));
            }
        };
        let rest = rest.strip_suffix('/').unwrap_or(rest);
        let (host, port) = if let Some(inner) = rest.strip_prefix('[') {
            let (host, after) = inner
                .split_once(']')
                .ok_or_else(|| fail("an IPv6 address needs its closing `]`"))?;
            let port = after
                .strip_prefix(':')
                .ok_or_else(|| fail("expected `:PORT` after the host"))?;
            (host, port)
        } else {
            rest.rsplit_once(':')
                .ok_or_else(|| fail("expected HOST:PORT (the TCP port is required)"))?
        };
        if host.is_empty() {
            return Err(fail("the host is missing"));
        }
        if host.contains(['/', '?', '#', '@']) {
            return Err(fail(
                "expected HOST:PORT only (no path, user or query after the scheme)",
            ));
        }
        if host.contains(':') && !rest.starts_with('[') {
            return Err(fail("write an IPv6 address in brackets: [ADDR]:PORT"));
        }
        let port: u16 = port
            .parse()
            .ok()
            .filter(|p| *p != 0)
            .ok_or_else(|| fail("the TCP port must be a number from 1 to 65535"))?;
        Ok(PortAddress::Network(NetTarget {
            mode,
            host: host.to_owned(),
            port,
        }))
    }
}

impl fmt::Display for PortAddress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PortAddress::Device(p) => write!(f, "{}", p.display()),
            PortAddress::Network(t) => t.fmt(f),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn net(mode: NetMode, host: &str, port: u16) -> PortAddress {
        PortAddress::Network(NetTarget {
            mode,
            host: host.into(),
            port,
        })
    }

    #[test]
    fn addresses_parse() {
        let table = [
            (
                "/dev/ttyUSB0",
                PortAddress::Device(PathBuf::from("/dev/ttyUSB0")),
            ),
            (
                "/dev/serial/by-id/usb-FTDI_FT232R_USB_UART_A12345-if00-port0",
                PortAddress::Device(PathBuf::from(
                    "/dev/serial/by-id/usb-FTDI_FT232R_USB_UART_A12345-if00-port0",
                )),
            ),
            ("tcp://pi.local:2000", net(NetMode::Raw, "pi.local", 2000)),
            ("TCP://10.0.0.7:4001/", net(NetMode::Raw, "10.0.0.7", 4001)),
            (
                "rfc2217://192.168.1.20:2001",
                net(NetMode::Rfc2217, "192.168.1.20", 2001),
            ),
            ("tcp://[::1]:2000", net(NetMode::Raw, "::1", 2000)),
        ];
        for (given, want) in table {
            let got = PortAddress::parse(given).expect(given);
            assert_eq!(got, want, "{given}");
        }
        assert_eq!(
            PortAddress::parse("tcp://[::1]:2000")
                .expect("v6")
                .to_string(),
            "tcp://[::1]:2000"
        );
        assert_eq!(
            PortAddress::parse("rfc2217://h:1").expect("ok").to_string(),
            "rfc2217://h:1"
        );
    }

    #[test]
    fn bad_addresses_say_what_is_wrong() {
        let table = [
            ("", "empty"),
            ("tcp://host", "TCP port is required"),
            ("tcp://host:0", "1 to 65535"),
            ("tcp://host:70000", "1 to 65535"),
            ("tcp://host:x", "1 to 65535"),
            ("tcp://:2000", "host is missing"),
            ("telnet://host:23", "unknown scheme"),
            ("tcp://[::1:2000", "closing `]`"),
            ("tcp://::1:2000", "brackets"),
            ("tcp://user@host:2000", "HOST:PORT only"),
        ];
        for (given, want) in table {
            let err = PortAddress::parse(given).expect_err(given);
            assert!(err.to_string().contains(want), "{given}: {err}");
            assert!(err.to_string().contains(&format!("`{given}`")), "{err}");
        }
    }
}
