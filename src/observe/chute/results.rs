//! What a chute job stores: one struct per table of schema.sql (`chute_summary`, `chute_blocks`,
//! `chute_msd`, `chute_fields`, `chute_vz_pdf`, `chute_correlation`), fields named and in the
//! units of their columns. Heights z are above the base spheres' centres. Written by
//! `store::chute_results`.

use serde::{Deserialize, Serialize};

/// Everything the observer measured.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ChuteResults {
    pub summary: ChuteSummaryRow,
    pub blocks: Vec<ChuteBlockRow>,
    pub msd: Vec<ChuteMsdRow>,
    pub fields: Vec<ChuteFieldRow>,
    pub vz_pdf: Vec<ChuteVzPdfRow>,
    pub correlation: Vec<ChuteCorrelationRow>,
}

/// `chute_summary`. The observer leaves the steady-state fields empty: the runner, which ran the
/// detector before measuring, fills `steady_time_s`, `steady_stress_ratio` and `steady`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ChuteSummaryRow {
    /// ξ = L/d.
    pub aspect_ratio: f64,
    pub inclination_deg: f64,
    pub total_length_m: f64,
    pub diameter_m: f64,
    /// Flowing particles in the last snapshot.
    pub particles: u64,
    /// Height where the time-averaged ρ falls to half its bulk value (see `finish`).
    pub bed_height_m: f64,
    /// Set by the runner.
    pub steady_time_s: Option<f64>,
    /// Set by the runner: μ = −σ_xz/σ_zz of the steady window (→ tan α).
    pub steady_stress_ratio: Option<f64>,
    /// First and last snapshot (s).
    pub measure_start_s: f64,
    pub measure_end_s: f64,
    pub samples: u64,
    pub msd_fit_min_lag_s: f64,
    pub msd_fit_max_lag_s: f64,
    /// ⟨cos θ⟩ over all particles and snapshots.
    pub mean_cos_theta: f64,
    pub d_perp_m: f64,
    pub cg_width_m: f64,
    /// Set by the runner: whether the criteria held when measurement started.
    pub steady: bool,
}

/// `chute_blocks`: one layer of height L.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ChuteBlockRow {
    pub block: u32,
    /// Block centre (m).
    pub z_m: f64,
    /// D_z from the MSD fit over the whole measurement.
    pub diffusion_m2_per_s: Option<f64>,
    /// Standard error of D_z from `msd_error_windows` independent time windows (std of the
    /// windows' D over √M, see `msd::window_stderr`), not from the fit's correlated lags.
    pub diffusion_stderr_m2_per_s: Option<f64>,
    pub msd_fit_r: Option<f64>,
    /// Mean of γ̇(z) over the block.
    pub shear_rate_per_s: f64,
    /// Mean of V_x(z) over the block.
    pub velocity_x_m_per_s: f64,
    /// Mean of ρ(z)/ρ_p over the block.
    pub solid_fraction: f64,
    pub mean_particles: f64,
    pub vz_std_m_per_s: Option<f64>,
    pub vz_skewness: Option<f64>,
    pub correlation_length_m: Option<f64>,
    /// Nematic order S2 of the rods with their centre in the block (largest eigenvalue of the
    /// snapshot-averaged Q); None for spheres (no axis) and for a job resumed from a checkpoint
    /// written before it was measured (schema < 13).
    #[serde(default)]
    pub nematic_order: Option<f64>,
    /// ⟨|cos θ|⟩, θ between a rod's axis and the flow direction x; None as `nematic_order`.
    #[serde(default)]
    pub mean_abs_cos_flow: Option<f64>,
    /// D_y from the MSD of unwrapped y, fitted as D_z (same lags, blocks, windows); None with
    /// too few particles, or for a job resumed from a checkpoint older than it.
    #[serde(default)]
    pub diffusion_y_m2_per_s: Option<f64>,
    /// Standard error of D_y from the `msd_error_windows` time windows, as D_z's.
    #[serde(default)]
    pub diffusion_y_stderr_m2_per_s: Option<f64>,
}

/// `chute_msd`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ChuteMsdRow {
    pub block: u32,
    pub lag_s: f64,
    pub msd_m2: f64,
    pub pairs: u64,
}

/// `chute_fields`: one grid point of the time-averaged profiles.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ChuteFieldRow {
    pub z_m: f64,
    pub density_kg_per_m3: f64,
    pub velocity_x_m_per_s: f64,
    pub shear_rate_per_s: f64,
    /// Kinetic + contact, compressive positive: negative in a flow along +x.
    pub stress_xz_pa: f64,
    pub stress_zz_pa: f64,
}

/// `chute_vz_pdf`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ChuteVzPdfRow {
    pub block: u32,
    /// Bin centre, in standard deviations.
    pub x: f64,
    pub density: f64,
}

/// `chute_correlation`: r = 0 holds C(0) = ⟨δv_z²⟩, then bin centres.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ChuteCorrelationRow {
    pub block: u32,
    pub r_m: f64,
    pub c_m2_per_s2: f64,
    pub pairs: u64,
}
