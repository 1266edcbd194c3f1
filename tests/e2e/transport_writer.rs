//! The paced writer and the emergency stop handle, over a socket pair whose
//! other end the test reads (and over a pty where a terminal is needed).

use std::io::Read;
use std::os::unix::net::UnixStream;
use std::thread;
use std::time::{Duration, Instant};

use jogterm::transport::{
    self, Interleave, Lane, MessageId, PortParts, PortSpec, TransportError, WriterConfig,
    WriterEvent, WrittenChunk,
};
use jogterm::wire::LineSettings;
use serialport::SerialPort;
use tokio::sync::mpsc::UnboundedReceiver;

const BAUD: u32 = 19200;

fn byte_time() -> Duration {
    LineSettings::new(BAUD).byte_time()
}

fn socket_port() -> (PortParts, UnixStream) {
    let (ours, theirs) = UnixStream::pair().expect("socketpair");
    let port = transport::open(PortSpec::InProcess {
        stream: ours,
        line: LineSettings::new(BAUD),
        name: "test-socket".into(),
    })
    .expect("open");
    (port.split(WriterConfig::default()).expect("split"), theirs)
}

/// Everything the peer receives, collected on a thread until `stop` bytes
/// have been seen in all or the peer end is closed.
fn collect_peer(mut peer: UnixStream, total: usize) -> thread::JoinHandle<Vec<u8>> {
    peer.set_read_timeout(Some(Duration::from_secs(5)))
        .expect("timeout");
    thread::spawn(move || {
        let mut got = Vec::new();
        let mut buf = [0u8; 512];
        while got.len() < total {
            match peer.read(&mut buf) {
                Ok(0) | Err(_) => break,
                Ok(n) => got.extend_from_slice(&buf[..n]),
            }
        }
        got
    })
}

fn next_event(events: &mut UnboundedReceiver<WriterEvent>) -> WriterEvent {
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        match events.try_recv() {
            Ok(e) => return e,
            Err(_) if Instant::now() < deadline => thread::sleep(Duration::from_micros(200)),
            Err(e) => panic!("no writer event within 5 s: {e:?}"),
        }
    }
}

/// Chunks until message `id` is done (inclusive).
fn chunks_until_done(
    events: &mut UnboundedReceiver<WriterEvent>,
    id: MessageId,
) -> Vec<WrittenChunk> {
    let mut chunks = Vec::new();
    loop {
        match next_event(events) {
            WriterEvent::Written(c) => {
                let last = c.id == id && c.done;
                chunks.push(c);
                if last {
                    return chunks;
                }
            }
            other => panic!("unexpected {other:?}"),
        }
    }
}

/// Wait until the writer has started on a message: its first chunk.
fn first_chunk(events: &mut UnboundedReceiver<WriterEvent>) -> WrittenChunk {
    match next_event(events) {
        WriterEvent::Written(c) => c,
        other => panic!("unexpected {other:?}"),
    }
}

fn long_message(n: usize) -> Vec<u8> {
    (0..n).map(|i| b'a' + (i % 26) as u8).collect()
}

#[test]
fn a_stop_overtakes_an_interruptible_message_within_the_whole_backlog() {
    let (parts, peer) = socket_port();
    let PortParts {
        writer, mut events, ..
    } = parts;
    let message = long_message(400); // 208 ms at 19200 baud
    let peer = collect_peer(peer, message.len() + 1);
    let id = writer
        .send(message.clone(), Interleave::BetweenBytes)
        .expect("send");
    let mut chunks = vec![first_chunk(&mut events)];
    thread::sleep(Duration::from_millis(10));
    let asked = Instant::now();
    let stop = writer.stop([0xFD]).expect("stop");
    chunks.extend(chunks_until_done(&mut events, id));

    let stop_at = chunks
        .iter()
        .position(|c| c.id == stop)
        .expect("stop written");
    let stop_chunk = &chunks[stop_at];
    assert_eq!(stop_chunk.lane, Lane::Stop);
    assert!(
        stop_at > 0 && stop_at < chunks.len() - 1,
        "between bytes of the message"
    );
    // No byte of the message was handed over after the stop was asked for
    // and before it: what precedes it on the wire is what the OS buffer held.
    for c in &chunks[..stop_at] {
        assert!(c.at <= stop_chunk.at);
        assert!(c.wire_end <= stop_chunk.wire_start);
    }
    let ahead = stop_chunk.wire_start.saturating_duration_since(asked);
    let handed_over = stop_chunk.at.saturating_duration_since(asked);
    println!(
        "stop handed over {:.3} ms after it was asked for, on the wire {:.3} ms after (OS backlog)",
        handed_over.as_secs_f64() * 1e3,
        ahead.as_secs_f64() * 1e3
    );
    // The writer wakes late on a loaded machine; beyond that, the stop waits
    // only for the ~1 ms of bytes already in the OS buffer.
    assert!(ahead <= handed_over + WriterConfig::default().whole_backlog + byte_time());

    assert_intact_around_the_stop(peer.join().expect("peer"), &chunks, stop_at, &message);
}

/// An upload's lines run further ahead of the wire (`send_bulk`): the
/// writer hands several bytes over per wake-up, never more than the bulk
/// backlog, and a stop still overtakes the rest within that backlog.
#[test]
fn a_bulk_message_runs_up_to_its_backlog_ahead_and_a_stop_still_overtakes_it() {
    let (parts, peer) = socket_port();
    let PortParts {
        writer, mut events, ..
    } = parts;
    let bulk = WriterConfig::default().bulk_backlog;
    let message = long_message(400);
    let peer = collect_peer(peer, message.len() + 1);
    let id = writer
        .send_bulk(message.clone(), Interleave::BetweenBytes)
        .expect("send");
    let mut chunks = vec![first_chunk(&mut events)];
    thread::sleep(Duration::from_millis(20));
    let asked = Instant::now();
    let stop = writer.stop([0xFD]).expect("stop");
    chunks.extend(chunks_until_done(&mut events, id));

    let stop_at = chunks
        .iter()
        .position(|c| c.id == stop)
        .expect("stop written");
    let stop_chunk = &chunks[stop_at];
    let largest = chunks
        .iter()
        .filter(|c| c.id == id)
        .map(|c| c.bytes.len())
        .max()
        .unwrap_or(0);
    let most = (bulk.as_nanos() / byte_time().as_nanos()) as usize;
    assert!(
        largest > 1 && largest <= most,
        "chunks of up to {most} bytes, not one per wake-up: {largest}"
    );
    for c in &chunks {
        // Handed over no further ahead of the wire than the bulk backlog.
        assert!(c.wire_end.saturating_duration_since(c.at) <= bulk + byte_time());
    }
    let ahead = stop_chunk.wire_start.saturating_duration_since(asked);
    let handed_over = stop_chunk.at.saturating_duration_since(asked);
    assert!(ahead <= handed_over + bulk + byte_time());

    assert_intact_around_the_stop(peer.join().expect("peer"), &chunks, stop_at, &message);
}

#[test]
fn a_stop_waits_for_a_whole_frame_and_goes_ahead_of_the_queue() {
    let (parts, peer) = socket_port();
    let PortParts {
        writer, mut events, ..
    } = parts;
    let frame = long_message(120); // 62 ms
    let queued = b"0211110000000000\x1a".to_vec();
    let peer = collect_peer(peer, frame.len() + 17 + 2 * queued.len());
    let first = writer
        .send(frame.clone(), Interleave::WholeMessage)
        .expect("send");
    let second = writer
        .send(queued.clone(), Interleave::WholeMessage)
        .expect("send");
    let third = writer
        .send(queued.clone(), Interleave::WholeMessage)
        .expect("send");
    let mut chunks = vec![first_chunk(&mut events)];
    let stop_frame = b"2011000000000000\x1a".to_vec();
    let stop = writer.stop(stop_frame.clone()).expect("stop");

    chunks.extend(chunks_until_done(&mut events, third));
    let order: Vec<MessageId> = chunks.iter().map(|c| c.id).collect();
    let mut dedup = order.clone();
    dedup.dedup();
    assert_eq!(dedup, vec![first, stop, second, third]);
    let frame_done = chunks
        .iter()
        .position(|c| c.id == first && c.done)
        .expect("frame done");
    assert_eq!(chunks[frame_done + 1].id, stop, "right behind the frame");

    let received = peer.join().expect("peer");
    let mut expected = frame;
    expected.extend_from_slice(&stop_frame);
    expected.extend_from_slice(&queued);
    expected.extend_from_slice(&queued);
    assert_eq!(received, expected);
}

#[test]
fn chunks_are_reported_in_order_and_add_up_to_the_stream() {
    let (parts, peer) = socket_port();
    let PortParts {
        writer, mut events, ..
    } = parts;
    let messages: Vec<Vec<u8>> = (0..5)
        .map(|i| format!("@0M{i}000,900\r").into_bytes())
        .collect();
    let total: usize = messages.iter().map(Vec::len).sum();
    let peer = collect_peer(peer, total);
    let ids: Vec<MessageId> = messages
        .iter()
        .map(|m| {
            writer
                .send(m.clone(), Interleave::BetweenBytes)
                .expect("send")
        })
        .collect();
    let started = Instant::now();
    let chunks = chunks_until_done(&mut events, ids[4]);
    let elapsed = started.elapsed();

    let mut seen_ids: Vec<MessageId> = chunks.iter().map(|c| c.id).collect();
    seen_ids.dedup();
    assert_eq!(seen_ids, ids);
    assert!(
        chunks
            .windows(2)
            .all(|w| w[0].at <= w[1].at && w[0].wire_end <= w[1].wire_start)
    );
    assert_eq!(chunks.iter().filter(|c| c.done).count(), 5);
    let stream: Vec<u8> = chunks.iter().flat_map(|c| c.bytes.clone()).collect();
    assert_eq!(stream, messages.concat());
    assert_eq!(peer.join().expect("peer"), stream);
    // Paced: the last byte was not handed over before the wire could carry
    // the ones before it (minus the ~1 ms the OS buffer may hold).
    let wire = LineSettings::new(BAUD).transfer_time(total);
    println!(
        "paced {total} bytes in {:.3} ms (wire time {:.3} ms)",
        elapsed.as_secs_f64() * 1e3,
        wire.as_secs_f64() * 1e3
    );
    assert!(
        elapsed + Duration::from_millis(2) >= wire,
        "{elapsed:?} for {wire:?} of bytes"
    );
    let first = chunks.first().map(|c| c.wire_start).expect("chunks");
    let last = chunks.last().map(|c| c.wire_end).expect("chunks");
    assert!(last - first >= wire - Duration::from_micros(1));
    assert_eq!(chunks[0].traffic().bytes, chunks[0].bytes);
}

#[test]
fn cancel_drops_the_queued_messages_and_finishes_the_one_on_the_wire() {
    let (parts, peer) = socket_port();
    let PortParts {
        writer, mut events, ..
    } = parts;
    let first = long_message(200);
    let peer = collect_peer(peer, first.len());
    let a = writer
        .send(first.clone(), Interleave::BetweenBytes)
        .expect("send");
    let b = writer
        .send(b"@0P\r".to_vec(), Interleave::BetweenBytes)
        .expect("send");
    let c = writer
        .send(b"@0P\r".to_vec(), Interleave::BetweenBytes)
        .expect("send");
    let started = first_chunk(&mut events);
    assert_eq!(started.id, a);
    writer.cancel_queued().expect("cancel");
    let mut cancelled = Vec::new();
    let mut done = started.done;
    while !(done && cancelled.len() == 2) {
        match next_event(&mut events) {
            WriterEvent::Written(chunk) => {
                assert_eq!(chunk.id, a, "nothing of a cancelled message is written");
                done |= chunk.done;
            }
            WriterEvent::Cancelled { id } => cancelled.push(id),
            other => panic!("unexpected {other:?}"),
        }
    }
    assert_eq!(cancelled, vec![b, c]);
    thread::sleep(Duration::from_millis(10));
    assert!(events.try_recv().is_err(), "nothing after the cancel");
    drop(writer);
    assert_eq!(peer.join().expect("peer"), first);
}

/// Everything the peer receives until every copy of the other end is
/// closed.
fn read_to_end(mut peer: UnixStream) -> thread::JoinHandle<Vec<u8>> {
    peer.set_read_timeout(Some(Duration::from_secs(5)))
        .expect("timeout");
    thread::spawn(move || {
        let mut got = Vec::new();
        let _ = peer.read_to_end(&mut got);
        got
    })
}

#[test]
fn a_close_completes_the_message_on_the_wire_and_drops_the_queue() {
    let (parts, peer) = socket_port();
    let PortParts {
        reader,
        writer,
        mut events,
        emergency,
    } = parts;
    drop((reader, emergency));
    let peer = read_to_end(peer);
    // 200 bytes take about 100 ms at 19200 baud: the close comes while
    // the message is partly written (one that may be cut: a frame that
    // may not goes in one write).
    let first = long_message(200);
    let a = writer
        .send(first.clone(), Interleave::BetweenBytes)
        .expect("send");
    writer
        .send(b"@X\r".to_vec(), Interleave::WholeMessage)
        .expect("send");
    let started = first_chunk(&mut events);
    assert_eq!(started.id, a);
    assert!(!started.done, "the message went out at once");
    writer.close();
    assert_eq!(peer.join().expect("peer"), first);
}

#[test]
fn a_close_right_behind_a_stop_writes_the_stop() {
    for _ in 0..20 {
        let (parts, peer) = socket_port();
        let PortParts {
            reader,
            writer,
            emergency,
            ..
        } = parts;
        drop((reader, emergency));
        let peer = read_to_end(peer);
        writer.stop(b"@B\r".to_vec()).expect("stop");
        writer.close();
        assert_eq!(peer.join().expect("peer"), b"@B\r");
    }
}

#[test]
fn a_vanished_peer_fails_the_writer_with_link_lost() {
    let (parts, peer) = socket_port();
    let PortParts {
        writer, mut events, ..
    } = parts;
    // Shut down, not only dropped: a process another test forks in the
    // meantime holds a copy of the descriptor until it execs (close-on-exec
    // closes it only then), and while it does the socket is still open and
    // takes the bytes (seen with six tests at once: `Written` came first).
    // A shut-down socket refuses them whoever holds it.
    peer.shutdown(std::net::Shutdown::Both)
        .expect("shut the peer down");
    drop(peer);
    writer
        .send(b"@0P\r".to_vec(), Interleave::BetweenBytes)
        .expect("send");
    match next_event(&mut events) {
        WriterEvent::Failed(e) => assert!(e.is_link_lost(), "{e}"),
        other => panic!("unexpected {other:?}"),
    }
    // The thread has ended: further sends say so.
    let deadline = Instant::now() + Duration::from_secs(2);
    loop {
        match writer.send(b"x".to_vec(), Interleave::BetweenBytes) {
            Err(TransportError::WriterStopped { port }) => {
                assert_eq!(port, "test-socket");
                break;
            }
            _ if Instant::now() < deadline => thread::sleep(Duration::from_millis(1)),
            other => panic!("{other:?}"),
        }
    }
}

#[test]
fn the_emergency_handle_writes_while_the_writer_is_busy_and_after_it_ended() {
    let (parts, peer) = socket_port();
    let PortParts {
        writer,
        mut events,
        emergency,
        ..
    } = parts;
    let message = long_message(300);
    let peer = collect_peer(peer, message.len() + 2);
    let id = writer
        .send(message.clone(), Interleave::BetweenBytes)
        .expect("send");
    first_chunk(&mut events);
    let from_other_thread = emergency.clone();
    thread::spawn(move || from_other_thread.write_now(&[0xFF]))
        .join()
        .expect("thread")
        .expect("write_now while busy");
    chunks_until_done(&mut events, id);
    writer.close(); // the writer thread is gone now
    emergency
        .write_now(&[0xFE])
        .expect("write_now after the writer");

    let received = peer.join().expect("peer");
    assert_eq!(received.len(), message.len() + 2);
    let ff = received
        .iter()
        .position(|&b| b == 0xFF)
        .expect("0xFF arrived");
    assert!(ff > 0 && ff < message.len(), "between bytes of the message");
    assert_eq!(received.last(), Some(&0xFE));
    let mut rest = received.clone();
    rest.retain(|&b| b != 0xFF && b != 0xFE);
    assert_eq!(rest, message);
}

#[test]
fn on_a_terminal_stops_and_emergency_writes_are_drained() {
    let (mut master, slave) = jogterm::sim::pty::pty_pair().expect("pty");
    let path = slave.name().expect("slave path");
    drop(slave);
    let port = transport::open(PortSpec::Serial {
        path: path.clone().into(),
        line: LineSettings::new(BAUD),
    })
    .expect("open the pty slave as a serial port");
    let PortParts {
        writer,
        mut events,
        emergency,
        ..
    } = port.split(WriterConfig::default()).expect("split");
    let stop = writer.stop([0xFD]).expect("stop");
    match next_event(&mut events) {
        WriterEvent::Written(c) => {
            assert_eq!(
                (c.id, c.lane, c.bytes.as_slice()),
                (stop, Lane::Stop, &[0xFD][..])
            );
        }
        other => panic!("unexpected {other:?}"),
    }
    emergency
        .write_now(&[0xFF])
        .expect("emergency write on a tty");
    master.set_timeout(Duration::from_secs(2)).expect("timeout");
    let mut got = [0u8; 2];
    master.read_exact(&mut got).expect("master reads");
    assert_eq!(got, [0xFD, 0xFF]);
}

#[test]
fn handles_can_be_shared_between_threads() {
    fn send_sync_clone<T: Send + Sync + Clone>() {}
    fn send_sync<T: Send + Sync>() {}
    send_sync_clone::<transport::EmergencyStop>();
    send_sync::<transport::PacedWriter>();
    send_sync::<transport::PortReader>();
}

#[test]
fn the_emergency_handle_gives_up_in_bounded_time_when_nothing_drains() {
    // A fast line so the bytes' own wire time does not dominate the bound.
    let (ours, _peer_never_reads) = UnixStream::pair().expect("socketpair");
    let port = transport::open(PortSpec::InProcess {
        stream: ours,
        line: LineSettings::new(4_000_000),
        name: "stuck".into(),
    })
    .expect("open");
    let parts = port.split(WriterConfig::default()).expect("split");
    let emergency = parts
        .emergency
        .with_timeout(Duration::from_millis(20))
        .expect("handle");
    let chunk = vec![0xFFu8; 4096];
    let started = Instant::now();
    let err = loop {
        let t = Instant::now();
        match emergency.write_now(&chunk) {
            Ok(()) => assert!(
                started.elapsed() < Duration::from_secs(5),
                "the buffer never filled"
            ),
            Err(e) => break (e, t.elapsed()),
        }
    };
    let bound = Duration::from_millis(20) + LineSettings::new(4_000_000).transfer_time(4096);
    assert!(
        matches!(err.0, TransportError::DrainTimeout { .. }),
        "{:?}",
        err.0
    );
    assert!(
        err.1 < bound + Duration::from_millis(500),
        "gave up after {:?}",
        err.1
    );
}

/// Issue 20, the EMCU hang-up stop: the emergency handle writes from another
/// thread while the writer has a line on its way. The bytes on the wire must
/// be whole lines and whole stops, however the two meet (seen before:
/// `@` CR `@B` CR `X` CR, a cut `@X` poll the interface took as two
/// malformed commands). Likewise EMP frames around its EOF-led stop.
#[test]
fn an_emergency_stop_never_cuts_a_line_or_frame_on_its_way() {
    // EMCU: `@LX` CR polls, the stop CR `@B` CR; every line between CRs is
    // a poll, the stop, or empty (the stop's leading CR).
    let emcu = wire_under_emergency_stops(b"@LX\r", b"\r@B\r", b'\r');
    for line in emcu.split(|&b| b == b'\r') {
        assert!(
            matches!(line, b"@LX" | b"@B" | b""),
            "a cut line {:?} in {:?}",
            String::from_utf8_lossy(line),
            String::from_utf8_lossy(&emcu)
        );
    }
    // EMP: `2C` frames ended by EOF, the stop an EOF then a stop frame.
    let frame = b"2C11000000000000\x1a";
    let stop = b"\x1a2A11030000000000\x1a";
    let emp = wire_under_emergency_stops(frame, stop, 0x1A);
    for piece in emp.split(|&b| b == 0x1A) {
        assert!(
            matches!(piece, b"2C11000000000000" | b"2A11030000000000" | b""),
            "a cut frame {:?}",
            String::from_utf8_lossy(piece)
        );
    }
}

/// `lines` copies of `line` queued as frames that must not be cut, and
/// emergency stops fired from another thread 0.2-2.5 ms apart while they
/// go out: everything the peer received.
fn wire_under_emergency_stops(line: &[u8], stop: &[u8], end: u8) -> Vec<u8> {
    const LINES: usize = 150;
    let (parts, peer) = socket_port();
    let PortParts {
        reader,
        writer,
        mut events,
        emergency,
    } = parts;
    drop(reader);
    let peer = read_to_end(peer);
    let stop_bytes = stop.to_vec();
    let mut last = None;
    for _ in 0..LINES {
        last = Some(
            writer
                .send(line.to_vec(), Interleave::WholeMessage)
                .expect("send"),
        );
    }
    first_chunk(&mut events);
    let stopper = thread::spawn(move || {
        let mut seed: u64 = 0x2545_F491_4F6C_DD1D;
        let mut fired = 0usize;
        let until = Instant::now() + LineSettings::new(BAUD).transfer_time(LINES * 4);
        while Instant::now() < until {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            thread::sleep(Duration::from_micros(200 + seed % 2300));
            emergency.write_now(&stop_bytes).expect("emergency stop");
            fired += 1;
        }
        fired
    });
    let fired = stopper.join().expect("stopper");
    assert!(fired > 20, "{fired} stops");
    chunks_until_done(&mut events, last.expect("sent"));
    writer.close();
    let got = peer.join().expect("peer");
    assert_eq!(got.len(), LINES * line.len() + fired * stop.len());
    assert_eq!(got.last(), Some(&end));
    got
}

/// Issue 18: a command on an idle line goes out in as few writes as the
/// whole backlog allows (`@0P` CR at 19200 baud: `@0P` before `send`
/// returns, from the caller's thread, then CR), not one byte per writer
/// wake-up; a frame that must not be cut goes whole at once; one sent while
/// the line is busy queues behind and follows in order (a byte at a time
/// once the backlog is full, each 1 ms before the line would idle).
#[test]
fn a_short_command_on_an_idle_line_goes_in_few_writes_the_first_before_send_returns() {
    let (parts, peer) = socket_port();
    let PortParts {
        writer, mut events, ..
    } = parts;
    let peer = collect_peer(peer, 13);
    let first = writer
        .send(b"@0P\r".to_vec(), Interleave::BetweenBytes)
        .expect("send");
    match events.try_recv() {
        Ok(WriterEvent::Written(c)) => {
            assert_eq!(
                (c.id, c.done, c.bytes.as_slice()),
                (first, false, &b"@0P"[..])
            );
            assert_eq!(c.wire_end - c.wire_start, byte_time() * 3);
        }
        other => panic!("not written at once: {other:?}"),
    }
    let rest = chunks_until_done(&mut events, first);
    assert_eq!(rest.len(), 1, "the CR in one more write: {rest:?}");
    let second = writer
        .send(b"@0b1\r".to_vec(), Interleave::BetweenBytes)
        .expect("send");
    let chunks = chunks_until_done(&mut events, second);
    assert!(chunks.iter().all(|c| c.id == second));
    // Idle again: a frame goes directly, whole.
    thread::sleep(Duration::from_millis(20));
    let third = writer
        .send(b"@LX\r".to_vec(), Interleave::WholeMessage)
        .expect("send");
    assert!(
        matches!(events.try_recv(), Ok(WriterEvent::Written(c)) if c.id == third && c.done && c.bytes == b"@LX\r"),
        "a frame on an idle line goes at once"
    );
    assert_eq!(peer.join().expect("peer"), b"@0P\r@0b1\r@LX\r");
}

/// What the peer received is the message with 0xFD where the stop overtook
/// it (after the chunks written before the stop's), nothing lost or doubled.
fn assert_intact_around_the_stop(
    received: Vec<u8>,
    chunks: &[WrittenChunk],
    stop_at: usize,
    message: &[u8],
) {
    let before: usize = chunks[..stop_at].iter().map(|c| c.bytes.len()).sum();
    let mut expected = message[..before].to_vec();
    expected.push(0xFD);
    expected.extend_from_slice(&message[before..]);
    assert_eq!(received, expected, "the message is intact around the stop");
}
