//! Arithmetic the import does for every move, where the standard library
//! calls out to the C library.

/// [`f64::round`] (half away from zero), bit for bit, written out: on
/// x86-64 without SSE4.1 the standard one is a call into libm, and the
/// import rounds every point of a file to steps and every speed to Hz
/// (a few million calls for a CAM file of half a million lines).
#[inline]
pub fn round(x: f64) -> f64 {
    // 2^52: from there on every f64 is a whole number (NaN and the
    // infinities fail the test too and are returned as they are).
    const WHOLE: f64 = 4_503_599_627_370_496.0;
    if x.abs() < WHOLE {
        fraction_rounded(x)
    } else {
        x
    }
}

/// [`round`] of an `x` below 2^52 in size.
#[inline]
fn fraction_rounded(x: f64) -> f64 {
    // Below 2^52 an i64 holds the whole part exactly, and `x - whole` is
    // exact too: it is `x` with the bits of its whole part cleared.
    let whole = x as i64 as f64;
    let fraction = x - whole;
    // Without a branch: the fraction of a point in steps follows no
    // pattern, and a mispredicted branch a point cost more than libm's call.
    let up = f64::from(u8::from(fraction >= 0.5));
    let down = f64::from(u8::from(fraction <= -0.5));
    let rounded = whole + up - down;
    // A result of zero keeps the sign of `x` (-0.3 rounds to -0.0), as
    // the standard one does; any other result has that sign already.
    rounded.copysign(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn same(x: f64) {
        let (a, b) = (round(x), x.round());
        assert!(
            a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
            "round({x:e}) = {a:e}, f64::round {b:e}"
        );
    }

    #[test]
    fn round_is_f64_round_at_the_edges() {
        let edges = [
            0.0,
            -0.0,
            0.5,
            -0.5,
            0.49999999999999994,
            -0.49999999999999994,
            1.5,
            2.5,
            -2.5,
            0.3,
            -0.3,
            4_503_599_627_370_495.5,
            -4_503_599_627_370_495.5,
            4_503_599_627_370_496.0,
            9_007_199_254_740_993.0,
            1e300,
            -1e300,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            f64::MAX,
            f64::MIN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        for x in edges {
            same(x);
            same(x.next_up());
            same(x.next_down());
        }
    }

    proptest! {
        #[test]
        fn round_is_f64_round_for_any_bits(bits in any::<u64>()) {
            same(f64::from_bits(bits));
        }

        #[test]
        fn round_is_f64_round_near_halves(k in -10_000_000i64..10_000_000, ulps in -3i64..=3) {
            let mut x = k as f64 + 0.5;
            for _ in 0..ulps.abs() {
                x = if ulps > 0 { x.next_up() } else { x.next_down() };
            }
            same(x);
            same(x / 1024.0);
        }
    }
}
