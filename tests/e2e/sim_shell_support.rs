//! A test device for the simulator shell: a fixture, not a controller. It
//! answers each CR-ended line with a fixed reply after a processing delay,
//! records when each byte reached it, has a `hood` input and a `start`
//! button (pressing it sends `S<CR>` unasked).
use std::collections::VecDeque;
use std::io::{Read, Write};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use jogterm::sim::{InputControl, SimDevice};
use jogterm::wire::LineSettings;

/// `0` + 18 hex digits: the size of an isel `@0P` reply for three axes.
pub const REPLY: &[u8] = b"0000100002000FFFFFE";
pub const REQUEST: &[u8] = b"@0P\r";

pub type Arrivals = Arc<Mutex<Vec<(u8, Instant)>>>;

pub struct LineAnswerer {
    line: LineSettings,
    delay: Duration,
    reply: Vec<u8>,
    arrivals: Arrivals,
    pending: VecDeque<(Instant, Vec<u8>)>,
    ready: VecDeque<Vec<u8>>,
    hood: bool,
}

impl LineAnswerer {
    pub fn new(baud: u32, delay: Duration) -> (Self, Arrivals) {
        let arrivals = Arrivals::default();
        (
            Self {
                line: LineSettings::new(baud),
                delay,
                reply: REPLY.to_vec(),
                arrivals: arrivals.clone(),
                pending: VecDeque::new(),
                ready: VecDeque::new(),
                hood: true,
            },
            arrivals,
        )
    }

    pub fn boxed(baud: u32) -> Box<dyn SimDevice> {
        Box::new(Self::new(baud, Duration::ZERO).0)
    }
}

impl SimDevice for LineAnswerer {
    fn line(&self) -> LineSettings {
        self.line
    }

    fn on_byte(&mut self, byte: u8, now: Instant) {
        self.arrivals.lock().unwrap().push((byte, now));
        if byte == b'\r' {
            self.pending
                .push_back((now + self.delay, self.reply.clone()));
        }
    }

    fn advance(&mut self, now: Instant) {
        while self.pending.front().is_some_and(|(t, _)| *t <= now) {
            if let Some((_, m)) = self.pending.pop_front() {
                self.ready.push_back(m);
            }
        }
    }

    fn next_deadline(&self) -> Option<Instant> {
        self.pending.front().map(|(t, _)| *t)
    }

    fn poll_output(&mut self) -> Option<Vec<u8>> {
        self.ready.pop_front()
    }

    fn control(&mut self, control: &InputControl, _now: Instant) -> Result<(), String> {
        match control {
            InputControl::Set { name, level } if name == "hood" => {
                self.hood = *level;
                Ok(())
            }
            InputControl::Press { name } if name == "start" => {
                self.ready.push_back(b"S\r".to_vec());
                Ok(())
            }
            other => Err(format!(
                "unknown input `{}`: expected hood or start",
                other.name()
            )),
        }
    }

    fn input_names(&self) -> Vec<&'static str> {
        vec!["hood", "start"]
    }

    fn input_level(&self, name: &str) -> Option<bool> {
        (name == "hood").then_some(self.hood)
    }

    fn describe(&self, _now: Instant) -> String {
        format!("hood={}", u8::from(self.hood))
    }
}

pub fn byte_time(baud: u32) -> Duration {
    LineSettings::new(baud).byte_time()
}

/// Read exactly `n` bytes or fail after `timeout`.
pub fn read_exact_within(port: &mut impl Read, n: usize, timeout: Duration) -> Vec<u8> {
    let deadline = Instant::now() + timeout;
    let mut got = Vec::with_capacity(n);
    let mut buf = [0u8; 256];
    while got.len() < n {
        assert!(Instant::now() < deadline, "timed out with {got:?}");
        match port.read(&mut buf[..(n - got.len()).min(256)]) {
            Ok(0) => panic!("end of stream after {got:?}"),
            Ok(k) => got.extend_from_slice(&buf[..k]),
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::TimedOut
                        | std::io::ErrorKind::WouldBlock
                        | std::io::ErrorKind::Interrupted
                ) => {}
            Err(e) => panic!("read failed: {e}"),
        }
    }
    got
}

/// Read whatever arrives within `window`.
pub fn read_for(port: &mut impl Read, window: Duration) -> Vec<u8> {
    let deadline = Instant::now() + window;
    let mut got = Vec::new();
    let mut buf = [0u8; 256];
    while Instant::now() < deadline {
        match port.read(&mut buf) {
            Ok(0) => break,
            Ok(k) => got.extend_from_slice(&buf[..k]),
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::TimedOut
                        | std::io::ErrorKind::WouldBlock
                        | std::io::ErrorKind::Interrupted
                ) => {}
            Err(_) => break,
        }
    }
    got
}

/// One request/reply cycle; returns the reply.
pub fn cycle(port: &mut (impl Read + Write), request: &[u8], reply_len: usize) -> Vec<u8> {
    port.write_all(request).expect("write request");
    read_exact_within(port, reply_len, Duration::from_secs(2))
}

/// Wait until the shell's `show` output contains `needle` (the shell notices
/// clients coming and going on its own schedule).
pub fn wait_for_show(control: &jogterm::sim::shell::ShellControl, needle: &str) {
    let deadline = Instant::now() + Duration::from_secs(3);
    loop {
        let shown = control.show().expect("show");
        if shown.contains(needle) {
            return;
        }
        assert!(
            Instant::now() < deadline,
            "`{needle}` never showed up in:\n{shown}"
        );
        std::thread::sleep(Duration::from_millis(1));
    }
}
