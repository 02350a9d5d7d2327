//! A plane wall: a point `a` on it and its unit normal `b`, solid on the side `b` points away
//! from.

use super::WallKernel;
use crate::engine::real::{Real, V3};

/// A sphere's (centre `p`, radius `rad`) contact with the plane: (normal, distance, point).
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
        let d = rel.dot(k.b);
        if d >= rad {
            return None;
        }
        (k.b, d, p - k.b * d)
    })
}
