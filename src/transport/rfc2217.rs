//! The client side of RFC 2217 (Telnet COM Port Control Option), sans-IO:
//! the negotiation that sets the remote serial port to the controller's line
//! (baud, 8 data bits, no parity, 1 stop bit, no flow control) and the
//! PURGE-DATA request that discards what the server still holds for the
//! serial line. Bytes in, bytes out; the socket is `transport::tcp`'s.
//!
//! Sequence (RFC 2217, "Telnet Negotiation" and "Com Port Configuration"):
//! 1. jogterm offers `WILL COM-PORT-OPTION`, `WILL`/`DO BINARY` (RFC 856,
//!    so no CR NUL stuffing) and `WILL`/`DO SUPPRESS-GO-AHEAD`, and answers
//!    every other offer of the server with a refusal (never `DO ECHO`: the
//!    server would send the controller's own bytes back).
//! 2. Once the server agreed (`DO COM-PORT-OPTION`), SET-BAUDRATE,
//!    SET-DATASIZE, SET-PARITY, SET-STOPSIZE, SET-CONTROL (no flow control)
//!    and the line- and modem-state masks (0: no notifications).
//! 3. The port is ready when the server has answered the four line
//!    settings (codes + 100) with the values asked for. A server that
//!    refuses the option, or sets another value, fails the negotiation with
//!    a message that says which.

use std::collections::HashSet;

use super::telnet::{
    self, Command, OPT_BINARY, OPT_COM_PORT, OPT_SGA, Verb, negotiation, subnegotiation,
};
use crate::wire::LineSettings;

/// Client-to-server COM-PORT-OPTION codes (RFC 2217); the server answers
/// with the same code plus [`SERVER_OFFSET`].
pub const SET_BAUDRATE: u8 = 1;
pub const SET_DATASIZE: u8 = 2;
pub const SET_PARITY: u8 = 3;
pub const SET_STOPSIZE: u8 = 4;
pub const SET_CONTROL: u8 = 5;
pub const SET_LINESTATE_MASK: u8 = 10;
pub const SET_MODEMSTATE_MASK: u8 = 11;
pub const PURGE_DATA: u8 = 12;
pub const SERVER_OFFSET: u8 = 100;
pub const NOTIFY_LINESTATE: u8 = 106;
pub const NOTIFY_MODEMSTATE: u8 = 107;

/// SET-PARITY value NONE; SET-STOPSIZE value 1; SET-CONTROL value
/// "no flow control (outbound/both)".
pub const PARITY_NONE: u8 = 1;
pub const STOPSIZE_1: u8 = 1;
pub const CONTROL_NO_FLOW: u8 = 1;
/// PURGE-DATA value: "purge access server transmit data buffer", the bytes
/// the server has from us and has not yet put on the serial line.
pub const PURGE_TRANSMIT: u8 = 2;

/// `IAC SB COM-PORT-OPTION PURGE-DATA 2 IAC SE`.
pub fn purge_transmit() -> Vec<u8> {
    subnegotiation(OPT_COM_PORT, &[PURGE_DATA, PURGE_TRANSMIT])
}

/// What the server said to a COM-PORT-OPTION request (or told on its own).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ServerReport {
    Baud(u32),
    DataSize(u8),
    Parity(u8),
    StopSize(u8),
    Control(u8),
    Purged(u8),
    LineState(u8),
    ModemState(u8),
    /// Another code, or a payload of the wrong length.
    Other {
        code: u8,
        payload: Vec<u8>,
    },
}

impl ServerReport {
    /// Read a COM-PORT-OPTION subnegotiation payload from the server.
    pub fn parse(payload: &[u8]) -> ServerReport {
        let byte = |p: &[u8]| match p {
            [b] => Some(*b),
            _ => None,
        };
        let Some((&code, rest)) = payload.split_first() else {
            return ServerReport::Other {
                code: 0,
                payload: Vec::new(),
            };
        };
        let other = || ServerReport::Other {
            code,
            payload: rest.to_vec(),
        };
        let one = |make: fn(u8) -> ServerReport| byte(rest).map_or_else(other, make);
        match code.wrapping_sub(SERVER_OFFSET) {
            SET_BAUDRATE => match rest {
                [a, b, c, d] => ServerReport::Baud(u32::from_be_bytes([*a, *b, *c, *d])),
                _ => other(),
            },
            SET_DATASIZE => one(ServerReport::DataSize),
            SET_PARITY => one(ServerReport::Parity),
            SET_STOPSIZE => one(ServerReport::StopSize),
            SET_CONTROL => one(ServerReport::Control),
            PURGE_DATA => one(ServerReport::Purged),
            _ if code == NOTIFY_LINESTATE => one(ServerReport::LineState),
            _ if code == NOTIFY_MODEMSTATE => one(ServerReport::ModemState),
            _ => other(),
        }
    }
}

/// Where the negotiation stands.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Progress {
    /// Waiting for the server.
    Pending,
    /// The remote port runs the line asked for.
    Ready,
    /// The server refused or set something else: why.
    Failed(String),
}

/// One negotiation, from the first bytes to the remote port set.
#[derive(Debug)]
pub struct Negotiation {
    line: LineSettings,
    decoder: telnet::Decoder,
    out: Vec<u8>,
    /// Every `IAC <verb> <option>` sent: each is sent at most once, so two
    /// peers that disagree cannot loop (RFC 854's rule against answering an
    /// answer, kept the simple way).
    said: HashSet<(Verb, u8)>,
    com_port_agreed: bool,
    settings_sent: bool,
    baud: Option<u32>,
    data_size: Option<u8>,
    parity: Option<u8>,
    stop_size: Option<u8>,
    /// Options in force on the server's side (it agreed to our `DO`).
    theirs: HashSet<u8>,
    /// Options in force on jogterm's side (the server asked with `DO`).
    ours: HashSet<u8>,
    failed: Option<String>,
    /// Text the server sent before or instead of negotiating (a refusal
    /// such as ser2net's "Port's device already in use").
    text: Vec<u8>,
}

/// Options jogterm wants the server to enable on its side (`DO`), and
/// agrees to enable on its own (`WILL`).
const WANTED: [u8; 2] = [OPT_BINARY, OPT_SGA];

impl Negotiation {
    /// Start: the offers to send first are in [`Negotiation::take_output`].
    pub fn new(line: LineSettings) -> Self {
        let mut n = Self {
            line,
            decoder: telnet::Decoder::new(),
            out: Vec::new(),
            said: HashSet::new(),
            com_port_agreed: false,
            settings_sent: false,
            baud: None,
            data_size: None,
            parity: None,
            stop_size: None,
            theirs: HashSet::new(),
            ours: HashSet::new(),
            failed: None,
            text: Vec::new(),
        };
        n.say(Verb::Will, OPT_COM_PORT);
        for option in WANTED {
            n.say(Verb::Will, option);
            n.say(Verb::Do, option);
        }
        // Until the server agrees, it sends CR NUL.
        n.decoder.set_binary(false);
        n
    }

    /// Bytes to send to the server now.
    pub fn take_output(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.out)
    }

    /// Take bytes from the server. Serial data that arrives before the
    /// port is set is kept as text for a refusal message and otherwise
    /// dropped, as a tty's input is flushed when it is opened.
    pub fn feed(&mut self, input: &[u8]) {
        let (mut data, mut commands) = (Vec::new(), Vec::new());
        self.decoder.feed(input, &mut data, &mut commands);
        let room = 200usize.saturating_sub(self.text.len());
        self.text.extend(data.iter().take(room));
        for command in commands {
            self.command(command);
        }
    }

    pub fn progress(&self) -> Progress {
        if let Some(why) = &self.failed {
            return Progress::Failed(why.clone());
        }
        let settled = self.baud.is_some()
            && self.data_size.is_some()
            && self.parity.is_some()
            && self.stop_size.is_some();
        if settled {
            Progress::Ready
        } else {
            Progress::Pending
        }
    }

    /// What the server has not answered yet, for a timeout's message.
    pub fn waiting_for(&self) -> &'static str {
        if !self.com_port_agreed {
            "the server's answer to COM-PORT-OPTION (WILL 44)"
        } else if self.baud.is_none() {
            "the server's answer to SET-BAUDRATE"
        } else {
            "the server's answers to SET-DATASIZE, SET-PARITY, SET-STOPSIZE"
        }
    }

    /// Printable text the server sent as data, if any.
    pub fn server_text(&self) -> Option<String> {
        let text = String::from_utf8_lossy(&self.text);
        let text = text.trim();
        (!text.is_empty()).then(|| text.to_owned())
    }

    /// Whether the server sends binary (the data decoder then keeps NUL
    /// after CR) and receives binary (the encoder then adds no NUL).
    pub fn binary(&self) -> (bool, bool) {
        (
            self.theirs.contains(&OPT_BINARY),
            self.ours.contains(&OPT_BINARY),
        )
    }

    fn say(&mut self, verb: Verb, option: u8) {
        if self.said.insert((verb, option)) {
            self.out.extend_from_slice(&negotiation(verb, option));
        }
    }

    fn command(&mut self, command: Command) {
        match command {
            Command::Negotiation { verb, option } => self.negotiate(verb, option),
            Command::Subnegotiation {
                option: OPT_COM_PORT,
                payload,
                ..
            } => self.report(ServerReport::parse(&payload)),
            Command::Subnegotiation { .. } | Command::Other(_) => {}
        }
    }

    /// RFC 1143's rules, kept small: an offer of an option jogterm wants is
    /// taken, any other refused; a refusal of jogterm's own request needs
    /// no answer; an option that was on and is switched off is acknowledged.
    fn negotiate(&mut self, verb: Verb, option: u8) {
        match verb {
            Verb::Do if option == OPT_COM_PORT => {
                self.com_port_agreed = true;
                self.send_settings();
            }
            Verb::Dont if option == OPT_COM_PORT => {
                self.fail(
                    "the server refuses RFC 2217 COM-PORT-OPTION (DONT 44): it does not \
                     serve the port in rfc2217 mode"
                        .into(),
                );
            }
            Verb::Do if WANTED.contains(&option) => {
                self.ours.insert(option);
                self.say(Verb::Will, option);
            }
            Verb::Will if WANTED.contains(&option) => {
                self.theirs.insert(option);
                self.say(Verb::Do, option);
            }
            Verb::Do => self.say(Verb::Wont, option),
            Verb::Will => self.say(Verb::Dont, option),
            Verb::Dont => {
                if self.ours.remove(&option) {
                    self.say(Verb::Wont, option);
                }
            }
            Verb::Wont => {
                if self.theirs.remove(&option) {
                    self.say(Verb::Dont, option);
                }
            }
        }
        self.decoder.set_binary(self.theirs.contains(&OPT_BINARY));
    }

    fn send_settings(&mut self) {
        if self.settings_sent {
            return;
        }
        self.settings_sent = true;
        let baud = self.line.baud.to_be_bytes();
        let requests: [&[u8]; 7] = [
            &[SET_BAUDRATE, baud[0], baud[1], baud[2], baud[3]],
            // 8N1 (`wire::BITS_PER_BYTE`): every controller here.
            &[SET_DATASIZE, 8],
            &[SET_PARITY, PARITY_NONE],
            &[SET_STOPSIZE, STOPSIZE_1],
            &[SET_CONTROL, CONTROL_NO_FLOW],
            &[SET_LINESTATE_MASK, 0],
            &[SET_MODEMSTATE_MASK, 0],
        ];
        for payload in requests {
            self.out
                .extend(subnegotiation(OPT_COM_PORT, payload).iter().copied());
        }
    }

    fn report(&mut self, report: ServerReport) {
        match report {
            ServerReport::Baud(b) => {
                // A server answers 0 for "cannot tell" only to a query;
                // to a SET it answers what the port runs now.
                if b != self.line.baud {
                    self.fail(format!(
                        "the server set the serial port to {b} baud, not {} (SET-BAUDRATE)",
                        self.line.baud
                    ));
                }
                self.baud = Some(b);
            }
            ServerReport::DataSize(v) => {
                self.check("data bits (SET-DATASIZE)", 8, v, |n| &mut n.data_size)
            }
            ServerReport::Parity(v) => {
                self.check("parity (SET-PARITY; 1 = none)", PARITY_NONE, v, |n| {
                    &mut n.parity
                })
            }
            ServerReport::StopSize(v) => {
                self.check("stop bits (SET-STOPSIZE)", STOPSIZE_1, v, |n| {
                    &mut n.stop_size
                })
            }
            // Flow control, purges and state notifications do not decide
            // whether the line is right.
            _ => {}
        }
    }

    fn check(&mut self, what: &str, want: u8, got: u8, slot: fn(&mut Self) -> &mut Option<u8>) {
        if got != want {
            self.fail(format!(
                "the server set the serial port's {what} to {got}, not {want}"
            ));
        }
        *slot(self) = Some(got);
    }

    fn fail(&mut self, why: String) {
        if self.failed.is_none() {
            self.failed = Some(why);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::telnet::{DO, DONT, IAC, SB, SE, WILL, WONT};

    fn sb(payload: &[u8]) -> Vec<u8> {
        subnegotiation(OPT_COM_PORT, payload)
    }

    /// What ser2net 4.3 sends when a client connects (checked against
    /// `ser2net -c` with a `telnet(rfc2217)` accepter).
    const GREETING: &[u8] = &[
        IAC, WILL, 3, IAC, DO, 3, IAC, WILL, 1, IAC, DONT, 1, IAC, DO, 0, IAC, WILL, 0, IAC, DO, 44,
    ];

    /// ser2net's answers to the settings of a 19200 8N1 line (recorded).
    fn ser2net_answers() -> Vec<u8> {
        [
            sb(&[106, 0]),
            sb(&[107, 0]),
            sb(&[101, 0, 0, 0x4b, 0]),
            sb(&[102, 8]),
            sb(&[103, 1]),
            sb(&[104, 1]),
            sb(&[105, 1]),
        ]
        .concat()
    }

    #[test]
    fn the_first_bytes_offer_com_port_binary_and_sga() {
        let mut n = Negotiation::new(LineSettings::new(19200));
        assert_eq!(
            n.take_output(),
            [
                IAC, WILL, 44, IAC, WILL, 0, IAC, DO, 0, IAC, WILL, 3, IAC, DO, 3
            ]
        );
        assert_eq!(n.progress(), Progress::Pending);
    }

    #[test]
    fn against_ser2net_the_line_is_set_and_echo_refused() {
        let mut n = Negotiation::new(LineSettings::new(19200));
        n.take_output();
        n.feed(GREETING);
        let out = n.take_output();
        // ECHO refused; the settings follow the agreement to 44.
        let mut want = vec![IAC, DONT, 1];
        want.extend(sb(&[1, 0, 0, 0x4b, 0]));
        want.extend(sb(&[2, 8]));
        want.extend(sb(&[3, 1]));
        want.extend(sb(&[4, 1]));
        want.extend(sb(&[5, 1]));
        want.extend(sb(&[10, 0]));
        want.extend(sb(&[11, 0]));
        assert_eq!(out, want);
        assert_eq!(n.progress(), Progress::Pending);
        assert_eq!(n.binary(), (true, true));
        n.feed(&ser2net_answers());
        assert_eq!(n.progress(), Progress::Ready);
        assert!(n.take_output().is_empty(), "nothing more to say");
    }

    #[test]
    fn the_answers_split_at_every_byte_give_the_same_result() {
        let mut all = GREETING.to_vec();
        all.extend(ser2net_answers());
        for cut in 0..=all.len() {
            let mut n = Negotiation::new(LineSettings::new(19200));
            n.feed(&all[..cut]);
            n.feed(&all[cut..]);
            assert_eq!(n.progress(), Progress::Ready, "cut at {cut}");
        }
    }

    #[test]
    fn a_server_that_refuses_the_option_or_sets_another_baud_fails_with_why() {
        let mut n = Negotiation::new(LineSettings::new(19200));
        n.feed(&[IAC, DONT, 44]);
        let Progress::Failed(why) = n.progress() else {
            panic!("{:?}", n.progress());
        };
        assert!(why.contains("COM-PORT-OPTION"), "{why}");

        let mut n = Negotiation::new(LineSettings::new(38400));
        n.feed(&[IAC, DO, 44]);
        n.feed(&sb(&[101, 0, 0, 0x4b, 0]));
        let Progress::Failed(why) = n.progress() else {
            panic!("{:?}", n.progress());
        };
        assert!(why.contains("19200 baud, not 38400"), "{why}");

        let mut n = Negotiation::new(LineSettings::new(19200));
        n.feed(&[IAC, DO, 44]);
        n.feed(&sb(&[103, 3]));
        let Progress::Failed(why) = n.progress() else {
            panic!("{:?}", n.progress());
        };
        assert!(why.contains("parity"), "{why}");
    }

    #[test]
    fn a_refusal_text_is_kept_for_the_message() {
        let mut n = Negotiation::new(LineSettings::new(19200));
        let mut bytes = GREETING.to_vec();
        bytes.extend_from_slice(b"Port's device already in use\r\n");
        n.feed(&bytes);
        assert_eq!(
            n.server_text().as_deref(),
            Some("Port's device already in use")
        );
    }

    #[test]
    fn every_negotiation_is_answered_at_most_once() {
        let mut n = Negotiation::new(LineSettings::new(19200));
        n.take_output();
        for _ in 0..3 {
            n.feed(&[IAC, WILL, 1, IAC, DO, 24, IAC, WONT, 0]);
        }
        assert_eq!(
            n.take_output(),
            [IAC, DONT, 1, IAC, WONT, 24],
            "a refusal of our DO BINARY needs no answer"
        );
        assert_eq!(n.binary(), (false, false));
    }

    #[test]
    fn server_reports_parse_and_purge_is_encoded() {
        assert_eq!(
            ServerReport::parse(&[101, 0, 0, 0x96, 0]),
            ServerReport::Baud(38400)
        );
        assert_eq!(ServerReport::parse(&[112, 2]), ServerReport::Purged(2));
        assert_eq!(
            ServerReport::parse(&[107, 0x30]),
            ServerReport::ModemState(0x30)
        );
        assert_eq!(
            ServerReport::parse(&[101, 1]),
            ServerReport::Other {
                code: 101,
                payload: vec![1]
            }
        );
        assert!(matches!(
            ServerReport::parse(&[]),
            ServerReport::Other { .. }
        ));
        assert_eq!(purge_transmit(), [IAC, SB, 44, 12, 2, IAC, SE]);
    }

    proptest::proptest! {
        /// Any server bytes: no panic, and never Ready unless all four
        /// settings were answered.
        #[test]
        fn any_server_bytes_are_taken(input in proptest::collection::vec(proptest::num::u8::ANY, 0..400)) {
            let mut n = Negotiation::new(LineSettings::new(19200));
            n.feed(&input);
            let _ = n.take_output();
            if n.progress() == Progress::Ready {
                proptest::prop_assert_eq!(n.baud, Some(19200));
            }
        }
    }
}
