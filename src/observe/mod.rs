//! Observers: read downloaded particle state, never change it; and the statistics and fits
//! that turn their samples into results.

pub mod chute;
pub mod chute_stats;
pub mod claims;
pub mod coarse_grain;
pub mod discharge;
pub mod energy;
pub mod fits;
pub mod msd;
pub mod silo_fields;
pub mod snapshots;
pub mod stationarity;
pub mod steady;
