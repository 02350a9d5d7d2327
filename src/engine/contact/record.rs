//! One contact as stress observers see it: who, where, the branch vector and the force. The
//! engine produces these only when an observer asks (`Backend::contacts`), never in the step loop.

use serde::{Deserialize, Serialize};

/// A particle–particle contact (each pair once) or a particle–wall contact, in f64 SI units.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContactRecord {
    /// Particle i (its stable id).
    pub i: u32,
    /// Partner j's id, or `None` for a wall.
    pub j: Option<u32>,
    /// Centre of i (m), wrapped into the periodic box.
    pub pos_i: [f64; 3],
    /// Branch vector c_i − c_j (m, minimum image); for a wall, c_i − contact point.
    pub branch: [f64; 3],
    /// Force on i from j (N); j feels the opposite.
    pub force_on_i: [f64; 3],
    /// Whether j is a fixed particle (the chute's rough base).
    pub j_fixed: bool,
}
