//! D from MSD_z(τ): the least-squares line MSD_z = 2 D τ + c over the fitted lags, the same line
//! as fixed weights on the lags (for per-particle window sums), and the standard error of D from
//! independent time windows.

use serde::{Deserialize, Serialize};

use crate::observe::fits::linear_fit;

/// D from a straight line MSD_z = 2 D τ + c.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DiffusionFit {
    /// D (m²/s): half the slope.
    pub d: f64,
    /// Standard error of D from the least-squares residuals (m²/s). The MSD at different lags
    /// are correlated (they share displacements), so this understates the true uncertainty
    /// several times; the chute stores the window-based error instead (`window_stderr`).
    pub stderr: f64,
    /// Correlation coefficient of the line.
    pub r: f64,
    /// Smallest and largest lag actually used (s).
    pub min_lag: f64,
    pub max_lag: f64,
    /// Lags used.
    pub points: usize,
}

/// Whether lag τ lies in [min_lag, max_lag], both ends included to within 10⁻⁹ relative (lags
/// are k·Δ in floating point). The one rule for every fit, so all use the same lags.
fn in_fit_range(lag: f64, min_lag: f64, max_lag: f64) -> bool {
    lag >= min_lag * (1.0 - 1e-9) && lag <= max_lag * (1.0 + 1e-9)
}

/// Fits MSD_z = 2 D τ + c to the points with τ in [min_lag, max_lag] (s). In the chute the
/// motion is diffusive for τ > 1 s (the paper's Fig. 2), ballistic below.
///
/// None with fewer than 3 such points (no residual left for an error), non-finite values or a
/// non-positive slope.
pub fn fit_diffusion(
    lags: &[f64],
    msd: &[f64],
    min_lag: f64,
    max_lag: f64,
) -> Option<DiffusionFit> {
    let (x, y): (Vec<f64>, Vec<f64>) = lags
        .iter()
        .zip(msd)
        .filter(|(t, _)| in_fit_range(**t, min_lag, max_lag))
        .map(|(&t, &m)| (t, m))
        .unzip();
    if x.len() < 3 {
        return None;
    }
    let line = linear_fit(&x, &y)?;
    (line.slope > 0.0).then(|| DiffusionFit {
        d: 0.5 * line.slope,
        stderr: 0.5 * line.slope_se,
        r: line.r,
        min_lag: x.iter().copied().fold(f64::INFINITY, f64::min),
        max_lag: x.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        points: x.len(),
    })
}

/// The fitted lags k = lo..=hi (in samples) and the least-squares slope as fixed weights:
/// slope = Σ_k c_k MSD(kΔ) with c_k = (τ_k − τ̄)/Σ(τ_j − τ̄)². Linear in the MSD, so a particle's
/// weighted squared displacements can be summed as they come and blocks formed later.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(super) struct FitLags {
    pub lo: usize,
    pub hi: usize,
    /// c_k for k = 0..W (zero outside lo..=hi, so the sum needs no branch), in 1/s.
    pub weights: Vec<f64>,
}

impl FitLags {
    /// The lags kΔ (k = 1..window) in [min_lag, max_lag]; None with fewer than 3.
    pub fn new(interval_s: f64, window: usize, min_lag: f64, max_lag: f64) -> Option<Self> {
        let ks: Vec<usize> = (1..window)
            .filter(|&k| in_fit_range(k as f64 * interval_s, min_lag, max_lag))
            .collect();
        let (&lo, &hi) = (ks.first()?, ks.last()?);
        if ks.len() < 3 {
            return None;
        }
        let mean = ks.iter().map(|&k| k as f64 * interval_s).sum::<f64>() / ks.len() as f64;
        let sxx: f64 = ks
            .iter()
            .map(|&k| (k as f64 * interval_s - mean).powi(2))
            .sum();
        let mut weights = vec![0.0; window];
        for &k in &ks {
            weights[k] = (k as f64 * interval_s - mean) / sxx;
        }
        Some(Self { lo, hi, weights })
    }

    /// Number of fitted lags.
    pub fn len(&self) -> usize {
        self.hi + 1 - self.lo
    }
}

/// Standard error of D from M independent window estimates D_j, each weighted by its amount of
/// data n_j (batch means with unequal batches, Var D_j ≈ σ²/n_j):
/// SE² = Σ n_j (D_j − D̄)² / ((M − 1) Σ n_j), D̄ = Σ n_j D_j / Σ n_j. With equal n_j this is
/// the familiar std(D_j)/√M (sample std, M − 1 degrees of freedom): a standard error, not an
/// interval; a 95 % interval is ± t_{M−1} SE (3.18 SE for M = 4).
///
/// None with fewer than 2 windows, a non-finite value or no data.
pub fn window_stderr(d: &[f64], n: &[f64]) -> Option<f64> {
    let m = d.len();
    if m < 2 || n.len() != m || d.iter().chain(n).any(|v| !v.is_finite()) {
        return None;
    }
    let total: f64 = n.iter().sum();
    if !(total > 0.0) {
        return None;
    }
    let mean = d.iter().zip(n).map(|(d, n)| d * n).sum::<f64>() / total;
    let ss: f64 = d.iter().zip(n).map(|(d, n)| n * (d - mean).powi(2)).sum();
    Some((ss / ((m - 1) as f64 * total)).sqrt())
}
