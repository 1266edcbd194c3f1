//! Where the device task (re)opens its port, and how long it waits between
//! attempts.

use std::path::PathBuf;
use std::time::Duration;

use crate::transport::{NetOptions, NetTarget, PortSpec, TransportError};
use crate::wire::LineSettings;

/// How the task gets a port, the first time and after every loss.
pub enum Connector {
    /// A serial device or pty by path: reopened by path after a loss (a
    /// vanished adapter gives `NotFound` until it is back).
    Serial { path: PathBuf, line: LineSettings },
    /// A serial port server: connected again by address after a loss (a
    /// server that is down refuses until it is back).
    Network {
        target: NetTarget,
        line: LineSettings,
        options: NetOptions,
    },
    /// One end of a socket pair: usable once; a lost in-process line cannot
    /// be reopened, so later attempts fail (and keep being retried).
    Once {
        spec: Option<PortSpec>,
        name: String,
    },
    /// Anything else that can hand out a port on demand (tests, tools).
    Factory(Box<dyn FnMut() -> Result<PortSpec, TransportError> + Send>),
}

impl std::fmt::Debug for Connector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Connector::Serial { path, line } => {
                write!(f, "Serial({}, {} baud)", path.display(), line.baud)
            }
            Connector::Network { target, line, .. } => {
                write!(f, "Network({target}, {} baud)", line.baud)
            }
            Connector::Once { name, .. } => write!(f, "Once({name})"),
            Connector::Factory(_) => f.write_str("Factory"),
        }
    }
}

impl From<PortSpec> for Connector {
    fn from(spec: PortSpec) -> Connector {
        match spec {
            PortSpec::Serial { path, line } => Connector::Serial { path, line },
            PortSpec::Network {
                target,
                line,
                options,
            } => Connector::Network {
                target,
                line,
                options,
            },
            PortSpec::InProcess { stream, line, name } => Connector::Once {
                name: name.clone(),
                spec: Some(PortSpec::InProcess { stream, line, name }),
            },
        }
    }
}

impl Connector {
    /// The next port to open.
    pub fn port(&mut self) -> Result<PortSpec, TransportError> {
        match self {
            Connector::Serial { path, line } => Ok(PortSpec::Serial {
                path: path.clone(),
                line: *line,
            }),
            Connector::Network {
                target,
                line,
                options,
            } => Ok(PortSpec::Network {
                target: target.clone(),
                line: *line,
                options: *options,
            }),
            Connector::Once { spec, name } => spec.take().ok_or_else(|| TransportError::Open {
                port: name.clone(),
                message: "an in-process line cannot be opened again".to_owned(),
            }),
            Connector::Factory(make) => make(),
        }
    }
}

/// Reconnect delays: 250 ms, doubling up to 5 s.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Backoff {
    pub first: Duration,
    pub max: Duration,
}

impl Default for Backoff {
    fn default() -> Self {
        Backoff {
            first: Duration::from_millis(250),
            max: Duration::from_secs(5),
        }
    }
}

impl Backoff {
    /// The wait before attempt `attempt` (counting from 1).
    pub fn delay(&self, attempt: u32) -> Duration {
        let doublings = attempt.saturating_sub(1).min(31);
        self.first
            .checked_mul(1u32 << doublings)
            .unwrap_or(self.max)
            .min(self.max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_backoff_doubles_from_250_ms_to_5_s() {
        let b = Backoff::default();
        let delays: Vec<u128> = (1..=8).map(|n| b.delay(n).as_millis()).collect();
        assert_eq!(delays, [250, 500, 1000, 2000, 4000, 5000, 5000, 5000]);
        assert_eq!(b.delay(u32::MAX), Duration::from_secs(5));
    }

    #[test]
    fn an_in_process_line_is_opened_once() {
        let (a, _b) = std::os::unix::net::UnixStream::pair().expect("pair");
        let mut c = Connector::from(PortSpec::InProcess {
            stream: a,
            line: LineSettings::new(19200),
            name: "sim".into(),
        });
        assert!(c.port().is_ok());
        let err = c.port().expect_err("second time");
        assert!(err.to_string().contains("cannot be opened again"), "{err}");
    }
}
