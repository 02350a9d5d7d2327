//! Closest points between two segments (and a point and a segment): the geometric core of the
//! spherocylinder contact. Owns the robustness rules — zero-length segments are points, (nearly)
//! parallel segments get a deterministic point in the middle of their overlap — and nothing about
//! radii, normals or forces (that is `spherocylinder`).
//!
//! Segment 1 is `p1 + s d1`, segment 2 is `p2 + t d2`, with s, t ∈ [0, 1]. The squared distance
//! F(s, t) = |r + s d1 − t d2|², r = p1 − p2, is a convex quadratic on the unit square; its
//! minimum is found as in Ericson, *Real-Time Collision Detection* (2005) §5.1.9: the line–line
//! minimiser s, clamped; t optimal for that s; if t leaves [0, 1] it is clamped and s re-solved.
//! Two changes make it robust:
//! - the line–line solution is written with cross products, s = (d1 × d2)·(d2 × r) / |d1 × d2|²
//!   (the Lagrange identity applied to Ericson's (b f − c e)/(a e − b²)), whose relative rounding
//!   error grows like ε/sin θ instead of ε/sin²θ as the angle θ between the segments closes;
//! - for parallel segments the closest pair is not unique, and for nearly parallel ones it jumps
//!   from one end of the overlap to the other as θ changes sign. Below sin θ = θc
//!   ([`PARALLEL_SIN`]) s is taken at the middle of the overlap of the two segments projected on
//!   segment 1 and t is its projection on segment 2; between θc and 2θc s moves linearly from
//!   there to the exact solution; above 2θc the pair is exact. So the point never jumps, and the
//!   distance returned exceeds the true minimum by at most ½ |d1| sin θ ≤ |d1| · 10⁻⁶ (the
//!   distance to the other segment changes by at most sin θ per unit length along the overlap).

use crate::engine::choice::{pick, Branch, Choice};
use crate::engine::real::{Real, V3};

/// θc: two segments whose directions make an angle with sine at most this are treated as
/// parallel (contact point in the middle of their overlap), and above twice this exactly.
/// 10⁻⁶ rad keeps the extra distance this costs, ½ l sin θ, at most 10⁻⁶ of a rod length, while
/// being well above the angle rounding can fake in f32 (directions are accurate to ~10⁻⁷).
pub const PARALLEL_SIN: f64 = 1e-6;

/// A segment whose squared length is at most this (in the caller's units squared) is a point:
/// it avoids dividing by zero (a sphere, l = 0) or by a subnormal. 10⁻³⁶ is above f32's smallest
/// normal (1.2 × 10⁻³⁸) and far below any real rod (ξ = 1.01 with d = 1 mm gives l² = 10⁻¹⁰ m²).
pub const POINT_LEN2: f64 = 1e-36;

/// The closest points of two segments.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosestPoints<R> {
    /// Parameter of the point on segment 1, in [0, 1].
    pub s: R,
    /// Parameter of the point on segment 2, in [0, 1].
    pub t: R,
    /// The point on segment 1, `p1 + s d1`.
    pub p: V3<R>,
    /// The point on segment 2, `p2 + t d2`.
    pub q: V3<R>,
    /// |p − q|².
    pub dist2: R,
}

/// Clamps to [0, 1]; NaN becomes 0 (the comparisons in `Real::max` are false for NaN).
#[inline(always)]
fn clamp01<R: Real>(x: R) -> R {
    x.max(R::zero()).min(R::one())
}

/// Closest points between segment 1 (`p1 + s d1`) and segment 2 (`p2 + t d2`), s, t ∈ [0, 1].
///
/// Robust for crossed, T, end-to-end, parallel and nearly parallel segments and for segments of
/// zero length (then a point, parameter 0). For sin θ ≤ θc = [`PARALLEL_SIN`] the pair is the
/// middle of the overlap of the two segments (projected on segment 1) and its projection on
/// segment 2, or the nearest ends when their projections do not overlap; for θc < sin θ < 2θc a
/// linear blend towards the exact pair (module doc).
#[inline]
pub fn closest_points<R: Real>(p1: V3<R>, d1: V3<R>, p2: V3<R>, d2: V3<R>) -> ClosestPoints<R> {
    closest_points_in::<R, Branch>(p1, d1, p2, d2)
}

/// [`closest_points`], written once: `C` takes its choices (`Select` in the lane kernels, which
/// give the same bits).
#[inline(always)]
pub fn closest_points_in<R: Real, C: Choice>(
    p1: V3<R>,
    d1: V3<R>,
    p2: V3<R>,
    d2: V3<R>,
) -> ClosestPoints<R> {
    let zero = R::zero();
    let tiny = R::from_f64(POINT_LEN2);
    let r = p1 - p2;
    let a = d1.norm2();
    let e = d2.norm2();
    let c = d1.dot(r);
    let f = d2.dot(r);
    let (a_point, e_point) = (a <= tiny, e <= tiny);
    let (s, t) = pick!(
        C,
        a_point & e_point,
        (zero, zero),
        pick!(
            C,
            a_point,
            (zero, clamp01(f / e)),
            pick!(
                C,
                e_point,
                (clamp01(-c / a), zero),
                segments::<R, C>(d1, d2, r, [a, c, e, f])
            )
        )
    );
    let p = p1 + d1 * s;
    let q = p2 + d2 * t;
    ClosestPoints {
        s,
        t,
        p,
        q,
        dist2: (p - q).norm2(),
    }
}

/// Two segments of nonzero length: exact, parallel, or the blend between (module doc).
/// [a, c, e, f] = [|d1|², d1·r, |d2|², d2·r].
#[inline(always)]
fn segments<R: Real, C: Choice>(d1: V3<R>, d2: V3<R>, r: V3<R>, acef: [R; 4]) -> (R, R) {
    let [a, c, e, f] = acef;
    let b = d1.dot(d2);
    let n = d1.cross(d2);
    let n2 = n.norm2();
    let ae = a * e;
    let lim2 = R::from_f64(PARALLEL_SIN * PARALLEL_SIN);
    let s_line = n.dot(d2.cross(r)) / n2;
    pick!(
        C,
        n2 > R::from_f64(4.0) * lim2 * ae,
        general::<R, C>(s_line, a, b, c, e, f),
        pick!(C, n2 <= lim2 * ae, parallel::<R, C>(a, b, c, e, f), {
            // θc < sin θ ≤ 2θc: from the overlap's middle (w = 0) to the exact pair (w = 1).
            let (s_mid, _) = parallel::<R, C>(a, b, c, e, f);
            let (s_exact, _) = general::<R, C>(s_line, a, b, c, e, f);
            let w = (n2 / ae).sqrt() / R::from_f64(PARALLEL_SIN) - R::one();
            let s = s_mid + (s_exact - s_mid) * w.max(R::zero()).min(R::one());
            (s, clamp01((b * s + f) / e))
        })
    )
}

/// Non-parallel segments from the line–line minimiser `s_line` (Lagrange identity form, see the
/// module doc): s clamped, t optimal for it; if t leaves [0, 1] it is clamped and s re-solved.
/// a = |d1|², b = d1·d2, c = d1·r, e = |d2|², f = d2·r.
#[inline(always)]
fn general<R: Real, C: Choice>(s_line: R, a: R, b: R, c: R, e: R, f: R) -> (R, R) {
    let s = clamp01(s_line);
    let t = (b * s + f) / e;
    pick!(
        C,
        t < R::zero(),
        (clamp01(-c / a), R::zero()),
        pick!(C, t > R::one(), (clamp01((b - c) / a), R::one()), (s, t))
    )
}

/// Parallel segments: the middle of the overlap of segment 2 projected on segment 1, or, when the
/// projections are disjoint, the nearest ends. a = |d1|², b = d1·d2, c = d1·r, e = |d2|², f = d2·r.
#[inline(always)]
fn parallel<R: Real, C: Choice>(a: R, b: R, c: R, e: R, f: R) -> (R, R) {
    let zero = R::zero();
    let one = R::one();
    // Where the two ends of segment 2 project on segment 1's line, in units of s.
    let s0 = -c / a;
    let s1 = (b - c) / a;
    let (lo, hi) = pick!(C, s0 <= s1, (s0, s1), (s1, s0));
    let (lo_in, hi_in) = (lo.max(zero), hi.min(one));
    pick!(
        C,
        lo_in <= hi_in,
        {
            let s = (lo_in + hi_in) * R::from_f64(0.5);
            (s, clamp01((b * s + f) / e))
        },
        {
            // Disjoint projections (end to end): from segment 1's nearer end to segment 2 and back.
            let s = pick!(C, hi < zero, zero, one);
            let t = clamp01((b * s + f) / e);
            (clamp01((b * t - c) / a), t)
        }
    )
}

/// The point of segment `p + s d` nearest to `x`: returns (s, point), s ∈ [0, 1]; a segment of
/// zero length returns (0, p).
#[inline]
pub fn closest_point_on_segment<R: Real>(p: V3<R>, d: V3<R>, x: V3<R>) -> (R, V3<R>) {
    let a = d.norm2();
    let s = if a <= R::from_f64(POINT_LEN2) {
        R::zero()
    } else {
        clamp01((x - p).dot(d) / a)
    };
    (s, p + d * s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64, z: f64) -> V3<f64> {
        V3::new(x, y, z)
    }

    #[test]
    fn crossed_segments_meet_at_their_crossing() {
        let c = closest_points(
            v(-1.0, 0.0, 1.0),
            v(2.0, 0.0, 0.0),
            v(0.0, -1.0, 0.0),
            v(0.0, 2.0, 0.0),
        );
        assert!((c.s - 0.5).abs() < 1e-15 && (c.t - 0.5).abs() < 1e-15);
        assert!((c.dist2 - 1.0).abs() < 1e-15);
    }

    #[test]
    fn parallel_overlap_gives_its_middle() {
        // Segment 2 covers x ∈ [0.5, 3]: the overlap with [0, 2] is [0.5, 2], middle 1.25.
        let c = closest_points(
            v(0.0, 0.0, 0.0),
            v(2.0, 0.0, 0.0),
            v(3.0, 1.0, 0.0),
            v(-2.5, 0.0, 0.0),
        );
        assert!((c.p.x - 1.25).abs() < 1e-15 && (c.q.x - 1.25).abs() < 1e-15);
        assert!((c.dist2 - 1.0).abs() < 1e-15);
    }

    #[test]
    fn zero_length_segments_are_points() {
        let c = closest_points(v(0.0, 0.0, 0.0), V3::zero(), v(1.0, 2.0, 2.0), V3::zero());
        assert_eq!((c.s, c.t, c.dist2), (0.0, 0.0, 9.0));
        let (s, p) = closest_point_on_segment(v(0.0, 0.0, 0.0), v(4.0, 0.0, 0.0), v(1.0, 1.0, 0.0));
        assert_eq!((s, p), (0.25, v(1.0, 0.0, 0.0)));
    }
}
