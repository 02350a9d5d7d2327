//! Coarse-graining (MercuryDPM's CG: coordinates × function × fields): the kernels (`kernel`
//! in 1-D, `sphere_kernel` in 3-D and its azimuthal average `ring`), the grids (`z_grid`;
//! `field_grid` for axisymmetric (r, z) and Cartesian ones), the field sums at a point
//! (`fields`), profiles on a z grid (`z_profile`) and their time average (`time_average`), sums
//! on (r, z) and Cartesian grids (`grid_fields`) and their time average (`grid_average`), and
//! the field sets that carry them to the store (`field_set`).

mod field_grid;
mod field_set;
mod fields;
mod grid_average;
mod grid_fields;
mod kernel;
mod ring;
mod sphere_kernel;
mod time_average;
mod z_grid;
mod z_profile;

pub use field_grid::{FieldGrid, GridKind};
pub use field_set::{FieldArray, FieldSet};
pub use fields::{PointFields, Tensor};
pub use grid_average::GridAverage;
pub use grid_fields::GridFields;
pub use kernel::{Kernel, Kernel1d};
pub use ring::{gauss_legendre, Ring, RingWeights};
pub use sphere_kernel::SphereKernel;
pub use time_average::ZProfileAverage;
pub use z_grid::ZGrid;
pub use z_profile::{bulk_stress_ratio, ZProfile};
