//! Observers: read downloaded particle state, never change it; and the statistics and fits
//! that turn their samples into results.

pub mod discharge;
pub mod fits;
