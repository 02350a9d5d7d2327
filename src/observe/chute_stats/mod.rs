//! Statistics of the chute paper beyond the coarse-grained fields: the particle size across the
//! flow (`orientation`), streaming moments (`moments`) and standardised PDFs (`vz_pdf`) of v_z,
//! the spatial correlation of v_z (`correlation`), and the rods' orientational order
//! (`nematic`: S2 and |cos θ|; `block_orientation`: both per block of height).

mod block_orientation;
mod correlation;
mod moments;
mod nematic;
mod orientation;
mod vz_pdf;

pub use block_orientation::BlockOrientation;

pub use correlation::{correlation_length, CorrelationCurve, VzCorrelation, CORRELATION_FIT_FLOOR};
pub use moments::Moments;
pub use nematic::{abs_cos_to, largest_eigenvalue, nematic_order, q_of, q_tensor, Sym3};
pub use orientation::{cos_theta, d_perp, mean_cos_theta};
pub use vz_pdf::{StandardisedPdf, FINE_BINS_PER_STD, FINE_HALF_RANGE_STD, WARMUP_VALUES};
