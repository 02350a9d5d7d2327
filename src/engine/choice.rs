//! How a kernel takes a two-way choice: by a branch (one contact at a time: only the taken side
//! is computed) or by a select (SIMD lanes: both sides computed, one kept per lane, so the loop
//! has no branch and vectorises). The contact law and the segment geometry are written once over
//! this choice with [`pick!`]; both forms compute the kept side with the same operations, so
//! they give the same bits.

/// How two-way choices are taken.
pub trait Choice {
    /// Whether only the side taken is computed (a branch) rather than both (a select).
    const LAZY: bool;
}

/// Computes only the side taken: the scalar kernels.
pub struct Branch;

/// Computes both sides and keeps one: the lane kernels (a blend per lane).
pub struct Select;

impl Choice for Branch {
    const LAZY: bool = true;
}

impl Choice for Select {
    const LAZY: bool = false;
}

/// `pick!(C, c, a, b)`: `a` when `c`, else `b`, taken as the [`Choice`] `C` takes choices. A
/// macro, not a function of closures: the sides stay in the caller's body, where the compiler
/// vectorises them (closures of a few dozen operations are left as calls in the lane loops).
macro_rules! pick {
    ($C:ty, $c:expr, $a:expr, $b:expr) => {
        if <$C as $crate::engine::choice::Choice>::LAZY {
            if $c {
                $a
            } else {
                $b
            }
        } else {
            let (taken, other) = ($a, $b);
            if $c {
                taken
            } else {
                other
            }
        }
    };
}
pub(crate) use pick;
