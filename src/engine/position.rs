//! Positions whose precision does not depend on where the particle is.
//!
//! In f32 a coordinate of 0.2 m is spaced 1.5·10⁻⁸ m from its neighbours and one of 100 m
//! 7.6·10⁻⁶ m: `x += v·dt` with a step below half that spacing leaves x where it was, and an
//! overlap formed from two such coordinates is resolved only to that spacing. So an f32 engine
//! keeps each coordinate as an unevaluated sum `hi + lo` of two f32 numbers with |lo| ≤ half
//! the spacing at hi (a "double-float"):
//! - the drift adds v·dt with `two_sum`, which returns the rounding error of `hi + step`
//!   exactly, so no step is lost wherever the particle is;
//! - a separation is `(hi_i − hi_j) + (lo_i − lo_j)`: the difference of two nearby f32 numbers
//!   is exact (Sterbenz) and the rest is small, so the separation is as precise as its own
//!   size allows, not as the coordinates';
//! - what leaves the engine (downloads, checkpoints) is hi + lo in f64, and what enters it is
//!   split by `split`, which gives back the same pair for a value the engine wrote: a resumed
//!   run continues with the same bits.
//!
//! f64 keeps plain coordinates (`Real::SPLIT_POSITIONS` is false and `lo` stays empty or zero).

use super::real::{Real, V3};

/// a + b = s + e exactly, with s = fl(a + b) (Knuth's TwoSum: no condition on |a|, |b|).
#[inline(always)]
pub(super) fn two_sum<R: Real>(a: R, b: R) -> (R, R) {
    let s = a + b;
    let bb = s - a;
    let e = (a - (s - bb)) + (b - bb);
    (s, e)
}

/// The drift of a split position by `step` (= v·dt): lo collects what hi cannot hold.
#[inline(always)]
pub(super) fn drift<R: Real>(hi: &mut V3<R>, lo: &mut V3<R>, step: V3<R>) {
    let one = |h: &mut R, l: &mut R, d: R| {
        let (s, e) = two_sum(*h, d + *l);
        *h = s;
        *l = e;
    };
    one(&mut hi.x, &mut lo.x, step.x);
    one(&mut hi.y, &mut lo.y, step.y);
    one(&mut hi.z, &mut lo.z, step.z);
}

/// The separation b − a of two split positions, before any periodic fold.
#[inline(always)]
pub(crate) fn separation<R: Real>(a_hi: V3<R>, a_lo: V3<R>, b_hi: V3<R>, b_lo: V3<R>) -> V3<R> {
    if R::SPLIT_POSITIONS {
        (b_hi - a_hi) + (b_lo - a_lo)
    } else {
        b_hi - a_hi
    }
}

/// A position relative to a fixed point (a wall's anchor), as precise as the separation.
#[inline(always)]
pub(super) fn relative<R: Real>(hi: V3<R>, lo: V3<R>, anchor: V3<R>) -> V3<R> {
    if R::SPLIT_POSITIONS {
        (hi - anchor) + lo
    } else {
        hi - anchor
    }
}

/// One coordinate into the engine: hi the nearest `R` to x, lo the rest rounded toward zero,
/// which makes the split a fixed point of `split(to_f64(hi, lo))` (see the module comment).
pub(crate) fn split<R: Real>(x: f64) -> (R, R) {
    let hi = R::from_f64(x);
    if !R::SPLIT_POSITIONS || !x.is_finite() {
        return (hi, R::zero());
    }
    // Exact: x and hi are within one spacing of R.
    let rest = x - hi.to_f64();
    let mut lo = R::from_f64(rest);
    if lo.to_f64().abs() > rest.abs() {
        lo = toward_zero(lo);
    }
    (hi, lo)
}

/// The next `R` toward zero from a nonzero finite x (f32: one unit in the last place).
fn toward_zero<R: Real>(x: R) -> R {
    let v = x.to_f64();
    // Only f32 splits; its neighbours toward zero are exact in f64.
    let f = v as f32;
    let bits = f.to_bits();
    R::from_f64(f32::from_bits(bits - 1) as f64)
}

/// One coordinate out of the engine: hi + lo in f64 (exact for a split made by `split`).
#[inline]
pub(crate) fn to_f64<R: Real>(hi: R, lo: R) -> f64 {
    hi.to_f64() + lo.to_f64()
}

/// `split` of each coordinate.
pub(crate) fn split_v3<R: Real>(x: [f64; 3]) -> (V3<R>, V3<R>) {
    let (a, b, c) = (split::<R>(x[0]), split::<R>(x[1]), split::<R>(x[2]));
    (V3::new(a.0, b.0, c.0), V3::new(a.1, b.1, c.1))
}

/// `to_f64` of each coordinate.
pub(crate) fn to_f64_v3<R: Real>(hi: V3<R>, lo: V3<R>) -> [f64; 3] {
    [to_f64(hi.x, lo.x), to_f64(hi.y, lo.y), to_f64(hi.z, lo.z)]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 10⁴ steps of 10⁻⁹ m from 100 m: plain f32 does not move (the step is below half the
    /// spacing, 3.8·10⁻⁶ m); the split position travels 10⁻⁵ m, within 10⁻⁴ of it (each step
    /// rounds in lo, whose spacing is below 10⁻¹² m).
    #[test]
    fn a_slow_drift_far_from_the_origin_is_kept_exactly() {
        let (mut plain, step) = (100.0f32, 1e-9f32);
        let (mut hi, mut lo) = (V3::new(0.0, 0.0, 100.0f32), V3::zero());
        for _ in 0..10_000 {
            plain += step;
            drift(&mut hi, &mut lo, V3::new(0.0, 0.0, step));
        }
        assert_eq!(plain, 100.0);
        let travelled = to_f64(hi.z, lo.z) - 100.0;
        let expected = 1e4 * f64::from(step);
        assert!(
            (travelled - expected).abs() < 1e-4 * expected,
            "{travelled} vs {expected}"
        );
    }

    /// A value the engine wrote comes back as the same pair, including the tie case (lo at
    /// exactly half the spacing) and negative coordinates.
    #[test]
    fn split_is_a_fixed_point_of_what_the_engine_writes() {
        let mut rng = 0x2545F4914F6CDD1Du64;
        for k in 0..100_000 {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            let x = (rng as f64 / u64::MAX as f64 - 0.5) * 10f64.powi((k % 7) - 2);
            let (h, l) = split::<f32>(x);
            let back = to_f64(h, l);
            assert_eq!(split::<f32>(back), (h, l), "x = {x}");
            assert!((back - x).abs() <= x.abs() * 1e-13, "x = {x}");
        }
        let half_ulp = f64::from(f32::EPSILON) / 2.0;
        for x in [1.0 + half_ulp, 1.0 + 3.0 * half_ulp, -(1.0 + half_ulp)] {
            let (hh, l) = split::<f32>(x);
            assert_eq!(split::<f32>(to_f64(hh, l)), (hh, l), "x = {x}");
        }
    }

    /// Separations of nearby particles far out are as precise as near the origin.
    #[test]
    fn separations_do_not_depend_on_where_the_pair_is() {
        let d = 2.9e-3 - 3.0e-8; // a resting overlap of 3·10⁻⁸ m below contact at 2.9 mm
        for base in [0.0, 0.2, 100.0] {
            let (a_hi, a_lo) = split_v3::<f32>([0.0, 0.0, base + 0.1234567]);
            let (b_hi, b_lo) = split_v3::<f32>([0.0, 0.0, base + 0.1234567 + d]);
            let s = separation(a_hi, a_lo, b_hi, b_lo);
            // Within the spacing of f32 numbers at d itself (2.3·10⁻¹⁰ m).
            assert!(
                (f64::from(s.z) - d).abs() <= d * f64::from(f32::EPSILON),
                "base {base}: {} vs {d}",
                s.z
            );
        }
    }
}
