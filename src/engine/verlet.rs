//! Velocity Verlet's two moves of a particle's centre, written once for every path (the f32
//! SIMD kick in `kick.rs` does the same operations in the same order on 4-wide registers).

use super::grid::Periodic;
use super::real::{Real, V3};

/// The kick: velocity by (force/m + g) over `kick` (half a step or a whole one).
#[inline(always)]
pub(super) fn kick<R: Real>(v: &mut V3<R>, force: V3<R>, inv_m: R, g: V3<R>, kick: R) {
    *v += (force * inv_m + g) * kick;
}

/// The drift: position by velocity over `dt`, wrapped into the periodic box.
#[inline(always)]
pub(super) fn drift<R: Real>(x: &mut V3<R>, v: V3<R>, dt: R, periodic: &Periodic<R>) {
    *x += v * dt;
    periodic.wrap(x);
}
