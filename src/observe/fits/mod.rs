//! Pure numerical fits used on discharge results: straight lines, the Student t quantile and
//! confidence intervals of a mean, the Janda law Q = C (1 − α1 e^{−D/α2}) D^{5/2} (Eq. 1 of the
//! silo paper) and the Beverloo law Q = C ρ_b √g (D − k d)^{5/2}.
//!
//! Everything here takes slices and returns plain values; nothing reads the database or the
//! simulation state. Inputs are SI (metres, kg/s); the doc of each field gives its unit.

mod beverloo;
mod bootstrap;
mod janda;
mod janda_bootstrap;
mod line;
mod minimise;
mod pooled;
mod stats;
#[cfg(test)]
mod tests;

pub use beverloo::{
    beverloo_bootstrap, beverloo_c_at_k, beverloo_fit, BeverlooFit, BeverlooIntervals,
};
pub use bootstrap::{JandaPoint, BOOTSTRAP_DRAWS};
pub use janda::{janda_fit, JandaFit};
pub use janda_bootstrap::{janda_bootstrap, JandaIntervals, JANDA_PARAMETERS};
pub use line::{linear_fit, LinearFit};
pub use pooled::{pool, t_975, Pooled, PooledFrom, ReplicaEstimate};
pub use stats::{mean_ci95, student_t_975};
