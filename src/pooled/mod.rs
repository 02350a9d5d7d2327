//! A campaign's replicas combined per point, read from the store: the silo's Q (`silo`) and the
//! chute's D, γ̇ and block profiles (`chute`, over the jobs `chute_jobs` reads) and its
//! coarse-grained V_x and φ profiles (`chute_fields`). Figures, claims
//! and the adaptive rounds all take their statistics from here, so a point means the same thing
//! to each of them.

pub mod chute;
pub mod chute_fields;
pub mod chute_jobs;
pub mod flow_pattern;
pub mod orifice_pressure;
pub mod replica_results;
pub mod silo;
