//! Statistics of the chute paper beyond the coarse-grained fields: the particle size across the
//! flow (`orientation`), streaming moments (`moments`) and standardised PDFs (`vz_pdf`) of v_z,
//! and the spatial correlation of v_z (`correlation`).

mod correlation;
mod moments;
mod orientation;
mod vz_pdf;

pub use correlation::{correlation_length, CorrelationCurve, VzCorrelation, CORRELATION_FIT_FLOOR};
pub use moments::Moments;
pub use orientation::{cos_theta, d_perp, mean_cos_theta};
pub use vz_pdf::{StandardisedPdf, FINE_BINS_PER_STD, FINE_HALF_RANGE_STD, WARMUP_VALUES};
