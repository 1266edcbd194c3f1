//! Property tests: whatever arrives, in whatever timing, the model never
//! panics, answers every line exactly once with a reply the core decodes, and
//! comes to rest on `@S`.

use proptest::collection::vec;
use proptest::prelude::*;

use super::harness::{Conversation, ms};
use crate::proto::emcu::{EmcuAxis, Reply, ReplyDecoder, ReplyEvent};

/// Bytes from the command alphabet, with the odd arbitrary byte.
fn byte() -> impl Strategy<Value = u8> {
    prop_oneof![
        8 => prop::sample::select(b"@RVXLBSACFJ#E$H&WxyzXYZ0123456789,-\r\x01".to_vec()),
        1 => any::<u8>(),
    ]
}

/// Well-formed command lines, each ended by CR or 0x01.
fn command_line() -> impl Strategy<Value = Vec<u8>> {
    let commands = prop::sample::select(vec![
        "@R",
        "@V",
        "@X",
        "@LX",
        "@LY",
        "@LZ",
        "@B",
        "@S",
        "@A",
        "@C",
        "@F",
        "@J",
        "#S150",
        "#S900",
        "#E1,800",
        "#E9,2000",
        "#R50",
        "#R900",
        "$HZXY",
        "$HY",
        "L1,x500,y1000",
        "L1,X-50,Z20",
        "L9,z-3000",
        "A1,1",
        "A2,0",
        "W25",
        "W700",
        "&V1",
        "&V0",
        "L1,X5,y5",
    ]);
    (commands, any::<bool>()).prop_map(|(text, run)| {
        let mut bytes = text.as_bytes().to_vec();
        bytes.push(if run { 0x01 } else { b'\r' });
        bytes
    })
}

fn terminators(bytes: &[u8]) -> usize {
    bytes.iter().filter(|b| **b == b'\r' || **b == 0x01).count()
}

/// Every line the interface sent, decoded; garbage fails the test.
fn replies(c: &Conversation) -> Result<Vec<Reply>, TestCaseError> {
    let all: Vec<u8> = c.log.iter().flat_map(|(_, m)| m.iter().copied()).collect();
    ReplyDecoder::new()
        .feed(&all)
        .into_iter()
        .map(|e| match e {
            ReplyEvent::Reply(r) => Ok(r),
            ReplyEvent::Garbage(g) => Err(TestCaseError::fail(format!("garbage: {g}"))),
        })
        .collect()
}

fn check(c: &mut Conversation, sent_lines: usize) -> Result<(), TestCaseError> {
    let answers = replies(c)?.iter().filter(|r| !r.is_unsolicited()).count();
    prop_assert_eq!(answers, sent_lines);
    // `@S` ends everything: at rest, no job, and nothing more to say.
    c.send("@S\r");
    let status = c.status();
    prop_assert!(!status.moving && !status.job_running && !status.waiting);
    let at: Vec<i32> = EmcuAxis::ALL.iter().map(|a| c.position(*a)).collect();
    prop_assert_eq!(c.wait(std::time::Duration::from_secs(60)), "");
    let later: Vec<i32> = EmcuAxis::ALL.iter().map(|a| c.position(*a)).collect();
    prop_assert_eq!(at, later);
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn any_bytes_are_answered_line_by_line(
        chunks in vec((vec(byte(), 0..24), 0u64..1500), 0..40)
    ) {
        let mut c = Conversation::new();
        let mut lines = 0;
        for (bytes, gap) in &chunks {
            lines += terminators(bytes);
            c.send_bytes(bytes);
            c.wait(ms(*gap));
        }
        // End a partial line so that it is counted too.
        lines += 1;
        c.send("\r");
        check(&mut c, lines)?;
    }

    #[test]
    fn command_streams_keep_the_model_consistent(
        stream in vec((command_line(), 0u64..3000), 0..40)
    ) {
        let mut c = Conversation::new();
        let mut lines = 0;
        for (line, gap) in &stream {
            lines += 1;
            c.send_bytes(line);
            c.wait(ms(*gap));
            let status = c.status();
            lines += 1;
            // Moving, waiting and referencing are each part of a running job.
            prop_assert!(!(status.moving && status.waiting));
            prop_assert!(!(status.referencing && status.job_running));
        }
        check(&mut c, lines)?;
    }
}
