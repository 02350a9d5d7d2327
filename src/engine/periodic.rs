//! The periodic box along x and y: wrapping positions into it (`Periodic`) and the minimum image
//! of a separation (`Image`), in the run's precision.

use super::real::{Real, V3};

/// Periodic extents along x and y, in the run's precision.
#[derive(Clone, Copy, Debug)]
pub struct Periodic<R: Real> {
    pub x: Option<(R, R)>,
    pub y: Option<(R, R)>,
}

impl<R: Real> Periodic<R> {
    /// Minimum-image separation b − a (see `Image`); a hot loop takes `image()` once instead.
    #[inline(always)]
    pub fn delta(&self, a: V3<R>, b: V3<R>) -> V3<R> {
        self.image().delta(a, b)
    }

    /// The lengths the minimum image needs, computed once for a hot loop.
    #[inline(always)]
    pub fn image(&self) -> Image<R> {
        let len = |a: Option<(R, R)>| a.map_or(R::zero(), |(lo, hi)| hi - lo);
        let (lx, ly) = (len(self.x), len(self.y));
        Image {
            len: [lx, ly],
            half: [lx * R::from_f64(0.5), ly * R::from_f64(0.5)],
        }
    }

    /// Whether p lies in the box along the periodic axes (then `wrap` leaves it).
    #[inline(always)]
    pub fn inside(&self, p: V3<R>) -> bool {
        let within = |x: R, b: Option<(R, R)>| b.is_none_or(|(lo, hi)| x >= lo && x < hi);
        within(p.x, self.x) && within(p.y, self.y)
    }

    /// The same box in f64.
    pub fn to_f64(&self) -> Periodic<f64> {
        let c = |b: Option<(R, R)>| b.map(|(lo, hi)| (lo.to_f64(), hi.to_f64()));
        Periodic {
            x: c(self.x),
            y: c(self.y),
        }
    }

    /// What `wrap` adds to p along x and y (z never wraps).
    pub fn wrap_shift(&self, p: V3<R>) -> V3<R> {
        let shift = |x: R, b: Option<(R, R)>| b.map_or(R::zero(), |(lo, hi)| shift1(x, lo, hi));
        V3::new(shift(p.x, self.x), shift(p.y, self.y), R::zero())
    }

    /// Wraps a position into the box (the `floor` only for a particle more than a box away).
    #[inline(always)]
    pub fn wrap(&self, p: &mut V3<R>) {
        if let Some((lo, hi)) = self.x {
            p.x = wrap1(p.x, lo, hi);
        }
        if let Some((lo, hi)) = self.y {
            p.y = wrap1(p.y, lo, hi);
        }
    }
}

/// The minimum image along the periodic axes. Positions are wrapped into the box, so |b − a| < L
/// and one shift is the minimum image: no `floor` (a libm call on baseline x86-64). The box
/// lengths are precomputed (zero along an axis that is not periodic, which leaves it untouched)
/// and the shift is chosen by selects, not branches (options and comparisons would sit in the
/// innermost loop, once per pair): d − (−l) is d + l and d − 0 is d, the same bits as a branch
/// would give.
#[derive(Clone, Copy, Debug)]
pub struct Image<R: Real> {
    len: [R; 2],
    half: [R; 2],
}

impl<R: Real> Image<R> {
    /// Box lengths and half lengths along x and y (zero along an axis that is not periodic).
    pub(crate) fn lengths(&self) -> ([R; 2], [R; 2]) {
        (self.len, self.half)
    }

    /// Minimum-image separation b − a (positions wrapped into the box).
    #[inline(always)]
    pub fn delta(&self, a: V3<R>, b: V3<R>) -> V3<R> {
        self.fold(b - a)
    }

    /// The minimum image of a separation d between two positions wrapped into the box.
    #[inline(always)]
    pub fn fold(&self, d: V3<R>) -> V3<R> {
        let fold = |d: R, k: usize| {
            let (l, h) = (self.len[k], self.half[k]);
            let up = if d > h { l } else { R::zero() };
            let down = if d < -h { l } else { R::zero() };
            d - (up - down)
        };
        V3::new(fold(d.x, 0), fold(d.y, 1), d.z)
    }
}

#[inline(always)]
fn wrap1<R: Real>(x: R, lo: R, hi: R) -> R {
    // Inside the box, by far the common case, needs only the box's ends in registers; the
    // crossing is out of line (the per-particle kick had spilled the crossing's constants).
    if x >= lo && x < hi {
        x
    } else {
        cross1(x, lo, hi)
    }
}

/// The whole number of box lengths `wrap1` adds to x (−l, 0, l or a multiple).
fn shift1<R: Real>(x: R, lo: R, hi: R) -> R {
    let l = hi - lo;
    if x >= lo && x < hi {
        R::zero()
    } else if x >= hi && x < hi + l {
        -l
    } else if x < lo && x >= lo - l {
        l
    } else {
        -(l * ((x - lo) / l).floor())
    }
}

/// `wrap1` for a coordinate outside the box.
#[cold]
#[inline(never)]
fn cross1<R: Real>(x: R, lo: R, hi: R) -> R {
    let l = hi - lo;
    if x >= hi && x < hi + l {
        x - l
    } else if x < lo && x >= lo - l {
        x + l
    } else {
        x - l * ((x - lo) / l).floor()
    }
}
