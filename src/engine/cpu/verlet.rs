//! Velocity Verlet's two moves of a particle's centre, written once for every path (the f32
//! SIMD kick in `kick.rs` does the same operations in the same order on 4-wide registers).

use crate::engine::grid::Periodic;
use crate::engine::position;
use crate::engine::real::{Real, V3};

/// The kick: velocity by (force/m + g) over `kick` (half a step or a whole one).
#[inline(always)]
pub(super) fn kick<R: Real>(v: &mut V3<R>, force: V3<R>, inv_m: R, g: V3<R>, kick: R) {
    *v += (force * inv_m + g) * kick;
}

/// The drift: position (`x`, and its rest `lo` where positions are split: `position.rs`) by
/// velocity over `dt`, wrapped into the periodic box.
#[inline(always)]
pub(super) fn drift<R: Real>(
    x: &mut V3<R>,
    lo: &mut V3<R>,
    v: V3<R>,
    dt: R,
    periodic: &Periodic<R>,
) {
    if R::SPLIT_POSITIONS {
        position::drift(x, lo, v * dt);
        if !periodic.inside(*x) {
            wrap_split(periodic, x, lo);
        }
    } else {
        *x += v * dt;
        periodic.wrap(x);
    }
}

/// The periodic wrap of a split position: the shift (whole box lengths, as `Periodic::wrap`
/// chooses them) added to hi by `two_sum`, its rounding error then carried into lo.
#[cold]
#[inline(never)]
pub(super) fn wrap_split<R: Real>(periodic: &Periodic<R>, x: &mut V3<R>, lo: &mut V3<R>) {
    let shift = periodic.wrap_shift(*x);
    let (ax, ay) = (
        position::two_sum(x.x, shift.x),
        position::two_sum(x.y, shift.y),
    );
    let (hx, lx) = position::two_sum(ax.0, ax.1 + lo.x);
    let (hy, ly) = position::two_sum(ay.0, ay.1 + lo.y);
    (x.x, lo.x, x.y, lo.y) = (hx, lx, hy, ly);
}
