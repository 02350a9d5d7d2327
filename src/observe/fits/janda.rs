//! The Janda law Q = C (1 − α1 e^{−D/α2}) D^{5/2} (Eq. 1 of the silo paper), fitted by a search
//! over α2 with C and α1 linear at each α2.

use serde::Serialize;

use super::minimise::{grid_then_golden, rms_residual};

/// Fit of the Janda law Q = C (1 − α1 e^{−D/α2}) D^{5/2}.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct JandaFit {
    /// C, in kg s⁻¹ m⁻⁵ᐟ² when Q is in kg/s and D in m.
    pub c: f64,
    /// α1, dimensionless.
    pub alpha1: f64,
    /// α2, in m.
    pub alpha2_m: f64,
    /// D_min = α2 ln α1, in m: the orifice at which the law predicts Q = 0. None when α1 ≤ 0.
    pub d_min_m: Option<f64>,
    /// Unweighted root-mean-square of Q − model over the points, in kg/s.
    pub rms_residual_kg_per_s: f64,
    /// Number of points used.
    pub n: usize,
    /// α2 ended at an end of its search range: the data do not pin it down, and the fit is
    /// only a curve through the points.
    pub alpha2_at_bound: bool,
}

impl JandaFit {
    /// The fitted law at orifice diameter `d_m` (m), in kg/s.
    pub fn predict(&self, d_m: f64) -> f64 {
        self.c * (1.0 - self.alpha1 * (-d_m / self.alpha2_m).exp()) * d_m.powf(2.5)
    }
}

/// Weighted least-squares fit of Q = C (1 − α1 e^{−D/α2}) D^{5/2}.
///
/// `weights` multiply the squared residuals (use 1/σ² for known uncertainties σ); None means all
/// equal. For a fixed α2 the model is linear in C and C α1, so those are solved exactly and only
/// α2 is searched: a log-spaced grid over [D_min/50, 100 D_max] of the data, then golden-section
/// refinement around the best grid point. This finds the global minimum in α2 on that range,
/// which Levenberg–Marquardt from a guess need not.
///
/// Returns None for fewer than 3 usable points (positive weight), mismatched lengths,
/// non-finite input, D ≤ 0, or a degenerate system.
pub fn janda_fit(d_m: &[f64], q: &[f64], weights: Option<&[f64]>) -> Option<JandaFit> {
    let n = d_m.len();
    if n != q.len() || weights.is_some_and(|w| w.len() != n) {
        return None;
    }
    let w: Vec<f64> = weights.map_or_else(|| vec![1.0; n], <[f64]>::to_vec);
    let bad = |v: &f64| !v.is_finite();
    if d_m.iter().chain(q).chain(&w).any(bad)
        || d_m.iter().any(|&d| d <= 0.0)
        || w.iter().any(|&wi| wi < 0.0)
        || w.iter().filter(|&&wi| wi > 0.0).count() < 3
    {
        return None;
    }
    let d_lo = d_m.iter().copied().fold(f64::INFINITY, f64::min);
    let d_hi = d_m.iter().copied().fold(0.0, f64::max);
    let objective =
        |ln_a: f64| janda_linear_part(d_m, q, &w, ln_a.exp()).map_or(f64::INFINITY, |(s, _, _)| s);
    let (lo, hi) = ((d_lo / 50.0).ln(), (d_hi * 100.0).ln());
    let ln_a = grid_then_golden(objective, lo, hi, 400)?;
    let alpha2_m = ln_a.exp();
    let alpha2_at_bound = (ln_a - lo).min(hi - ln_a) < 1e-3 * (hi - lo);
    let (_, b0, b1) = janda_linear_part(d_m, q, &w, alpha2_m)?;
    if b0 == 0.0 {
        return None;
    }
    let alpha1 = -b1 / b0;
    let fit = JandaFit {
        c: b0,
        alpha1,
        alpha2_m,
        d_min_m: (alpha1 > 0.0).then(|| alpha2_m * alpha1.ln()),
        rms_residual_kg_per_s: 0.0,
        n,
        alpha2_at_bound,
    };
    let rms = rms_residual(d_m, q, |d| fit.predict(d));
    Some(JandaFit {
        rms_residual_kg_per_s: rms,
        ..fit
    })
}

/// For fixed α2, the weighted least-squares solution of Q = β0 D^{5/2} + β1 D^{5/2} e^{−D/α2}
/// (so C = β0, α1 = −β1/β0). Returns (weighted residual sum of squares, β0, β1), or None when the
/// two basis functions are numerically collinear.
fn janda_linear_part(d_m: &[f64], q: &[f64], w: &[f64], alpha2: f64) -> Option<(f64, f64, f64)> {
    let basis = |d: f64| {
        let g0 = d.powf(2.5);
        (g0, g0 * (-d / alpha2).exp())
    };
    let (mut a00, mut a01, mut a11, mut r0, mut r1) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for ((&d, &qi), &wi) in d_m.iter().zip(q).zip(w) {
        let (g0, g1) = basis(d);
        a00 += wi * g0 * g0;
        a01 += wi * g0 * g1;
        a11 += wi * g1 * g1;
        r0 += wi * g0 * qi;
        r1 += wi * g1 * qi;
    }
    if a00 <= 0.0 || a11 <= 0.0 {
        return None;
    }
    // Normal equations with unit-scaled columns: the raw ones differ by orders of magnitude.
    let (s0, s1) = (a00.sqrt(), a11.sqrt());
    let c = a01 / (s0 * s1);
    let det = 1.0 - c * c;
    if det < 1e-12 {
        return None;
    }
    let (u0, u1) = (r0 / s0, r1 / s1);
    let b0 = (u0 - c * u1) / det / s0;
    let b1 = (u1 - c * u0) / det / s1;
    let ssr = d_m
        .iter()
        .zip(q)
        .zip(w)
        .map(|((&d, &qi), &wi)| {
            let (g0, g1) = basis(d);
            wi * (qi - b0 * g0 - b1 * g1).powi(2)
        })
        .sum();
    Some((ssr, b0, b1))
}
