//! How a kernel takes a two-way choice: by a branch (one contact at a time: only the taken side
//! is computed) or by a select (SIMD lanes: both sides computed, one kept per lane, so the loop
//! has no branch and vectorises). The contact law and the segment geometry are written once over
//! this choice; both forms compute the kept side with the same operations, so they give the same
//! bits.

use crate::engine::real::{Real, V3};

/// A two-way choice between values of type T.
pub trait Choice {
    /// `a()` when `c`, else `b()`.
    fn pick<T>(c: bool, a: impl FnOnce() -> T, b: impl FnOnce() -> T) -> T;
}

/// Computes only the side taken: the scalar kernels.
pub struct Branch;

/// Computes both sides and keeps one: the lane kernels (a blend per lane).
pub struct Select;

impl Choice for Branch {
    #[inline(always)]
    fn pick<T>(c: bool, a: impl FnOnce() -> T, b: impl FnOnce() -> T) -> T {
        if c {
            a()
        } else {
            b()
        }
    }
}

impl Choice for Select {
    #[inline(always)]
    fn pick<T>(c: bool, a: impl FnOnce() -> T, b: impl FnOnce() -> T) -> T {
        let (x, y) = (a(), b());
        if c {
            x
        } else {
            y
        }
    }
}

/// Per component `a` when `c`, else `b`: a blend in the lane kernels.
#[inline(always)]
pub fn select3<R: Real>(c: bool, a: V3<R>, b: V3<R>) -> V3<R> {
    V3::new(
        if c { a.x } else { b.x },
        if c { a.y } else { b.y },
        if c { a.z } else { b.z },
    )
}
