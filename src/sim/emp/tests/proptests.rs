//! Whatever arrives, the model does not panic, does not hang its caller, and
//! answers every request frame for one of its drives exactly once, on time.

use std::time::Duration;

use proptest::prelude::*;

use super::harness::*;
use crate::proto::emp::DriveAddress;
use crate::proto::emp::{Frame, FrameDecoder, Incoming};
use crate::sim::SimDevice;
use crate::sim::emp::{DriveConfig, EmpSimConfig, PROCESSING_TIME, SLOW_ADC_PROCESSING_TIME};

#[derive(Debug, Clone)]
enum Chunk {
    /// A well-formed frame with arbitrary bytes.
    Frame([u8; 8]),
    /// Anything at all.
    Garbage(Vec<u8>),
    /// The host pauses.
    Pause(u16),
}

fn chunk() -> impl Strategy<Value = Chunk> {
    prop_oneof![
        4 => (any::<[u8; 8]>(), prop::sample::select(vec![0x11u8, 0x21, 0x31])).prop_map(
            |(mut b, ds)| {
                b[0] &= 0xFE; // every even CMD, documented or not
                b[1] = ds;
                Chunk::Frame(b)
            }
        ),
        1 => prop::collection::vec(any::<u8>(), 0..40).prop_map(Chunk::Garbage),
        1 => any::<u16>().prop_map(Chunk::Pause),
    ]
}

fn link() -> EmpSimConfig {
    EmpSimConfig {
        drives: vec![
            DriveConfig::new(DriveAddress::SINGLE),
            DriveConfig::new(DriveAddress::module(2).unwrap()).starting_at(-600_000.0),
        ],
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn any_input_is_survived_and_every_message_is_a_frame(
        chunks in prop::collection::vec(chunk(), 0..40)
    ) {
        let mut c = Conversation::new(link());
        c.switch_on();
        c.exchange("0221000000000000", "0321002200000000");
        for chunk in &chunks {
            match chunk {
                Chunk::Frame(b) => { c.send_bytes(&Frame::from_bytes(*b).encode()); }
                Chunk::Garbage(g) => { c.send_bytes(g); }
                Chunk::Pause(ms) => c.wait(Duration::from_millis(u64::from(*ms))),
            }
        }
        // Ten minutes of whatever was started, in bounded work.
        let end = c.now + Duration::from_secs(600);
        let mut steps = 0;
        while let Some(d) = c.sim.next_deadline().filter(|d| *d <= end) {
            c.sim.advance(d);
            steps += 1;
            prop_assert!(steps < 100_000, "deadlines do not progress: {}", c.sim.describe(d));
            let mut decoder = FrameDecoder::new();
            while let Some(bytes) = c.sim.poll_output() {
                let decoded = decoder.feed(&bytes);
                prop_assert_eq!(decoded.len(), 1);
                match &decoded[0] {
                    Ok(Incoming::Frame(f)) => {
                        prop_assert!(f.is_reply());
                        prop_assert!([0x11, 0x21].contains(&f.ds));
                        prop_assert!([0x22, 0x55, 0xEE].contains(&f.info));
                    }
                    Ok(Incoming::Identity(_)) => {}
                    Err(e) => prop_assert!(false, "undecodable output: {}", e),
                }
            }
        }
        let _ = c.sim.describe(end);
    }

    #[test]
    fn every_request_to_a_drive_is_answered_once_after_its_processing_time(
        bytes in any::<[u8; 8]>(),
        switched_on in any::<bool>(),
    ) {
        let mut c = Conversation::new(EmpSimConfig::single());
        if switched_on {
            c.switch_on();
        }
        let mut b = bytes;
        b[0] &= 0xFE;
        b[1] = 0x11;
        let frame = Frame::from_bytes(b);
        let eof = c.send_bytes(&frame.encode());
        let first = c.next_within(Duration::from_millis(5));
        prop_assert!(first.is_some(), "no answer to {}", frame);
        let first = first.unwrap_or_else(|| unreachable!());
        prop_assert!(
            first.at == eof + PROCESSING_TIME || first.at == eof + SLOW_ADC_PROCESSING_TIME,
            "answered after {:?}", first.at - eof
        );
        if first.text.starts_with("DRS-") {
            prop_assert_eq!(b[0], 0x00);
        } else {
            let reply: Frame = first.text.parse().map_err(|e| TestCaseError::fail(format!("{e}")))?;
            prop_assert_eq!(reply.cmd, b[0] + 1);
            prop_assert_eq!(reply.ds, 0x11);
            if !switched_on && b[0] != 0x02 && b[0] != 0x0A {
                prop_assert_eq!(reply.info, 0xEE);
            }
            // Only a long action's busy reply may be followed by more, and
            // only by its own reply code.
            if reply.info != 0x55 {
                prop_assert!(c.next_within(Duration::from_secs(1)).is_none());
            }
        }
    }
}
