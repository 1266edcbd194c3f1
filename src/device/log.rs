//! The traffic log (`--log FILE`): one line per traffic record, with its
//! UTC time, its direction and its bytes in `traffic::readable` form, plus
//! `#` lines for link changes, faults, input changes (decoded by the input
//! recorder, `device::inputs`) and events dropped for a slow log.
//!
//! ```text
//! 2026-11-21T22:34:01.123456Z >> @0P<CR>
//! 2026-11-21T22:34:01.135012Z << 0000100020000FFFFFE
//! 2026-11-21T22:34:02.000001Z # link lost: no reply to @0P within 111 ms
//! 2026-11-21T22:34:03.000002Z # input limit X1 (in3.0) 1 hit, t 2.017 s, within 16.7 ms
//! ```

use std::io::{self, Write};
use std::time::{SystemTime, UNIX_EPOCH};

use tokio::task::JoinHandle;

use super::api::{Event, LinkState};
use super::events::EventReceiver;
use crate::traffic::TrafficRecord;

/// `2026-11-21T22:34:01.123456Z`.
pub fn utc_timestamp(at: SystemTime) -> String {
    let since = at.duration_since(UNIX_EPOCH).unwrap_or_default();
    let secs = since.as_secs();
    let (days, rest) = (secs / 86_400, secs % 86_400);
    let (h, m, s) = (rest / 3600, rest % 3600 / 60, rest % 60);
    let (y, mo, d) = civil_from_days(days as i64);
    format!(
        "{y:04}-{mo:02}-{d:02}T{h:02}:{m:02}:{s:02}.{:06}Z",
        since.subsec_micros()
    )
}

/// Days since 1970-01-01 to a proleptic Gregorian date (H. Hinnant's
/// `civil_from_days`).
fn civil_from_days(days: i64) -> (i64, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let y = yoe + era * 400 + i64::from(m <= 2);
    (y, m, d)
}

pub fn traffic_line(record: &TrafficRecord) -> String {
    format!("{} {}", utc_timestamp(record.at), record.readable())
}

/// The log line for an event, if it has one.
pub fn log_line(event: &Event) -> Option<String> {
    let now = || utc_timestamp(SystemTime::now());
    match event {
        Event::Traffic(r) => Some(traffic_line(r)),
        Event::Link(state) => Some(format!(
            "{} # link {}",
            now(),
            match state {
                LinkState::Connecting => "connecting".to_owned(),
                LinkState::Connected => "connected".to_owned(),
                LinkState::Lost { reason } => format!("lost: {reason}"),
                LinkState::Reconnecting { attempt, retry_in } => format!(
                    "reconnecting (attempt {attempt}) in {} ms",
                    retry_in.as_millis()
                ),
                LinkState::Closed => "closed".to_owned(),
            }
        )),
        Event::Input(change) => Some(format!(
            "{} # input {}",
            now(),
            super::inputs::describe(change)
        )),
        Event::Fault(f) => Some(format!(
            "{} # fault: {} answered {}: {}",
            now(),
            f.command,
            f.code,
            f.meaning
        )),
        _ => None,
    }
}

/// Write the log until the device task ends. Each line goes out with one
/// `write_all`, so lines from other writers appending to the same file
/// (the tracing log) do not cut into it.
pub async fn write_log(mut events: EventReceiver, mut out: impl Write) -> io::Result<()> {
    let mut dropped = 0;
    while let Some(event) = events.recv().await {
        let now_dropped = events.dropped();
        if now_dropped > dropped {
            let line = format!(
                "{} # {} traffic records were dropped: the log fell behind\n",
                utc_timestamp(SystemTime::now()),
                now_dropped - dropped
            );
            out.write_all(line.as_bytes())?;
            dropped = now_dropped;
        }
        if let Some(line) = log_line(&event) {
            out.write_all(format!("{line}\n").as_bytes())?;
            out.flush()?;
        }
    }
    out.flush()
}

/// Run [`write_log`] as a task.
pub fn spawn_log(
    events: EventReceiver,
    out: impl Write + Send + 'static,
) -> JoinHandle<io::Result<()>> {
    tokio::spawn(write_log(events, out))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::events::EventBus;
    use crate::traffic::Direction;
    use std::time::Duration;

    #[test]
    fn timestamps_are_utc_with_microseconds() {
        let t = UNIX_EPOCH + Duration::from_micros(1_795_300_441_123_456);
        assert_eq!(utc_timestamp(t), "2026-11-21T22:34:01.123456Z");
        assert_eq!(utc_timestamp(UNIX_EPOCH), "1970-01-01T00:00:00.000000Z");
        let leap = UNIX_EPOCH + Duration::from_secs(951_782_400);
        assert_eq!(utc_timestamp(leap), "2000-02-29T00:00:00.000000Z");
    }

    #[tokio::test]
    async fn traffic_and_link_changes_become_lines() {
        let bus = EventBus::new(16);
        let rx = bus.subscribe();
        let at = UNIX_EPOCH + Duration::from_secs(1_795_300_441);
        bus.publish(Event::Traffic(TrafficRecord {
            at,
            direction: Direction::Sent,
            bytes: b"@0P\r".to_vec(),
            messages: Vec::new(),
        }));
        bus.publish(Event::Traffic(TrafficRecord {
            at,
            direction: Direction::Received,
            bytes: vec![b'F', 0xFD],
            messages: Vec::new(),
        }));
        bus.publish(Event::Link(LinkState::Lost {
            reason: "gone".into(),
        }));
        bus.publish(Event::Notice("not logged".into()));
        bus.close();
        let mut out = Vec::new();
        write_log(rx, &mut out).await.expect("log");
        let text = String::from_utf8(out).expect("utf-8");
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 3);
        assert_eq!(lines[0], "2026-11-21T22:34:01.000000Z >> @0P<CR>");
        assert_eq!(lines[1], "2026-11-21T22:34:01.000000Z << F<FD>");
        assert!(lines[2].ends_with(" # link lost: gone"));
    }

    #[tokio::test]
    async fn every_input_change_gets_a_decoded_line() {
        use crate::device::api::{EstopSkew, InputChange};
        use crate::device::inputs;
        use std::sync::Arc;
        use std::time::Instant;
        let profile =
            crate::config::load_profile("isel", &crate::config::ConfigDirs::builtin_only())
                .expect("profile");
        let ch = inputs::channels::shared(&profile);
        let by = |a: &str| ch.iter().find(|c| c.address == a).cloned().expect(a);
        let seen = Instant::now();
        let ms = Duration::from_millis;
        let bus = EventBus::new(16);
        let rx = bus.subscribe();
        bus.publish(Event::Input(InputChange {
            seq: 1,
            channel: by("in1.1"),
            level: false,
            seen,
            before: seen - ms(17),
            t: ms(2017),
            chatter: None,
            skew: Some(EstopSkew {
                first: Arc::clone(&by("in1.0")),
                measured: ms(34),
                min: ms(17),
                max: ms(51),
            }),
        }));
        bus.close();
        let mut out = Vec::new();
        write_log(rx, &mut out).await.expect("log");
        let text = String::from_utf8(out).expect("utf-8");
        assert!(
            text.trim_end().ends_with(
                " # input E-stop circuit 2 (in1.1) 0 open, t 2.017 s, within 17.0 ms; \
                 E-STOP SKEW 34.0 ms after E-stop circuit 1 (between 17.0 ms and 51.0 ms)"
            ),
            "{text}"
        );
    }
}
