//! Scenes turn a job's physical parameters into an engine configuration, an initial state and the
//! stage logic around the engine (filling, opening the orifice, re-insertion).

pub mod fill;
pub mod silo;

pub use silo::{SiloParams, SiloScene};
