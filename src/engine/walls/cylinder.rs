//! The silo's side wall: a vertical cylinder (axis at `a`, radius `r`, from `z0` to `z1`),
//! touched from inside.

use super::WallKernel;
use crate::engine::real::{Real, V3};

/// A sphere's (centre `p`, radius `rad`) contact with the cylinder: (normal, distance, point).
/// `rel` is the centre's offset from `k.a` (`position::relative`), `p` the centre itself (for
/// the contact point, which only sets the wall's surface velocity).
#[inline(always)]
pub(super) fn touch<R: Real>(
    k: &WallKernel<R>,
    rel: V3<R>,
    p: V3<R>,
    rad: R,
) -> Option<(V3<R>, R, V3<R>)> {
    Some({
        if p.z < k.z0 || p.z > k.z1 {
            return None;
        }
        let (dx, dy) = (rel.x, rel.y);
        let rr2 = dx * dx + dy * dy;
        // Well inside: no contact, without the square root (every particle, every step).
        // The margin keeps the decision at the surface to the exact test below.
        let inner = k.r - rad;
        if inner > R::zero() && rr2 < inner * inner * R::from_f64(0.999) {
            return None;
        }
        let rr = rr2.sqrt();
        let d = k.r - rr;
        if d >= rad || rr <= R::zero() {
            return None;
        }
        let n = V3::new(-dx / rr, -dy / rr, R::zero());
        (
            n,
            d,
            V3::new(k.a.x + dx / rr * k.r, k.a.y + dy / rr * k.r, p.z),
        )
    })
}
