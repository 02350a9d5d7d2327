//! Coarse-graining (MercuryDPM's CG: coordinates × function × fields): the kernel (`kernel`),
//! the grids (`z_grid`; axisymmetric and Cartesian ones for the silo slot in beside it), the
//! field sums at a point (`fields`), profiles on a grid (`z_profile`) and their time average
//! (`time_average`).

mod fields;
mod kernel;
mod time_average;
mod z_grid;
mod z_profile;

pub use fields::{PointFields, Tensor};
pub use kernel::{Kernel, Kernel1d};
pub use time_average::ZProfileAverage;
pub use z_grid::ZGrid;
pub use z_profile::{bulk_stress_ratio, ZProfile};
