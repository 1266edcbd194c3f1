//! Which reply answers a command. The interface may put an unsolicited 0x02 CR
//! on the line at any moment, also between a query and its answer (manual
//! 1.4.2: "Es folgt nicht als Quittierung für einen anderen Befehl"), so a
//! reader waiting for an answer sorts every reply into answer, unsolicited or
//! unexpected instead of taking the next line.

use super::command::{Class, Command};
use super::reply::Reply;
use super::values::EmcuAxis;

/// The reply that completes a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Expect {
    /// A bare CR (master commands that are no queries).
    Ack,
    /// A bare CR, or 0x03 CR when the command filled the data memory
    /// (buffered commands, decision 1).
    AckOrMemoryFull,
    /// `@V …`.
    Version,
    /// `@X……`.
    Status,
    /// `@L<axis>…` of this axis.
    Position(EmcuAxis),
}

/// How a reply relates to the command a reader is waiting on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Disposition {
    /// The answer: the command is complete.
    Answer,
    /// 0x02 CR, sent on its own (buffer or job finished, or room again); the
    /// command still waits for its answer.
    Unsolicited,
    /// Neither: the line does not belong to this command (a lost or
    /// out-of-step answer). The reader should resynchronise, e.g. by `@X`.
    Unexpected,
}

impl Expect {
    pub fn classify(self, reply: &Reply) -> Disposition {
        let answers = match (self, reply) {
            (_, Reply::Ready) => return Disposition::Unsolicited,
            (Expect::Ack | Expect::AckOrMemoryFull, Reply::Ack) => true,
            (Expect::AckOrMemoryFull, Reply::MemoryFull) => true,
            (Expect::Version, Reply::Version(_)) => true,
            (Expect::Status, Reply::Status(_)) => true,
            (Expect::Position(want), Reply::Position { axis, .. }) => want == *axis,
            _ => false,
        };
        if answers {
            Disposition::Answer
        } else {
            Disposition::Unexpected
        }
    }
}

impl Command {
    /// The reply that completes this command (manual 1.4.2, 1.5.2-1.5.4).
    pub fn expect(&self) -> Expect {
        match self {
            Command::Version => Expect::Version,
            Command::Status => Expect::Status,
            Command::Position(axis) => Expect::Position(*axis),
            other if other.class() == Class::Buffered => Expect::AckOrMemoryFull,
            _ => Expect::Ack,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::emcu::status::Status;

    #[test]
    fn ready_is_never_an_answer() {
        for expect in [
            Expect::Ack,
            Expect::AckOrMemoryFull,
            Expect::Version,
            Expect::Status,
            Expect::Position(EmcuAxis::X),
        ] {
            assert_eq!(expect.classify(&Reply::Ready), Disposition::Unsolicited);
        }
    }

    #[test]
    fn answers_match_their_command() {
        let status = Reply::Status(Status::default());
        assert_eq!(
            Command::Status.expect().classify(&status),
            Disposition::Answer
        );
        assert_eq!(
            Command::Status.expect().classify(&Reply::Ack),
            Disposition::Unexpected
        );
        let y = Reply::Position {
            axis: EmcuAxis::Y,
            steps: -1234,
        };
        assert_eq!(
            Command::Position(EmcuAxis::Y).expect().classify(&y),
            Disposition::Answer
        );
        assert_eq!(
            Command::Position(EmcuAxis::X).expect().classify(&y),
            Disposition::Unexpected
        );
        // 0x03 CR acknowledges only a command that went into the memory.
        assert_eq!(
            Command::Halt.expect().classify(&Reply::MemoryFull),
            Disposition::Unexpected
        );
        let wait: Command = "W250".parse().unwrap();
        assert_eq!(
            wait.expect().classify(&Reply::MemoryFull),
            Disposition::Answer
        );
        assert_eq!(wait.expect().classify(&Reply::Ack), Disposition::Answer);
    }
}
