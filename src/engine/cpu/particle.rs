//! Per-particle tags the CPU engine (`cpu/`), the pair pass (`pair_pass.rs`), the kick
//! (`kick.rs`) and the oriented gather (`oriented.rs`) share. A leaf: it imports only `real`,
//! so none of those modules needs to import another for them.

use crate::engine::real::Real;

/// A particle's liveness in the CPU engine. One byte per particle (`#[repr(u8)]`), as the
/// `u8` flags it replaces.
#[repr(u8)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub(super) enum Status {
    /// Removed: reported and waiting for the next compaction.
    Dead = 0,
    /// Interacting.
    #[default]
    Alive = 1,
    /// Fell through the sink this step: no longer interacts, to be reported (`bury_dying`).
    Dying = 2,
}

/// Per-particle constants the per-particle pass reads besides the motion record (`Kin`, which
/// carries radius and mass), packed in one array.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Props<R: Real> {
    pub(super) inv_m: R,
    pub(super) inv_i: R,
    /// 1 / (2r): overlap ratios without a division per contact.
    pub(super) inv_d: R,
}
