//! The drive's real-time clock (EMP manual "54 : RTC"), run from the
//! simulator's synthetic time so tests are deterministic.
//!
//! It behaves like the usual I²C RTC chips: date and time count together, the
//! weekday is a register of its own that `54 02` sets and that advances at
//! every midnight; setting the date (`54 03`) leaves time and weekday alone.
//! Writing restarts the seconds prescaler, so a second set at `t` ends at
//! `t + 1 s`. It starts at [`RtcClock::POWER_UP`], Thursday 2026-01-01
//! 00:00:00, when the simulator first sees time.

use std::time::Instant;

use crate::proto::emp::{RtcDate, RtcTime, ValueError};

const SECS_PER_DAY: i64 = 86_400;

/// Days from 1970-01-01 to a proleptic Gregorian date (H. Hinnant's
/// `days_from_civil`).
fn days_from_civil(year: i64, month: i64, day: i64) -> i64 {
    let y = if month <= 2 { year - 1 } else { year };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (month + 9) % 12;
    let doy = (153 * mp + 2) / 5 + day - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// The inverse of [`days_from_civil`]: year, month, day.
fn civil_from_days(days: i64) -> (i64, i64, i64) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    (year, month, day)
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct RtcClock {
    /// When the registers below were last written (or first seen).
    anchor: Option<Instant>,
    /// Seconds since 1970-01-01 00:00:00 at `anchor`.
    secs: i64,
    /// Weekday register at `anchor`, 1 (Monday) to 7.
    weekday: u8,
}

impl RtcClock {
    /// Seconds since 1970 of 2026-01-01 00:00:00, and its weekday (Thursday).
    pub(crate) const POWER_UP: (i64, u8) = (20_454 * SECS_PER_DAY, 4);

    pub(crate) fn new() -> RtcClock {
        RtcClock {
            anchor: None,
            secs: Self::POWER_UP.0,
            weekday: Self::POWER_UP.1,
        }
    }

    /// Start counting at `now` if the clock has not started yet.
    pub(crate) fn start(&mut self, now: Instant) {
        self.anchor.get_or_insert(now);
    }

    fn secs_at(&self, now: Instant) -> i64 {
        let elapsed = self
            .anchor
            .map_or(0, |a| now.saturating_duration_since(a).as_secs());
        self.secs
            .saturating_add(i64::try_from(elapsed).unwrap_or(i64::MAX))
    }

    fn weekday_at(&self, now: Instant) -> u8 {
        let days = self
            .secs_at(now)
            .div_euclid(SECS_PER_DAY)
            .saturating_sub(self.secs.div_euclid(SECS_PER_DAY));
        // 1..=7 by construction.
        ((i64::from(self.weekday) - 1 + days).rem_euclid(7) + 1) as u8
    }

    /// Every field is in range by construction, so this does not fail; the
    /// `Result` keeps the arithmetic free of panics all the same.
    pub(crate) fn time(&self, now: Instant) -> Result<RtcTime, ValueError> {
        let tod = self.secs_at(now).rem_euclid(SECS_PER_DAY);
        let (h, m, s) = (tod / 3600, tod / 60 % 60, tod % 60);
        RtcTime::new(self.weekday_at(now), h as u8, m as u8, s as u8)
    }

    pub(crate) fn date(&self, now: Instant) -> Result<RtcDate, ValueError> {
        let (y, m, d) = civil_from_days(self.secs_at(now).div_euclid(SECS_PER_DAY));
        // The year register holds four BCD digits: it wraps after 9999.
        RtcDate::new(y.rem_euclid(10_000) as u16, m as u8, d as u8)
    }

    /// `54 02`: weekday and time of day; the date stays.
    pub(crate) fn set_time(&mut self, now: Instant, t: RtcTime) {
        let day = self.secs_at(now).div_euclid(SECS_PER_DAY);
        let tod = i64::from(t.hour()) * 3600 + i64::from(t.minute()) * 60 + i64::from(t.second());
        self.secs = day * SECS_PER_DAY + tod;
        self.weekday = t.weekday();
        self.anchor = Some(now);
    }

    /// `54 03`: the date; time of day and weekday stay.
    pub(crate) fn set_date(&mut self, now: Instant, d: RtcDate) {
        let tod = self.secs_at(now).rem_euclid(SECS_PER_DAY);
        let weekday = self.weekday_at(now);
        let day = days_from_civil(
            i64::from(d.year()),
            i64::from(d.month()),
            i64::from(d.day()),
        );
        self.secs = day * SECS_PER_DAY + tod;
        self.weekday = weekday;
        self.anchor = Some(now);
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;

    #[test]
    fn civil_days_round_trip_and_power_up_is_a_thursday() {
        assert_eq!(days_from_civil(1970, 1, 1), 0);
        assert_eq!(days_from_civil(2026, 1, 1), 20_454);
        // 1970-01-01 was a Thursday, and 20454 is a multiple of 7.
        assert_eq!(20_454 % 7, 0);
        for days in [-800_000, -1, 0, 59, 11_016, 20_454, 2_900_000] {
            let (y, m, d) = civil_from_days(days);
            assert_eq!(days_from_civil(y, m, d), days);
        }
        assert_eq!(civil_from_days(days_from_civil(2024, 2, 29)), (2024, 2, 29));
    }

    #[test]
    fn counts_from_power_up_across_midnight() {
        let t0 = Instant::now();
        let mut c = RtcClock::new();
        c.start(t0);
        assert_eq!(c.time(t0).unwrap().to_string(), "day 4 00:00:00");
        assert_eq!(c.date(t0).unwrap().to_string(), "01.01.2026");
        let later = t0 + Duration::from_secs(86_400 + 3_661);
        assert_eq!(c.time(later).unwrap().to_string(), "day 5 01:01:01");
        assert_eq!(c.date(later).unwrap().to_string(), "02.01.2026");
    }

    #[test]
    fn setting_time_and_date_keeps_the_other_half() {
        let t0 = Instant::now();
        let mut c = RtcClock::new();
        c.start(t0);
        let t1 = t0 + Duration::from_millis(1500);
        c.set_time(t1, RtcTime::new(7, 23, 59, 58).unwrap());
        c.set_date(t1, RtcDate::new(2024, 2, 28).unwrap());
        let t2 = t1 + Duration::from_secs(3);
        assert_eq!(c.time(t2).unwrap().to_string(), "day 1 00:00:01");
        assert_eq!(c.date(t2).unwrap().to_string(), "29.02.2024");
        // Wrapping after 9999 keeps the registers valid.
        c.set_date(t2, RtcDate::new(9999, 12, 31).unwrap());
        let t3 = t2 + Duration::from_secs(86_400);
        assert_eq!(c.date(t3).unwrap().to_string(), "01.01.0000");
    }
}
