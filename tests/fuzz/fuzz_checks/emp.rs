//! EMP (MSR DRS-500-ECS): the frame decoder, requests and replies decoded
//! from the frames, and the correlator that matches them.

use std::sync::OnceLock;
use std::time::{Duration, Instant};

use jogterm::proto::emp::error::MAX_REPORTED_BYTES;
use jogterm::proto::emp::{
    Correlator, FRAME_WIRE_LEN, FrameDecoder, FrameError, Incoming, Reply, Request,
};

use super::{Choices, split_independent};

/// A request of every command code, as the manual's tables write them
/// (DS 11), for the replies in the input to answer.
const MANUAL_REQUESTS: &[&str] = &[
    "0011000000000000",
    "0211110000000000",
    "0411000000000000",
    "0811000000000000",
    "0A11000000000000",
    "2011050100000064",
    "2011190000000A76",
    "2211040000000000",
    "2411000000000000",
    "2611000000140500",
    "2A11011000000064",
    "2A11000200000000",
    "2A11030000000000",
    "2C11000000000000",
    "4011010000000000",
    "4211010000000101",
    "4411080000A00000",
    "5011040000000000",
    "5411000000000000",
    "5411010000000000",
];

pub fn manual_requests() -> &'static [Request] {
    static REQUESTS: OnceLock<Vec<Request>> = OnceLock::new();
    REQUESTS.get_or_init(|| {
        let all: Vec<Request> = MANUAL_REQUESTS
            .iter()
            .filter_map(|s| s.parse().ok())
            .collect();
        assert_eq!(
            all.len(),
            MANUAL_REQUESTS.len(),
            "a manual request does not parse"
        );
        all
    })
}

/// The input is what the line delivered (to a host, or to a drive: both
/// directions use the same frames).
pub fn frames(data: &[u8]) {
    let mut choices = Choices::new(data);
    let whole = split_independent(data, &mut choices, decode);

    let incoming: Vec<Incoming> = whole
        .iter()
        .filter_map(|r| r.as_ref().ok())
        .copied()
        .collect();
    let mut requests: Vec<Request> = manual_requests().to_vec();
    for message in &incoming {
        let Incoming::Frame(frame) = message else {
            continue;
        };
        match Request::decode(frame) {
            Ok(request) => {
                // Every byte of a request means something or must be 00, so
                // a decoded request re-encodes to the very frame.
                assert_eq!(request.to_frame(), *frame, "{request}");
                let _ = (request.to_string(), request.command.may_move());
                if requests.len() < MANUAL_REQUESTS.len() + 8 {
                    requests.push(request);
                }
            }
            Err(e) => {
                let _ = e.to_string();
            }
        }
    }
    for message in &incoming {
        for request in &requests {
            match Reply::decode(message, request) {
                Ok(reply) => {
                    let again = Reply::decode(&reply.to_incoming(), request);
                    assert_eq!(again, Ok(reply), "{message} to {request}");
                    let _ = (reply.to_string(), reply.ds(), reply.info());
                }
                Err(e) => {
                    let _ = e.to_string();
                }
            }
        }
    }
    correlate(&requests, &incoming, &mut choices);
}

fn decode(pieces: &[&[u8]]) -> Vec<Result<Incoming, FrameError>> {
    let mut decoder = FrameDecoder::new();
    let mut out = Vec::new();
    let mut fed = 0;
    for piece in pieces {
        out.extend(decoder.feed(piece));
        fed += piece.len();
        assert!(decoder.pending().len() <= MAX_REPORTED_BYTES);
        assert!(out.len() <= fed, "more messages than bytes");
    }
    for result in &out {
        match result {
            Ok(message) => {
                let bytes = message.encode();
                assert_eq!(bytes.len(), FRAME_WIRE_LEN);
                let back = FrameDecoder::new().feed(&bytes);
                assert_eq!(back, [Ok(*message)], "{message} re-encodes to {bytes:?}");
            }
            Err(e) => {
                assert!(!e.bytes.is_empty() && e.bytes.len() <= MAX_REPORTED_BYTES + 1);
                let _ = e.to_string();
            }
        }
    }
    // Reset reports what was held, and holds nothing after.
    let held = decoder.pending().len();
    let report = decoder.reset();
    assert_eq!(report.is_some(), held > 0);
    assert!(decoder.pending().is_empty());
    out
}

/// The requests sent in an order the input picks, the frames arriving in
/// between; timeouts at the end.
fn correlate(requests: &[Request], incoming: &[Incoming], choices: &mut Choices) {
    let t0 = Instant::now();
    let mut correlator = Correlator::new(Duration::from_millis(50));
    let mut sent = 0usize;
    let mut now = t0;
    for message in incoming {
        if choices.one_in(2) {
            let request = requests[choices.below(requests.len() as u64) as usize];
            for e in correlator.sent(request, now) {
                let _ = e.to_string();
            }
            sent += 1;
        }
        now += Duration::from_millis(choices.below(20));
        let _ = correlator.received(*message).to_string();
        for e in correlator.poll_timeouts(now) {
            let _ = e.to_string();
        }
        assert!(correlator.outstanding().count() <= sent);
        let _ = correlator.next_deadline();
    }
    // Without replies every request that is not a running action times out.
    let _ = correlator.poll_timeouts(now + Duration::from_secs(1));
    assert!(correlator.outstanding().count() <= correlator.running().count());
    let cleared = correlator.clear();
    assert!(cleared.len() <= sent);
    assert!(correlator.is_idle());
}
