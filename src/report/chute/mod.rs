//! Figures 1(b)–7 of the chute paper (Soft Matter 2022, spherocylinders on an incline) redrawn
//! from a campaign's rows: the V_x and φ profiles (Fig. 1(b), `fig1b`), MSD_z(τ) per block
//! (Fig. 2, here), the D and γ̇ profiles (Figs. 3 and 4, `profiles`), v_z PDFs and skewness
//! (Fig. 5) and velocity correlations (Fig. 7, `velocity`), the scaling D ~ γ̇ d_⊥² (Fig. 6,
//! `scaling`); beyond the paper's figures, the rods' order S2(z) and ⟨|cos θ|⟩(z)
//! (`orientation`) and the ESI's D_y beside γ̇ (`dy`, in `lateral`). Every number comes
//! from the chute tables of the campaign's done jobs. Lengths are in units of the particle length
//! L = chute_summary.total_length_m of each job, so D is in L²/s, as the paper plots.
//!
//! Figs. 2, 5 and 7 show the paper's two showcase cases: the done job with ξ closest to 1.3 (then
//! α closest to 27°) and the one with ξ closest to 2.5 (then α closest to 30°); their curves are
//! that one job's, the text says how many replicas its point has. Figs. 3, 4, 6 and Fig. 5's
//! skewness combine the steady replicas of a point (`replicas`): D pooled with its 95 % CI, the
//! other block values their mean.

mod common;
mod fig1b;
mod lateral;
mod msd;
mod orientation;
mod profiles;
#[cfg(test)]
mod replica_tests;
mod scaling;
mod velocity;

pub(crate) use crate::report::chute::fig1b::fig1b;
pub(crate) use crate::report::chute::lateral::dy;
pub(crate) use crate::report::chute::msd::fig2;
pub(crate) use crate::report::chute::orientation::orientation;
pub(crate) use crate::report::chute::profiles::{fig3, fig4};
pub(crate) use crate::report::chute::scaling::fig6;
pub(crate) use crate::report::chute::velocity::{fig5, fig7};
