//! Text replies (isel manual 2.2.12, 2.2.25, 2.2.26; decision 8), read
//! back with the protocol core's decoder.

use std::time::Duration;

use super::Conv;
use crate::proto::isel::{Command, Event, Expect, Reply, ReplyCode, ReplyDecoder, TextEnd};

fn decoded(c: &mut Conv, line: &str, command: Command) -> Reply {
    c.send(line);
    c.wait(Duration::from_millis(1));
    let bytes = c.take();
    let mut decoder = ReplyDecoder::new();
    decoder
        .expect(Expect::for_command(&command, None))
        .expect("idle decoder");
    let mut events = decoder.feed(bytes.as_bytes());
    events.extend(decoder.silence());
    match events.as_slice() {
        [Event::Reply(reply)] => reply.clone(),
        other => panic!("{line}: {other:?} from {bytes:?}"),
    }
}

#[test]
fn version_and_user_info_are_lines_without_a_handshake() {
    let mut c = Conv::new();
    for line in ["@0V", "@0?"] {
        let Reply::Text { lines, end } = decoded(&mut c, line, Command::ReadVersion) else {
            panic!("text");
        };
        assert_eq!(end, TextEnd::Silence);
        assert!(lines[0].contains("iMC-S8"), "{lines:?}");
    }
    c.expect("@0IUisel_1234_aabbcc_24122012", "0");
    let reply = decoded(&mut c, "@0U", Command::ReadUserInfo);
    assert_eq!(
        reply,
        Reply::Text {
            lines: vec!["isel_1234_aabbcc_24122012".into()],
            end: TextEnd::Silence
        }
    );
    c.expect("@0IUthis user info is longer than 32 chars", "1");
}

#[test]
fn status_texts_end_with_the_handshake() {
    let mut c = Conv::new();
    c.expect("@07", "0");
    c.set("hood", false);
    let Reply::Text { lines, end } = decoded(&mut c, "@0H", Command::Status) else {
        panic!("text");
    };
    assert_eq!(end, TextEnd::Code(ReplyCode::Ok));
    let all = lines.join("\n");
    assert!(all.contains("axes XYZ"), "{all}");
    assert!(all.contains("Hood OPEN"), "{all}");
    assert!(all.contains("Program: none"), "{all}");
    c.set("limit-y2", true);
    let Reply::Text { lines, end } = decoded(&mut c, "@0h", Command::LimitSwitchStatus) else {
        panic!("text");
    };
    assert_eq!(end, TextEnd::Code(ReplyCode::Ok));
    assert_eq!(lines.len(), 4);
    assert!(lines[1].contains("switch 2 ACTIVE"), "{lines:?}");
}
