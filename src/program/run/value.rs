//! Positions as the program runner knows them: exact, within a range (after
//! a move that a port condition may end early), or unknown (before anything
//! fixed them).

/// A coordinate in steps that lies in `lo..=hi`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) struct Iv {
    pub lo: i64,
    pub hi: i64,
}

impl Iv {
    pub const ZERO: Iv = Iv { lo: 0, hi: 0 };

    pub fn exact(v: i64) -> Iv {
        Iv { lo: v, hi: v }
    }

    pub fn offset(self, d: i64) -> Iv {
        Iv {
            lo: self.lo.saturating_add(d),
            hi: self.hi.saturating_add(d),
        }
    }

    pub fn add(self, other: Iv) -> Iv {
        Iv {
            lo: self.lo.saturating_add(other.lo),
            hi: self.hi.saturating_add(other.hi),
        }
    }

    pub fn hull(self, other: Iv) -> Iv {
        Iv {
            lo: self.lo.min(other.lo),
            hi: self.hi.max(other.hi),
        }
    }
}

/// A coordinate, `None` when unknown.
pub(crate) type Val = Option<Iv>;

/// The extreme coordinates one motion of one axis reaches: its highest
/// coordinate lies in `max`, its lowest in `min` (machine coordinates).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Reach {
    pub min: Iv,
    pub max: Iv,
}

impl Reach {
    /// A straight motion from `from` to `to`, where `to` is `from` moved by a
    /// fixed amount or a fixed target: the extremes are at the ends.
    pub fn line(from: Iv, to: Iv) -> Reach {
        Reach {
            min: Iv {
                lo: from.lo.min(to.lo),
                hi: from.hi.min(to.hi),
            },
            max: Iv {
                lo: from.lo.max(to.lo),
                hi: from.hi.max(to.hi),
            },
        }
    }

    /// A motion around `centre` whose coordinate stays in
    /// `centre + low ..= centre + high`.
    pub fn around(centre: Iv, low: i64, high: i64) -> Reach {
        Reach {
            min: centre.offset(low),
            max: centre.offset(high),
        }
    }

    pub fn shifted(self, by: Iv) -> Reach {
        Reach {
            min: self.min.add(by),
            max: self.max.add(by),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_from_an_uncertain_start_reaches_at_least_its_certain_part() {
        let from = Iv { lo: 0, hi: 100 };
        let reach = Reach::line(from, from.offset(50));
        assert_eq!(reach.max, Iv { lo: 50, hi: 150 });
        assert_eq!(reach.min, Iv { lo: 0, hi: 100 });
        assert_eq!(Iv::exact(i64::MAX).offset(1), Iv::exact(i64::MAX));
    }
}
