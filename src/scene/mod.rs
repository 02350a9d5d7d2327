//! Scenes turn a job's physical parameters into an engine configuration, an initial state and the
//! stage logic around the engine (filling, opening the orifice, re-insertion, steady state).

mod blame;
pub mod chute;
pub mod chute_scene;
pub mod chute_warm_start;
pub mod dense_bed;
pub mod fill;
pub mod fill_rods;
pub mod placement_checks;
pub mod silo;
mod silo_checks;
pub mod silo_refill;

pub use chute::ChuteParams;
pub use chute_scene::ChuteScene;
pub use silo::{SiloParams, SiloScene};
pub use silo_refill::RefillError;

/// Whether a scene's `origin_m` is the default (then it is left out of the job's parameters,
/// so that jobs from before the parameter keep their hashes).
pub fn at_origin(o: &[f64; 3]) -> bool {
    *o == [0.0; 3]
}
