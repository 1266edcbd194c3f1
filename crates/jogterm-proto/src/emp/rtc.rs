//! The drive's real-time clock (EMP manual "54 : RTC"). Every field is one BCD
//! byte: the manual's VB code shows each byte's two hex digits as the decimal
//! field (`lbl8.Text + "." + lbl7.Text + …` gives "TT.MM.JJJJ").

use std::fmt;

use super::error::ValueError;

/// Two decimal digits as one byte, `42` -> 0x42.
pub fn to_bcd(value: u8) -> Result<u8, ValueError> {
    if value > 99 {
        return Err(ValueError::OutOfRange {
            field: "BCD value",
            value: i64::from(value),
            expected: "0..=99",
        });
    }
    Ok(((value / 10) << 4) | (value % 10))
}

pub fn from_bcd(field: &'static str, byte: u8) -> Result<u8, ValueError> {
    let (hi, lo) = (byte >> 4, byte & 0x0F);
    if hi > 9 || lo > 9 {
        return Err(ValueError::NotBcd { field, value: byte });
    }
    Ok(hi * 10 + lo)
}

fn check(
    field: &'static str,
    value: u8,
    range: std::ops::RangeInclusive<u8>,
    expected: &'static str,
) -> Result<u8, ValueError> {
    if range.contains(&value) {
        Ok(value)
    } else {
        Err(ValueError::OutOfRange {
            field,
            value: i64::from(value),
            expected,
        })
    }
}

/// WT HH MM SS of `54 DS 00` (reply) and `54 DS 02` (request).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct RtcTime {
    weekday: u8,
    hour: u8,
    minute: u8,
    second: u8,
}

impl RtcTime {
    /// `weekday` 1 (Monday) to 7 (Sunday) (docs/protocols.md, EMP).
    pub fn new(weekday: u8, hour: u8, minute: u8, second: u8) -> Result<RtcTime, ValueError> {
        Ok(RtcTime {
            weekday: check("weekday", weekday, 1..=7, "1..=7 (Monday = 1)")?,
            hour: check("hour", hour, 0..=23, "0..=23")?,
            minute: check("minute", minute, 0..=59, "0..=59")?,
            second: check("second", second, 0..=59, "0..=59")?,
        })
    }

    pub fn weekday(&self) -> u8 {
        self.weekday
    }
    pub fn hour(&self) -> u8 {
        self.hour
    }
    pub fn minute(&self) -> u8 {
        self.minute
    }
    pub fn second(&self) -> u8 {
        self.second
    }

    /// D3..D0: WT HH MM SS.
    pub fn to_bytes(self) -> [u8; 4] {
        // All fields were checked to be below 100, so `to_bcd` cannot fail.
        [self.weekday, self.hour, self.minute, self.second].map(|v| to_bcd(v).unwrap_or(0))
    }

    pub fn from_bytes(b: [u8; 4]) -> Result<RtcTime, ValueError> {
        RtcTime::new(
            from_bcd("weekday", b[0])?,
            from_bcd("hour", b[1])?,
            from_bcd("minute", b[2])?,
            from_bcd("second", b[3])?,
        )
    }
}

impl fmt::Display for RtcTime {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "day {} {:02}:{:02}:{:02}",
            self.weekday, self.hour, self.minute, self.second
        )
    }
}

/// CC JJ MO TT (century, year, month, day of month) of `54 DS 01` (reply) and
/// `54 DS 03` (request).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct RtcDate {
    year: u16,
    month: u8,
    day: u8,
}

impl RtcDate {
    /// `year` 0-9999 (century and year byte), a real calendar date.
    pub fn new(year: u16, month: u8, day: u8) -> Result<RtcDate, ValueError> {
        if year > 9999 {
            return Err(ValueError::OutOfRange {
                field: "year",
                value: i64::from(year),
                expected: "0..=9999",
            });
        }
        check("month", month, 1..=12, "1..=12")?;
        if day == 0 || day > days_in_month(year, month) {
            return Err(ValueError::NoSuchDay { year, month, day });
        }
        Ok(RtcDate { year, month, day })
    }

    pub fn year(&self) -> u16 {
        self.year
    }
    pub fn month(&self) -> u8 {
        self.month
    }
    pub fn day(&self) -> u8 {
        self.day
    }

    /// D3..D0: CC JJ MO TT.
    pub fn to_bytes(self) -> [u8; 4] {
        // year <= 9999, so both halves are below 100 and `to_bcd` cannot fail.
        let century = (self.year / 100) as u8;
        let year = (self.year % 100) as u8;
        [century, year, self.month, self.day].map(|v| to_bcd(v).unwrap_or(0))
    }

    pub fn from_bytes(b: [u8; 4]) -> Result<RtcDate, ValueError> {
        let century = from_bcd("century", b[0])?;
        let year = from_bcd("year", b[1])?;
        RtcDate::new(
            u16::from(century) * 100 + u16::from(year),
            from_bcd("month", b[2])?,
            from_bcd("day", b[3])?,
        )
    }
}

fn days_in_month(year: u16, month: u8) -> u8 {
    match month {
        2 if year.is_multiple_of(4) && (!year.is_multiple_of(100) || year.is_multiple_of(400)) => {
            29
        }
        2 => 28,
        4 | 6 | 9 | 11 => 30,
        _ => 31,
    }
}

/// `TT.MM.JJJJ` as the manual's VB code shows it.
impl fmt::Display for RtcDate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:02}.{:02}.{:04}", self.day, self.month, self.year)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bcd_round_trips_and_rejects_hex_digits() {
        assert_eq!(to_bcd(59).unwrap(), 0x59);
        assert!(to_bcd(100).is_err());
        assert_eq!(from_bcd("x", 0x59).unwrap(), 59);
        assert!(from_bcd("x", 0x5A).is_err());
        assert!(from_bcd("x", 0xA5).is_err());
    }

    #[test]
    fn time_and_date_bytes() {
        let t = RtcTime::new(3, 14, 5, 9).unwrap();
        assert_eq!(t.to_bytes(), [0x03, 0x14, 0x05, 0x09]);
        assert_eq!(RtcTime::from_bytes([0x03, 0x14, 0x05, 0x09]).unwrap(), t);
        assert!(RtcTime::from_bytes([0x08, 0x14, 0x05, 0x09]).is_err());
        assert!(RtcTime::from_bytes([0x01, 0x24, 0x05, 0x09]).is_err());
        let d = RtcDate::new(2026, 11, 20).unwrap();
        assert_eq!(d.to_bytes(), [0x20, 0x26, 0x11, 0x20]);
        assert_eq!(d.to_string(), "20.11.2026");
        assert_eq!(RtcDate::from_bytes([0x20, 0x26, 0x11, 0x20]).unwrap(), d);
    }

    #[test]
    fn impossible_dates_are_rejected() {
        assert!(RtcDate::new(2026, 2, 29).is_err());
        assert!(RtcDate::new(2024, 2, 29).is_ok());
        assert!(RtcDate::new(2100, 2, 29).is_err());
        assert!(RtcDate::new(2000, 2, 29).is_ok());
        assert!(RtcDate::new(2026, 4, 31).is_err());
        assert!(RtcDate::new(2026, 13, 1).is_err());
        assert!(RtcDate::new(2026, 1, 0).is_err());
        assert!(RtcDate::new(10_000, 1, 1).is_err());
    }
}
