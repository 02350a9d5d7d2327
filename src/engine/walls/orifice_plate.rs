//! The silo's bottom: a horizontal plate at `z0` with a circular orifice (centre `a`, radius
//! `r`; radius 0 is a closed plate) whose rim is a real edge.

use super::WallKernel;
use crate::engine::real::{Real, V3};

/// A sphere's (centre `p`, radius `rad`) contact with the plate's face or the orifice's rim:
/// (normal, distance, point).
#[inline(always)]
pub(super) fn touch<R: Real>(k: &WallKernel<R>, p: V3<R>, rad: R) -> Option<(V3<R>, R, V3<R>)> {
    Some({
        let dz = p.z - k.z0;
        if dz.abs() >= rad {
            return None;
        }
        let dx = p.x - k.a.x;
        let dy = p.y - k.a.y;
        let rr = (dx * dx + dy * dy).sqrt();
        if rr >= k.r {
            // Over the solid part: the plate's face, from whichever side.
            let s = if dz >= R::zero() { R::one() } else { -R::one() };
            (
                V3::new(R::zero(), R::zero(), s),
                dz.abs(),
                V3::new(p.x, p.y, k.z0),
            )
        } else {
            // Over the hole: the nearest solid point is on the rim (a real edge).
            if rr <= R::zero() {
                return None;
            }
            let q = V3::new(k.a.x + dx / rr * k.r, k.a.y + dy / rr * k.r, k.z0);
            let d = p - q;
            let dist = d.norm();
            if dist >= rad || dist <= R::zero() {
                return None;
            }
            (d * (R::one() / dist), dist, q)
        }
    })
}
