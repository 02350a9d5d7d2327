//! The Beverloo law Q = C ρ_b √g (D − k d)^{5/2}, fitted by a line in (D, Q^{2/5}) refined over k.

use serde::Serialize;

use super::bootstrap::{fitted_draws, percentiles, JandaPoint};
use super::line::linear_fit;
use super::minimise::{golden_min, rms_residual};

/// Fit of the Beverloo law Q = C ρ_b √g (D − k d)^{5/2}.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct BeverlooFit {
    /// C, dimensionless.
    pub c: f64,
    /// k, dimensionless (the empty annulus is k d wide).
    pub k: f64,
    /// Unweighted root-mean-square of Q − model over the points, in kg/s.
    pub rms_residual_kg_per_s: f64,
    /// Number of points used.
    pub n: usize,
}

impl BeverlooFit {
    /// The fitted law at orifice diameter `d_m` (m), in kg/s; 0 below D = k d.
    pub fn predict(&self, d_m: f64, particle_d_m: f64, bulk_density: f64, g: f64) -> f64 {
        let gap = (d_m - self.k * particle_d_m).max(0.0);
        self.c * bulk_density * g.sqrt() * gap.powf(2.5)
    }
}

/// Least-squares fit of Q = C ρ_b √g (D − k d)^{5/2} for C and k.
///
/// Q^{2/5} is linear in D, so a straight line through (D, Q^{2/5}) gives both parameters exactly
/// for data that follow the law; k is then refined by minimising the residuals of Q itself (C
/// solved exactly for each k) with a golden-section search, because the linearised fit weights
/// the points differently. Only points with Q > 0 are used.
///
/// Returns None for fewer than 3 such points, mismatched lengths, non-finite input, a
/// non-positive d, ρ_b or g, or a non-increasing Q(D).
pub fn beverloo_fit(
    d_m: &[f64],
    q: &[f64],
    particle_d_m: f64,
    bulk_density: f64,
    g: f64,
) -> Option<BeverlooFit> {
    if d_m.len() != q.len()
        || [particle_d_m, bulk_density, g]
            .iter()
            .any(|&v| v.is_nan() || v <= 0.0)
    {
        return None;
    }
    let (d, q): (Vec<f64>, Vec<f64>) = d_m
        .iter()
        .zip(q)
        .filter(|(di, qi)| di.is_finite() && qi.is_finite() && **qi > 0.0)
        .map(|(&di, &qi)| (di, qi))
        .unzip();
    if d.len() < 3 || !particle_d_m.is_finite() || !bulk_density.is_finite() || !g.is_finite() {
        return None;
    }
    let scale = bulk_density * g.sqrt();
    let y: Vec<f64> = q.iter().map(|qi| qi.powf(0.4)).collect();
    let line = linear_fit(&d, &y)?;
    if line.slope <= 0.0 {
        return None;
    }
    let k0 = -line.intercept / (line.slope * particle_d_m);
    let c0 = line.slope.powf(2.5) / scale;
    // Residual sum of squares in Q for a given k, with the best C for that k.
    let d_lo = d.iter().copied().fold(f64::INFINITY, f64::min);
    let c_for_k = |k: f64| c_and_ssr_at_k(&d, &q, particle_d_m, scale, k);
    let k_hi = (k0 + 1.0).min(d_lo / particle_d_m);
    let k_ref = golden_min(|k| c_for_k(k).0, k0 - 1.0, k_hi, 1e-12);
    let (ssr0, _) = c_for_k(k0);
    let (ssr_ref, c_ref) = c_for_k(k_ref);
    let (c, k) = if ssr_ref.is_finite() && ssr_ref < ssr0 {
        (c_ref, k_ref)
    } else {
        (c0, k0)
    };
    let fit = BeverlooFit {
        c,
        k,
        rms_residual_kg_per_s: 0.0,
        n: d.len(),
    };
    let rms = rms_residual(&d, &q, |di| fit.predict(di, particle_d_m, bulk_density, g));
    Some(BeverlooFit {
        rms_residual_kg_per_s: rms,
        ..fit
    })
}

/// 95 % intervals (2.5 and 97.5 percentiles over the bootstrap draws) of Beverloo's C and k.
#[derive(Debug, Clone, Copy)]
pub struct BeverlooIntervals {
    pub c: (f64, f64),
    pub k: (f64, f64),
    /// Draws fitted (a draw the law cannot fit is left out).
    pub draws: usize,
}

/// The 95 % intervals of [`beverloo_fit`] over `points` redrawn from their replicas or their
/// CI (`bootstrap.rs`), seeded by `seed`. None with fewer than 3 points (two parameters and no
/// degree of freedom left) or when fewer than half the draws can be fitted.
pub fn beverloo_bootstrap(
    points: &[JandaPoint],
    particle_d_m: f64,
    bulk_density: f64,
    g: f64,
    seed: u64,
) -> Option<BeverlooIntervals> {
    if points.len() < 3 {
        return None;
    }
    let d: Vec<f64> = points.iter().map(|p| p.d_m).collect();
    let fits = fitted_draws(points, seed, |q| {
        beverloo_fit(&d, q, particle_d_m, bulk_density, g)
    });
    if fits.len() * 2 < super::bootstrap::BOOTSTRAP_DRAWS {
        return None;
    }
    Some(BeverlooIntervals {
        c: percentiles(fits.iter().map(|f| f.c).collect()),
        k: percentiles(fits.iter().map(|f| f.k).collect()),
        draws: fits.len(),
    })
}

/// The least-squares C of Q = C ρ_b √g (D − k d)^{5/2} at a given k, and the residual sum of
/// squares in Q: (ssr, C).
fn c_and_ssr_at_k(d: &[f64], q: &[f64], particle_d_m: f64, scale: f64, k: f64) -> (f64, f64) {
    let h: Vec<f64> = d
        .iter()
        .map(|di| scale * (di - k * particle_d_m).max(0.0).powf(2.5))
        .collect();
    let hh: f64 = h.iter().map(|hi| hi * hi).sum();
    let c = h.iter().zip(q).map(|(hi, qi)| hi * qi).sum::<f64>() / hh;
    let ssr: f64 = h.iter().zip(q).map(|(hi, qi)| (qi - c * hi).powi(2)).sum();
    (ssr, c)
}

/// Beverloo's C with k held fixed (k = 1.5 is the usual value for spheres): unlike the joint
/// fit, whose C and k trade off against each other, this C moves only with the flow rates.
/// None for no point with Q > 0 and D > k d, or non-finite or non-positive inputs.
pub fn beverloo_c_at_k(
    d_m: &[f64],
    q: &[f64],
    particle_d_m: f64,
    bulk_density: f64,
    g: f64,
    k: f64,
) -> Option<f64> {
    if d_m.len() != q.len()
        || [particle_d_m, bulk_density, g, k]
            .iter()
            .any(|&v| !v.is_finite() || v <= 0.0)
    {
        return None;
    }
    let (d, q): (Vec<f64>, Vec<f64>) = d_m
        .iter()
        .zip(q)
        .filter(|(di, qi)| qi.is_finite() && **qi > 0.0 && **di > k * particle_d_m)
        .map(|(&di, &qi)| (di, qi))
        .unzip();
    if d.is_empty() {
        return None;
    }
    let (_, c) = c_and_ssr_at_k(&d, &q, particle_d_m, bulk_density * g.sqrt(), k);
    c.is_finite().then_some(c)
}
