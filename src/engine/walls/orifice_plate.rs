//! The silo's bottom: a horizontal plate at `z0` with a circular orifice (centre `a`, radius
//! `r`; radius 0 is a closed plate) whose rim is a real edge.

use super::WallKernel;
use crate::engine::real::{Real, V3};

/// A sphere's (centre `p`, radius `rad`) contact with the plate's face or the orifice's rim:
/// (normal, distance, point).
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
        // The anchor is the orifice's centre on the plate (a.z = z0).
        let dz = rel.z;
        if dz.abs() >= rad {
            return None;
        }
        let (dx, dy) = (rel.x, rel.y);
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
            let d = if R::SPLIT_POSITIONS {
                V3::new(rel.x - dx / rr * k.r, rel.y - dy / rr * k.r, rel.z)
            } else {
                p - q
            };
            let dist = d.norm();
            if dist >= rad || dist <= R::zero() {
                return None;
            }
            (d * (R::one() / dist), dist, q)
        }
    })
}
