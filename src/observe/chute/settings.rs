//! What the chute observer is told: its settings (from the campaign file) and the chute's
//! geometry (from the scene), with their range checks.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::observe::msd::MsdBlocks;

/// The chute job's chunk (s): the engine advances this much between two looks at the state.
/// Every chunk starts from a fresh sort and neighbour list (so a resumed run repeats the same
/// operations), which makes the chunk part of the trajectory's bits; it is therefore fixed, not
/// the sampling interval, and jobs that differ only in their observers follow the same
/// trajectory. Sampling intervals are multiples of it; a faster one shortens the chunk.
pub const CHUNK_S: f64 = 0.05;

/// Most time windows of D(z)'s error: each costs 2 · 4 · 12 bytes per particle in the
/// trajectory assignment (see `msd::cells`).
pub const MAX_ERROR_WINDOWS: u32 = 16;

/// Settings of the chute observer (recorded with each job). Lengths are in units of the particle
/// length L, so one campaign file serves every aspect ratio.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ChuteObserverSettings {
    /// Interval between snapshots (s), also the MSD's lag resolution. Default 0.05 s, the
    /// paper's δτ.
    pub sample_interval_s: f64,
    /// Longest MSD lag (s). Default 5 s: five times the ballistic-to-diffusive crossover
    /// (τ ≈ 1 s in the paper), at O(N · max_lag/interval) memory.
    pub max_lag_s: f64,
    /// Shortest lag of the diffusion fit (s). Default 1 s: the paper's motion is diffusive above.
    pub fit_min_lag_s: f64,
    /// Longest lag of the diffusion fit (s); None (default) = `max_lag_s`.
    pub fit_max_lag_s: Option<f64>,
    /// How the MSD is split into blocks of height L: "trajectory" (default, the paper's: each
    /// particle once, by the mean height of its whole tracked trajectory) or "window" (each
    /// (particle, origin) pair by the particle's mean height over [t, t + τ]).
    pub msd_blocks: MsdBlocks,
    /// Consecutive time windows M of the measurement for D(z)'s standard error (std of the
    /// per-window D over √M). Default 4; 2 to 16. Each window should be much longer than the
    /// fit's longest lag (no error is stored when one is shorter).
    pub msd_error_windows: u32,
    /// Coarse-graining width w / L. Default 0.25, the paper's ω = L/4.
    pub cg_width_over_length: f64,
    /// Kernel cutoff in widths. Default 4, the paper's r_c = 4ω.
    pub cg_cutoff_widths: f64,
    /// Spacing of the field grid / L. Default 0.125 = w/2: the Gaussian is resolved and the
    /// block means (8 points per block) do not depend on where the points fall.
    pub field_dz_over_length: f64,
    /// Bin width of the standardised v_z PDFs, in standard deviations. Default 0.25.
    pub pdf_bin_std: f64,
    /// Evaluate C(r) every this many snapshots. Default 10 (every 0.5 s): each evaluation is
    /// O(n_block²), and snapshots 0.05 s apart are strongly correlated anyway.
    pub correlation_every: u32,
    /// Bin width of C(r) / L. Default 0.25, the paper's L/4.
    pub correlation_bin_over_length: f64,
    /// Largest r of C(r) / L. Default 4: beyond a few L the paper's C(r) is lost in noise.
    pub correlation_max_r_over_length: f64,
}

impl Default for ChuteObserverSettings {
    fn default() -> Self {
        Self {
            sample_interval_s: 0.05,
            max_lag_s: 5.0,
            fit_min_lag_s: 1.0,
            fit_max_lag_s: None,
            msd_blocks: MsdBlocks::Trajectory,
            msd_error_windows: 4,
            cg_width_over_length: 0.25,
            cg_cutoff_widths: 4.0,
            field_dz_over_length: 0.125,
            pdf_bin_std: 0.25,
            correlation_every: 10,
            correlation_bin_over_length: 0.25,
            correlation_max_r_over_length: 4.0,
        }
    }
}

/// The chute as the observer needs it (SI). z is the lab vertical; heights in the results are
/// measured from `z_base_m`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ChuteGeometry {
    /// Particle length L = l + d (m).
    pub total_length_m: f64,
    /// Diameter d (m).
    pub diameter_m: f64,
    /// Cylinder length l (m).
    pub cylinder_length_m: f64,
    /// Periodic box length along the flow (m).
    pub box_x_m: f64,
    /// Periodic box width (m).
    pub box_y_m: f64,
    /// z of the base spheres' centres (m): height 0, bottom of block 0.
    pub z_base_m: f64,
    /// Top of the field grid and of the last block (m).
    pub z_top_m: f64,
    /// Inclination α (degrees).
    pub inclination_deg: f64,
}

/// A setting or geometry value out of range.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{field}: {message}")]
pub struct SettingProblem {
    /// The field's name (settings fields as in the campaign file, geometry ones prefixed
    /// `geometry.`).
    pub field: &'static str,
    /// Expected and found.
    pub message: String,
}

impl ChuteObserverSettings {
    /// The fit's longest lag (s).
    pub fn fit_max_lag(&self) -> f64 {
        self.fit_max_lag_s.unwrap_or(self.max_lag_s)
    }

    /// Every out-of-range setting (empty when all are usable).
    pub fn problems(&self) -> Vec<SettingProblem> {
        let mut p = Vec::new();
        let mut positive = |field: &'static str, v: f64, unit: &str| {
            if !(v > 0.0 && v.is_finite()) {
                p.push(SettingProblem {
                    field,
                    message: format!("expected {unit} > 0, got {v}"),
                });
            }
        };
        positive("sample_interval_s", self.sample_interval_s, "seconds");
        positive("max_lag_s", self.max_lag_s, "seconds");
        positive("fit_min_lag_s", self.fit_min_lag_s, "seconds");
        positive("cg_width_over_length", self.cg_width_over_length, "a ratio");
        positive("cg_cutoff_widths", self.cg_cutoff_widths, "widths");
        positive("field_dz_over_length", self.field_dz_over_length, "a ratio");
        positive("pdf_bin_std", self.pdf_bin_std, "standard deviations");
        positive(
            "correlation_bin_over_length",
            self.correlation_bin_over_length,
            "a ratio",
        );
        positive(
            "correlation_max_r_over_length",
            self.correlation_max_r_over_length,
            "a ratio",
        );
        if !(2..=MAX_ERROR_WINDOWS).contains(&self.msd_error_windows) {
            p.push(SettingProblem {
                field: "msd_error_windows",
                message: format!(
                    "expected 2 to {MAX_ERROR_WINDOWS} windows, got {}",
                    self.msd_error_windows
                ),
            });
        }
        if self.correlation_every == 0 {
            p.push(SettingProblem {
                field: "correlation_every",
                message: "expected at least 1 snapshot, got 0".into(),
            });
        }
        if self.sample_interval_s > CHUNK_S {
            let r = self.sample_interval_s / CHUNK_S;
            if (r - r.round()).abs() > 1e-6 {
                p.push(SettingProblem {
                    field: "sample_interval_s",
                    message: format!(
                        "expected a multiple of the chute's {CHUNK_S} s chunk (or less than it), got {}",
                        self.sample_interval_s
                    ),
                });
            }
        }
        if self.max_lag_s < self.sample_interval_s {
            p.push(SettingProblem {
                field: "max_lag_s",
                message: format!(
                    "expected at least sample_interval_s = {} s, got {}",
                    self.sample_interval_s, self.max_lag_s
                ),
            });
        }
        let hi = self.fit_max_lag();
        // A straight line with a standard error needs 3 lags.
        if !(hi <= self.max_lag_s
            && hi - self.fit_min_lag_s >= 2.0 * self.sample_interval_s * (1.0 - 1e-9))
        {
            p.push(SettingProblem {
                field: "fit_max_lag_s",
                message: format!(
                    "expected at most max_lag_s = {} s and at least fit_min_lag_s + 2 sample intervals = {} s, got {hi}",
                    self.max_lag_s,
                    self.fit_min_lag_s + 2.0 * self.sample_interval_s
                ),
            });
        }
        if self.correlation_max_r_over_length < self.correlation_bin_over_length {
            p.push(SettingProblem {
                field: "correlation_max_r_over_length",
                message: format!(
                    "expected at least correlation_bin_over_length = {}, got {}",
                    self.correlation_bin_over_length, self.correlation_max_r_over_length
                ),
            });
        }
        p
    }
}

impl ChuteGeometry {
    /// Whether the particles are rods (ξ > 1, a cylinder between the caps) with an axis whose
    /// orientation means something; spheres (ξ = 1) have none.
    pub fn has_axis(&self) -> bool {
        self.cylinder_length_m > 1e-9 * self.total_length_m
    }

    /// Every out-of-range value (empty when the geometry is usable).
    pub fn problems(&self) -> Vec<SettingProblem> {
        let mut p = Vec::new();
        for (field, v) in [
            ("geometry.total_length_m", self.total_length_m),
            ("geometry.diameter_m", self.diameter_m),
            ("geometry.box_x_m", self.box_x_m),
            ("geometry.box_y_m", self.box_y_m),
        ] {
            if !(v > 0.0 && v.is_finite()) {
                p.push(SettingProblem {
                    field,
                    message: format!("expected metres > 0, got {v}"),
                });
            }
        }
        let l = self.cylinder_length_m;
        if !(l >= 0.0
            && (self.total_length_m - l - self.diameter_m).abs() <= 1e-9 * self.total_length_m)
        {
            p.push(SettingProblem {
                field: "geometry.cylinder_length_m",
                message: format!(
                    "expected total_length_m − diameter_m = {} m, got {l}",
                    self.total_length_m - self.diameter_m
                ),
            });
        }
        if !(self.z_top_m - self.z_base_m >= self.total_length_m) {
            p.push(SettingProblem {
                field: "geometry.z_top_m",
                message: format!(
                    "expected at least one particle length above z_base_m = {} m, got {}",
                    self.z_base_m, self.z_top_m
                ),
            });
        }
        if !(self.inclination_deg > 0.0 && self.inclination_deg < 90.0) {
            p.push(SettingProblem {
                field: "geometry.inclination_deg",
                message: format!("expected degrees in (0, 90), got {}", self.inclination_deg),
            });
        }
        p
    }
}
