//! Codec throughput of the three protocol cores: the time to encode and to
//! decode one message, on both sides of the line (the host encodes requests
//! and decodes replies; a controller, or the simulator, does the opposite),
//! with a reply decoded whole and fed one byte at a time.
//!
//! Measured by divan (warm-up, many samples, median and spread): each bench
//! counts one message's bytes, so divan prints bytes per second beside the
//! time per message. Set against the serial line itself, that rate reads as
//! the headroom: the line carries 1920 bytes/s for isel and EMCU (19200
//! baud), 3840 for EMP (38400); the first line this bench prints says so.
//!
//! Run: `cargo bench --bench codec` (optimised), `-- emp` for the benches
//! whose name contains `emp`, `-- --sample-count 20` for a shorter run,
//! `cargo test --bench codec` to run each once. Results and their reading:
//! `docs/performance.md`, "Codecs".

// A benchmark's setup that fails cannot measure anything: it stops with its
// message (Cargo.toml [lints] denies these in the crate itself).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use divan::counter::BytesCount;
use divan::{Bencher, black_box};
use jogterm::proto::{Protocol, emcu, emp, isel};

fn main() {
    let wire = |p: Protocol| p.default_line().bytes_per_second();
    println!(
        "jogterm codecs: the wire carries {:.0} bytes/s (isel), {:.0} (emcu), {:.0} (emp); \
         a codec's bytes/s divided by its family's is its headroom",
        wire(Protocol::Isel),
        wire(Protocol::Emcu),
        wire(Protocol::Emp),
    );
    divan::main();
}

mod isel_codec {
    use super::*;

    const REQUESTS: [&str; 2] = ["@0P", "@0A30,800,10,900,4,90,-4,30"];

    fn frame(line: &str) -> isel::Frame {
        isel::parse_frame(line).expect("a request").value
    }

    #[divan::bench(args = REQUESTS)]
    fn request_encode(b: Bencher, line: &str) {
        let frame = frame(line);
        b.counter(BytesCount::new(frame.encode().len()))
            .bench_local(|| black_box(&frame).encode().len());
    }

    /// The controller's side: cut the line, parse it.
    #[divan::bench(args = REQUESTS)]
    fn request_decode_framer_and_parse(b: Bencher, line: &str) {
        let bytes = frame(line).encode();
        let mut framer = isel::RequestFramer::new();
        b.counter(BytesCount::new(bytes.len())).bench_local(|| {
            framer
                .push_all(black_box(&bytes))
                .iter()
                .filter_map(|r| match r {
                    isel::Received::Line(l) => isel::parse_frame(l).ok(),
                    _ => None,
                })
                .count()
        });
    }

    fn positions() -> isel::Reply {
        isel::Reply::Positions(isel::Positions {
            x: 256,
            y: 131_087,
            z: -2,
            a: None,
        })
    }

    const EXPECT: isel::Expect = isel::Expect::Positions { with_a: false };

    #[divan::bench]
    fn reply_encode_positions(b: Bencher) {
        let reply = positions();
        let len = reply.encode().expect("positions encode").len();
        b.counter(BytesCount::new(len))
            .bench_local(|| black_box(&reply).encode().map_or(0, |b| b.len()));
    }

    #[divan::bench]
    fn reply_decode_whole_positions(b: Bencher) {
        let bytes = positions().encode().expect("positions encode");
        let mut decoder = isel::ReplyDecoder::new();
        b.counter(BytesCount::new(bytes.len())).bench_local(|| {
            let _ = decoder.expect(EXPECT);
            decoder.feed(black_box(&bytes)).len()
        });
    }

    #[divan::bench]
    fn reply_decode_byte_by_byte_positions(b: Bencher) {
        let bytes = positions().encode().expect("positions encode");
        let mut decoder = isel::ReplyDecoder::new();
        b.counter(BytesCount::new(bytes.len())).bench_local(|| {
            let _ = decoder.expect(EXPECT);
            black_box(&bytes)
                .iter()
                .map(|b| decoder.feed(&[*b]).len())
                .sum::<usize>()
        });
    }
}

mod emcu_codec {
    use super::*;

    const REQUESTS: [&str; 2] = ["@LX", "L1,X200,Y500,Z-35"];

    fn encoded(line: &str) -> (emcu::Command, Vec<u8>) {
        let command: emcu::Command = line.parse().expect("a command");
        let bytes = command.encode(emcu::Terminator::Cr).expect("encode");
        (command, bytes)
    }

    #[divan::bench(args = REQUESTS)]
    fn request_encode(b: Bencher, line: &str) {
        let (command, bytes) = encoded(line);
        b.counter(BytesCount::new(bytes.len())).bench_local(|| {
            black_box(&command)
                .encode(emcu::Terminator::Cr)
                .map_or(0, |b| b.len())
        });
    }

    #[divan::bench(args = REQUESTS)]
    fn request_decode_framer_and_parse(b: Bencher, line: &str) {
        let (_, bytes) = encoded(line);
        let mut framer = emcu::CommandFramer::new();
        b.counter(BytesCount::new(bytes.len()))
            .bench_local(|| framer.feed(black_box(&bytes)).len());
    }

    fn position() -> emcu::Reply {
        emcu::Reply::Position {
            axis: emcu::EmcuAxis::X,
            steps: -123_456,
        }
    }

    #[divan::bench]
    fn reply_encode_position(b: Bencher) {
        let reply = position();
        b.counter(BytesCount::new(reply.encode().len()))
            .bench_local(|| black_box(&reply).encode().len());
    }

    #[divan::bench]
    fn reply_decode_whole_position(b: Bencher) {
        let bytes = position().encode();
        let mut decoder = emcu::ReplyDecoder::new();
        b.counter(BytesCount::new(bytes.len()))
            .bench_local(|| decoder.feed(black_box(&bytes)).len());
    }

    #[divan::bench]
    fn reply_decode_byte_by_byte_position(b: Bencher) {
        let bytes = position().encode();
        let mut decoder = emcu::ReplyDecoder::new();
        b.counter(BytesCount::new(bytes.len())).bench_local(|| {
            black_box(&bytes)
                .iter()
                .filter_map(|b| decoder.push(*b))
                .count()
        });
    }
}

mod emp_codec {
    use super::*;

    /// `2C` read position and `2A 01` move to.
    const REQUESTS: [&str; 2] = ["2C11000000000000", "2A110110000186A0"];
    const POLL: &str = "2C11000000000000";

    fn request(text: &str) -> emp::Request {
        text.parse().expect("a request")
    }

    #[divan::bench(args = REQUESTS)]
    fn request_encode(b: Bencher, text: &str) {
        let request = request(text);
        b.counter(BytesCount::new(request.encode().len()))
            .bench_local(|| black_box(&request).encode().len());
    }

    /// The drive's side: frame, then type the request.
    #[divan::bench(args = REQUESTS)]
    fn request_decode_frame_and_request(b: Bencher, text: &str) {
        let bytes = request(text).encode();
        let mut decoder = emp::FrameDecoder::new();
        b.counter(BytesCount::new(bytes.len())).bench_local(|| {
            decoder
                .feed(black_box(&bytes))
                .iter()
                .filter_map(|r| match r {
                    Ok(emp::Incoming::Frame(f)) => emp::Request::decode(f).ok(),
                    _ => None,
                })
                .count()
        });
    }

    /// The `2D` position reply to the `2C` poll.
    fn position() -> emp::Reply {
        let frame: emp::Frame = "2D110022000186A0".parse().expect("2D");
        emp::Reply::decode(&emp::Incoming::Frame(frame), &request(POLL)).expect("2D reply")
    }

    fn typed(r: &Result<emp::Incoming, emp::FrameError>, poll: &emp::Request) -> usize {
        match r {
            Ok(incoming) => usize::from(emp::Reply::decode(incoming, poll).is_ok()),
            Err(_) => 0,
        }
    }

    #[divan::bench]
    fn reply_encode_position(b: Bencher) {
        let reply = position();
        b.counter(BytesCount::new(reply.encode().len()))
            .bench_local(|| black_box(&reply).encode().len());
    }

    #[divan::bench]
    fn reply_decode_whole_position(b: Bencher) {
        let (bytes, poll) = (position().encode(), request(POLL));
        let mut decoder = emp::FrameDecoder::new();
        b.counter(BytesCount::new(bytes.len())).bench_local(|| {
            decoder
                .feed(black_box(&bytes))
                .iter()
                .map(|r| typed(r, &poll))
                .sum::<usize>()
        });
    }

    #[divan::bench]
    fn reply_decode_byte_by_byte_position(b: Bencher) {
        let (bytes, poll) = (position().encode(), request(POLL));
        let mut decoder = emp::FrameDecoder::new();
        b.counter(BytesCount::new(bytes.len())).bench_local(|| {
            black_box(&bytes)
                .iter()
                .filter_map(|b| decoder.push(*b))
                .map(|r| typed(&r, &poll))
                .sum::<usize>()
        });
    }
}
