//! The Telnet byte layer (RFC 854, 855), sans-IO: what an RFC 2217 serial
//! server speaks around the serial bytes. Bytes in, bytes out; no sockets.
//!
//! - Outgoing serial bytes are escaped: 0xFF is IAC and goes as IAC IAC
//!   (RFC 854, "the data byte 255"). isel's break byte 0xFF would otherwise
//!   open a Telnet command and the byte after it (a stop 0xFD is `DO`)
//!   would be eaten as one. Without the BINARY option in force (RFC 856)
//!   a CR goes as CR NUL (RFC 854, "the sequence CR NUL").
//! - Incoming bytes are split into serial data and Telnet commands by
//!   [`Decoder`], a state machine that may be fed any split of the stream.

/// Interpret As Command (RFC 854).
pub const IAC: u8 = 255;
pub const DONT: u8 = 254;
pub const DO: u8 = 253;
pub const WONT: u8 = 252;
pub const WILL: u8 = 251;
/// Subnegotiation begin.
pub const SB: u8 = 250;
/// Subnegotiation end.
pub const SE: u8 = 240;

/// Options jogterm negotiates.
pub const OPT_BINARY: u8 = 0;
pub const OPT_ECHO: u8 = 1;
pub const OPT_SGA: u8 = 3;
/// RFC 2217 COM-PORT-OPTION.
pub const OPT_COM_PORT: u8 = 44;

/// Longest subnegotiation payload kept. RFC 2217's longest is a 4-byte
/// baud rate plus a code; a server's signature text may be longer and is
/// cut (and marked) rather than grown without bound.
pub const MAX_SUBNEGOTIATION: usize = 256;

/// A negotiation verb.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Verb {
    Will,
    Wont,
    Do,
    Dont,
}

impl Verb {
    fn from_byte(b: u8) -> Option<Verb> {
        match b {
            WILL => Some(Verb::Will),
            WONT => Some(Verb::Wont),
            DO => Some(Verb::Do),
            DONT => Some(Verb::Dont),
            _ => None,
        }
    }

    pub fn byte(self) -> u8 {
        match self {
            Verb::Will => WILL,
            Verb::Wont => WONT,
            Verb::Do => DO,
            Verb::Dont => DONT,
        }
    }
}

/// A Telnet command found in the incoming stream.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Command {
    /// `IAC WILL/WONT/DO/DONT <option>`.
    Negotiation { verb: Verb, option: u8 },
    /// `IAC SB <option> <payload> IAC SE`, with IAC IAC inside the payload
    /// already undone. `truncated` when it was longer than
    /// [`MAX_SUBNEGOTIATION`].
    Subnegotiation {
        option: u8,
        payload: Vec<u8>,
        truncated: bool,
    },
    /// Any other `IAC <byte>` (NOP, GA, BRK, AYT …): nothing for a serial
    /// line, reported so that a caller may log it.
    Other(u8),
}

/// A negotiation to send: `IAC <verb> <option>`.
pub fn negotiation(verb: Verb, option: u8) -> [u8; 3] {
    [IAC, verb.byte(), option]
}

/// A subnegotiation to send: `IAC SB <option> <payload escaped> IAC SE`.
pub fn subnegotiation(option: u8, payload: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(payload.len() + 6);
    out.extend_from_slice(&[IAC, SB, option]);
    for &b in payload {
        out.push(b);
        if b == IAC {
            out.push(IAC);
        }
    }
    out.extend_from_slice(&[IAC, SE]);
    out
}

/// Serial bytes as they go into the Telnet stream: IAC doubled, and a CR
/// followed by NUL unless the server agreed to receive binary (RFC 856).
pub fn escape_into(data: &[u8], binary: bool, out: &mut Vec<u8>) {
    for &b in data {
        out.push(b);
        if b == IAC {
            out.push(IAC);
        } else if b == b'\r' && !binary {
            out.push(0);
        }
    }
}

/// [`escape_into`] a new buffer.
pub fn escape(data: &[u8], binary: bool) -> Vec<u8> {
    let mut out = Vec::with_capacity(data.len() + 2);
    escape_into(data, binary, &mut out);
    out
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    Data,
    /// A CR in non-binary mode: a NUL after it is padding (RFC 854).
    DataCr,
    Iac,
    Negotiate(Verb),
    /// After `IAC SB`: the option byte comes next.
    SbOption,
    Sb,
    SbIac,
}

/// Splits an incoming Telnet stream into serial data and commands. Feed it
/// the bytes as they come, in any pieces: a command cut between two reads is
/// completed by the next.
#[derive(Debug, Clone)]
pub struct Decoder {
    state: State,
    binary: bool,
    sb_option: u8,
    sb: Vec<u8>,
    sb_truncated: bool,
}

impl Default for Decoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Decoder {
    /// A decoder for a server that sends binary (no CR NUL to undo).
    pub fn new() -> Self {
        Self {
            state: State::Data,
            binary: true,
            sb_option: 0,
            sb: Vec::new(),
            sb_truncated: false,
        }
    }

    /// Whether the server sends binary (RFC 856 in force towards us). When
    /// not, a NUL after a CR is padding and dropped.
    pub fn set_binary(&mut self, binary: bool) {
        self.binary = binary;
        if binary && self.state == State::DataCr {
            self.state = State::Data;
        }
    }

    /// Take `input`: serial bytes are appended to `data`, each complete
    /// command to `commands`.
    pub fn feed(&mut self, input: &[u8], data: &mut Vec<u8>, commands: &mut Vec<Command>) {
        for &b in input {
            self.state = self.step(b, data, commands);
        }
    }

    fn step(&mut self, b: u8, data: &mut Vec<u8>, commands: &mut Vec<Command>) -> State {
        match self.state {
            State::Data | State::DataCr => {
                if b == IAC {
                    return State::Iac;
                }
                if self.state == State::DataCr && b == 0 {
                    return State::Data;
                }
                data.push(b);
                if b == b'\r' && !self.binary {
                    State::DataCr
                } else {
                    State::Data
                }
            }
            State::Iac => match b {
                IAC => {
                    data.push(IAC);
                    State::Data
                }
                SB => State::SbOption,
                _ => match Verb::from_byte(b) {
                    Some(verb) => State::Negotiate(verb),
                    None => {
                        commands.push(Command::Other(b));
                        State::Data
                    }
                },
            },
            State::Negotiate(verb) => {
                commands.push(Command::Negotiation { verb, option: b });
                State::Data
            }
            State::SbOption => {
                self.sb_option = b;
                self.sb.clear();
                self.sb_truncated = false;
                State::Sb
            }
            State::Sb => {
                if b == IAC {
                    State::SbIac
                } else {
                    self.sb_push(b);
                    State::Sb
                }
            }
            State::SbIac => match b {
                SE => {
                    commands.push(Command::Subnegotiation {
                        option: self.sb_option,
                        payload: std::mem::take(&mut self.sb),
                        truncated: self.sb_truncated,
                    });
                    State::Data
                }
                IAC => {
                    self.sb_push(IAC);
                    State::Sb
                }
                // RFC 855 allows nothing else here; a server that sends it
                // has ended the subnegotiation without SE. Take what came and
                // read the byte as the command it is.
                other => {
                    commands.push(Command::Subnegotiation {
                        option: self.sb_option,
                        payload: std::mem::take(&mut self.sb),
                        truncated: true,
                    });
                    self.state = State::Iac;
                    self.step(other, data, commands)
                }
            },
        }
    }

    fn sb_push(&mut self, b: u8) {
        if self.sb.len() < MAX_SUBNEGOTIATION {
            self.sb.push(b);
        } else {
            self.sb_truncated = true;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn decode_all(decoder: &mut Decoder, input: &[u8]) -> (Vec<u8>, Vec<Command>) {
        let (mut data, mut commands) = (Vec::new(), Vec::new());
        decoder.feed(input, &mut data, &mut commands);
        (data, commands)
    }

    /// What ser2net 4.3 sends on a new `telnet(rfc2217)` connection, then a
    /// NOTIFY-MODEMSTATE, then an escaped 0xFF between two data bytes.
    const SER2NET_GREETING: &[u8] = &[
        0xff, 0xfb, 0x03, 0xff, 0xfd, 0x03, 0xff, 0xfb, 0x01, 0xff, 0xfe, 0x01, 0xff, 0xfd, 0x00,
        0xff, 0xfb, 0x00, 0xff, 0xfd, 0x2c, 0xff, 0xfa, 0x2c, 0x6b, 0x00, 0xff, 0xf0, b'0', 0xff,
        0xff, b'1',
    ];

    fn greeting_commands() -> Vec<Command> {
        let n = |verb, option| Command::Negotiation { verb, option };
        vec![
            n(Verb::Will, OPT_SGA),
            n(Verb::Do, OPT_SGA),
            n(Verb::Will, OPT_ECHO),
            n(Verb::Dont, OPT_ECHO),
            n(Verb::Do, OPT_BINARY),
            n(Verb::Will, OPT_BINARY),
            n(Verb::Do, OPT_COM_PORT),
            Command::Subnegotiation {
                option: OPT_COM_PORT,
                payload: vec![107, 0],
                truncated: false,
            },
        ]
    }

    #[test]
    fn a_ser2net_greeting_decodes_into_its_commands_and_data() {
        let (data, commands) = decode_all(&mut Decoder::new(), SER2NET_GREETING);
        assert_eq!(data, b"0\xff1");
        assert_eq!(commands, greeting_commands());
    }

    #[test]
    fn split_at_every_byte_the_greeting_decodes_the_same() {
        for cut in 0..=SER2NET_GREETING.len() {
            let (a, b) = SER2NET_GREETING.split_at(cut);
            let mut d = Decoder::new();
            let (mut data, mut commands) = (Vec::new(), Vec::new());
            d.feed(a, &mut data, &mut commands);
            d.feed(b, &mut data, &mut commands);
            assert_eq!(data, b"0\xff1", "cut at {cut}");
            assert_eq!(commands, greeting_commands(), "cut at {cut}");
        }
        // And one byte at a time.
        let mut d = Decoder::new();
        let (mut data, mut commands) = (Vec::new(), Vec::new());
        for b in SER2NET_GREETING {
            d.feed(std::slice::from_ref(b), &mut data, &mut commands);
        }
        assert_eq!(data, b"0\xff1");
        assert_eq!(commands, greeting_commands());
    }

    #[test]
    fn the_isel_break_byte_goes_as_iac_iac() {
        assert_eq!(escape(&[0xFD, 0xFF], true), [0xFD, 0xFF, 0xFF]);
        assert_eq!(escape(b"@0P\r", true), b"@0P\r");
    }

    #[test]
    fn without_binary_a_cr_is_followed_by_nul_both_ways() {
        assert_eq!(escape(b"@0P\r", false), b"@0P\r\0");
        let mut d = Decoder::new();
        d.set_binary(false);
        let (data, commands) = decode_all(&mut d, b"0\r\0\r\n");
        assert_eq!(data, b"0\r\r\n");
        assert!(commands.is_empty());
        // In binary a NUL is data.
        let (data, _) = decode_all(&mut Decoder::new(), b"\r\0");
        assert_eq!(data, b"\r\0");
    }

    #[test]
    fn subnegotiations_undo_iac_iac_and_are_bounded() {
        let sb = subnegotiation(OPT_COM_PORT, &[1, 0, 0, 0xff, 0xff]);
        assert_eq!(
            sb,
            [IAC, SB, 44, 1, 0, 0, 0xff, 0xff, 0xff, 0xff, IAC, SE],
            "IAC doubled inside"
        );
        let (data, commands) = decode_all(&mut Decoder::new(), &sb);
        assert!(data.is_empty());
        assert_eq!(
            commands,
            [Command::Subnegotiation {
                option: 44,
                payload: vec![1, 0, 0, 0xff, 0xff],
                truncated: false
            }]
        );
        let long = subnegotiation(44, &vec![b'x'; MAX_SUBNEGOTIATION + 10]);
        let (_, commands) = decode_all(&mut Decoder::new(), &long);
        let [
            Command::Subnegotiation {
                payload, truncated, ..
            },
        ] = commands.as_slice()
        else {
            panic!("{commands:?}");
        };
        assert_eq!(payload.len(), MAX_SUBNEGOTIATION);
        assert!(truncated);
    }

    #[test]
    fn a_subnegotiation_without_se_ends_at_the_next_command() {
        let (data, commands) = decode_all(&mut Decoder::new(), &[IAC, SB, 44, 7, IAC, DO, 3, b'a']);
        assert_eq!(data, b"a");
        assert_eq!(
            commands,
            [
                Command::Subnegotiation {
                    option: 44,
                    payload: vec![7],
                    truncated: true
                },
                Command::Negotiation {
                    verb: Verb::Do,
                    option: 3
                }
            ]
        );
    }

    #[test]
    fn other_commands_are_reported_and_not_data() {
        // NOP, GA, AYT.
        let (data, commands) = decode_all(&mut Decoder::new(), &[b'a', IAC, 241, IAC, 249, b'b']);
        assert_eq!(data, b"ab");
        assert_eq!(commands, [Command::Other(241), Command::Other(249)]);
    }

    proptest! {
        /// Any serial bytes, escaped and cut anywhere, come back unchanged;
        /// with commands between them, the commands come back too.
        #[test]
        fn escaped_data_round_trips_at_any_split(
            data in proptest::collection::vec(any::<u8>(), 0..200),
            binary in any::<bool>(),
            cut in any::<prop::sample::Index>(),
            option in any::<u8>(),
        ) {
            let mut stream = escape(&data, binary);
            stream.extend_from_slice(&negotiation(Verb::Will, option));
            stream.extend(escape(&data, binary));
            let at = cut.index(stream.len() + 1);
            let mut d = Decoder::new();
            d.set_binary(binary);
            let (mut out, mut commands) = (Vec::new(), Vec::new());
            d.feed(&stream[..at], &mut out, &mut commands);
            d.feed(&stream[at..], &mut out, &mut commands);
            let mut twice = data.clone();
            twice.extend_from_slice(&data);
            prop_assert_eq!(out, twice);
            prop_assert_eq!(commands, vec![Command::Negotiation { verb: Verb::Will, option }]);
        }

        /// Garbage never panics and never yields more data than it had bytes.
        #[test]
        fn garbage_is_taken_without_panic(input in proptest::collection::vec(any::<u8>(), 0..300)) {
            let (data, _) = decode_all(&mut Decoder::new(), &input);
            prop_assert!(data.len() <= input.len());
        }
    }
}
