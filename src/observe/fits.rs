//! Pure numerical fits used on discharge results: straight lines, the Student t quantile and
//! confidence intervals of a mean, the Janda law Q = C (1 − α1 e^{−D/α2}) D^{5/2} (Eq. 1 of the
//! silo paper) and the Beverloo law Q = C ρ_b √g (D − k d)^{5/2}.
//!
//! Everything here takes slices and returns plain values; nothing reads the database or the
//! simulation state. Inputs are SI (metres, kg/s); the doc of each field gives its unit.

use serde::Serialize;

/// Least-squares straight line y = slope · x + intercept.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct LinearFit {
    /// Slope, in units of y per unit of x.
    pub slope: f64,
    /// Intercept, in units of y.
    pub intercept: f64,
    /// Standard error of the slope (NaN when n = 2: no degree of freedom left).
    pub slope_se: f64,
    /// Standard error of the intercept (NaN when n = 2).
    pub intercept_se: f64,
    /// Pearson correlation coefficient R, dimensionless (NaN when y is constant).
    pub r: f64,
    /// Number of points used.
    pub n: usize,
}

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

/// Ordinary least-squares line through (x, y).
///
/// Returns None when the slices differ in length, hold fewer than 2 points, contain a non-finite
/// value, or when every x is the same.
pub fn linear_fit(x: &[f64], y: &[f64]) -> Option<LinearFit> {
    let n = x.len();
    if n != y.len() || n < 2 || x.iter().chain(y).any(|v| !v.is_finite()) {
        return None;
    }
    let nf = n as f64;
    let x_mean = x.iter().sum::<f64>() / nf;
    let y_mean = y.iter().sum::<f64>() / nf;
    // Centred sums: the uncentred form loses digits when |mean| ≫ spread.
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for (xi, yi) in x.iter().zip(y) {
        let (dx, dy) = (xi - x_mean, yi - y_mean);
        sxx += dx * dx;
        sxy += dx * dy;
        syy += dy * dy;
    }
    if sxx <= 0.0 {
        return None;
    }
    let slope = sxy / sxx;
    let intercept = y_mean - slope * x_mean;
    let (slope_se, intercept_se) = if n > 2 {
        let ssr: f64 = x
            .iter()
            .zip(y)
            .map(|(xi, yi)| (yi - intercept - slope * xi).powi(2))
            .sum();
        let s2 = ssr / (nf - 2.0);
        (
            (s2 / sxx).sqrt(),
            (s2 * (1.0 / nf + x_mean * x_mean / sxx)).sqrt(),
        )
    } else {
        (f64::NAN, f64::NAN)
    };
    let r = if syy > 0.0 {
        sxy / (sxx * syy).sqrt()
    } else {
        f64::NAN
    };
    Some(LinearFit {
        slope,
        intercept,
        slope_se,
        intercept_se,
        r,
        n,
    })
}

/// Two-sided 95 % quantile of Student's t with `dof` degrees of freedom (t such that
/// P(T ≤ t) = 0.975). Infinite for dof = 0.
pub fn student_t_975(dof: usize) -> f64 {
    // Exact values for small dof, where the asymptotic series below is not accurate enough.
    const TABLE: [f64; 30] = [
        12.706204736174707,
        4.302652729749464,
        3.182446305284263,
        2.7764451051977934,
        2.570581835636314,
        2.4469118511449666,
        2.3646242515927853,
        2.306004135204168,
        2.2621571628540993,
        2.2281388519862744,
        2.200985160082949,
        2.1788128296672284,
        2.1603686564627926,
        2.1447866879178044,
        2.131449545559323,
        2.1199052992210112,
        2.1098155778333156,
        2.100922040241036,
        2.093024054408263,
        2.0859634472658364,
        2.079613844727662,
        2.0738730679040147,
        2.0686576104190406,
        2.0638985616280205,
        2.059538552753294,
        2.055529438642871,
        2.0518305164802833,
        2.048407141795244,
        2.045229642132703,
        2.0422724563012373,
    ];
    match dof {
        0 => f64::INFINITY,
        1..=30 => TABLE[dof - 1],
        _ => {
            // Cornish–Fisher expansion of the t quantile around the normal one (Abramowitz &
            // Stegun 26.7.5); with five terms it is good to ~1e-8 for dof > 30.
            let z: f64 = 1.959_963_984_540_054;
            let v = dof as f64;
            let (z3, z5, z7, z9) = (z.powi(3), z.powi(5), z.powi(7), z.powi(9));
            z + (z3 + z) / (4.0 * v)
                + (5.0 * z5 + 16.0 * z3 + 3.0 * z) / (96.0 * v * v)
                + (3.0 * z7 + 19.0 * z5 + 17.0 * z3 - 15.0 * z) / (384.0 * v.powi(3))
                + (79.0 * z9 + 776.0 * z7 + 1482.0 * z5 - 1920.0 * z3 - 945.0 * z)
                    / (92160.0 * v.powi(4))
        }
    }
}

/// Mean of `samples` and the half-width of its 95 % confidence interval, t_{n−1} s / √n.
///
/// None for fewer than 2 samples (no spread to estimate) or a non-finite sample.
pub fn mean_ci95(samples: &[f64]) -> Option<(f64, f64)> {
    let n = samples.len();
    if n < 2 || samples.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let nf = n as f64;
    let mean = samples.iter().sum::<f64>() / nf;
    let var = samples.iter().map(|s| (s - mean).powi(2)).sum::<f64>() / (nf - 1.0);
    Some((mean, student_t_975(n - 1) * (var / nf).sqrt()))
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

fn rms_residual(x: &[f64], y: &[f64], model: impl Fn(f64) -> f64) -> f64 {
    let ss: f64 = x
        .iter()
        .zip(y)
        .map(|(&xi, &yi)| (yi - model(xi)).powi(2))
        .sum();
    (ss / x.len() as f64).sqrt()
}

/// Minimises `f` on [lo, hi]: the best of `points` log-spaced grid values, then golden section
/// between its neighbours. None when `f` is infinite everywhere on the grid.
fn grid_then_golden(f: impl Fn(f64) -> f64, lo: f64, hi: f64, points: usize) -> Option<f64> {
    let step = (hi - lo) / (points - 1) as f64;
    let (best, best_val) = (0..points).map(|i| (i, f(lo + step * i as f64))).fold(
        (0, f64::INFINITY),
        |acc, (i, v)| if v < acc.1 { (i, v) } else { acc },
    );
    if !best_val.is_finite() {
        return None;
    }
    let a = lo + step * best.saturating_sub(1) as f64;
    let b = lo + step * (best + 1).min(points - 1) as f64;
    Some(golden_min(&f, a, b, 1e-12))
}

/// Golden-section minimisation of a unimodal `f` on [a, b], to an interval width of
/// `tol` · (1 + |x|).
fn golden_min(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64, tol: f64) -> f64 {
    let inv_phi = (5f64.sqrt() - 1.0) / 2.0;
    let mut c = b - inv_phi * (b - a);
    let mut d = a + inv_phi * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..200 {
        if (b - a).abs() <= tol * (1.0 + c.abs()) {
            break;
        }
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - inv_phi * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + inv_phi * (b - a);
            fd = f(d);
        }
    }
    if fc < fd {
        c
    } else {
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic normal deviates (SplitMix64 + Box–Muller), so Monte-Carlo checks are stable.
    struct Normal(u64);
    impl Normal {
        fn uniform(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        }
        fn sample(&mut self) -> f64 {
            let (u1, u2) = (self.uniform(), self.uniform());
            (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
        }
    }

    fn rel(a: f64, b: f64) -> f64 {
        ((a - b) / b).abs()
    }

    /// ln Γ(x) for x > 0 (Lanczos, g = 7), to build the t density independently of the table.
    fn ln_gamma(x: f64) -> f64 {
        const C: [f64; 9] = [
            0.999_999_999_999_809_9,
            676.520_368_121_885_1,
            -1_259.139_216_722_402_8,
            771.323_428_777_653_1,
            -176.615_029_162_140_6,
            12.507_343_278_686_905,
            -0.138_571_095_265_720_12,
            9.984_369_578_019_572e-6,
            1.505_632_735_149_311_6e-7,
        ];
        let x = x - 1.0;
        let t = x + 7.5;
        let s: f64 = C[0] + (1..9).map(|i| C[i] / (x + i as f64)).sum::<f64>();
        0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + s.ln()
    }

    /// P(T ≤ t) for Student's t by Simpson integration of the density from 0.
    fn t_cdf(t: f64, dof: usize) -> f64 {
        let v = dof as f64;
        let norm = (ln_gamma((v + 1.0) / 2.0) - ln_gamma(v / 2.0)).exp()
            / (v * std::f64::consts::PI).sqrt();
        let pdf = |x: f64| norm * (1.0 + x * x / v).powf(-(v + 1.0) / 2.0);
        let m = 20_000;
        let h = t / m as f64;
        let mut s = pdf(0.0) + pdf(t);
        for i in 1..m {
            s += if i % 2 == 1 { 4.0 } else { 2.0 } * pdf(i as f64 * h);
        }
        0.5 + s * h / 3.0
    }

    #[test]
    fn linear_fit_recovers_exact_line() {
        let x: Vec<f64> = (0..10).map(|i| 0.5 + i as f64).collect();
        let y: Vec<f64> = x.iter().map(|x| 3.0 * x - 2.0).collect();
        let f = linear_fit(&x, &y).expect("fit");
        assert!((f.slope - 3.0).abs() < 1e-12, "{f:?}");
        assert!((f.intercept + 2.0).abs() < 1e-12, "{f:?}");
        assert!(f.slope_se < 1e-12 && f.intercept_se < 1e-12, "{f:?}");
        assert!((f.r - 1.0).abs() < 1e-12 && f.n == 10, "{f:?}");
        let down: Vec<f64> = x.iter().map(|x| 1.0 - x).collect();
        assert!((linear_fit(&x, &down).expect("fit").r + 1.0).abs() < 1e-12);
    }

    #[test]
    fn linear_fit_rejects_degenerate_input() {
        assert!(linear_fit(&[1.0, 1.0, 1.0], &[1.0, 2.0, 3.0]).is_none());
        assert!(linear_fit(&[1.0, 2.0], &[1.0]).is_none());
        assert!(linear_fit(&[1.0], &[1.0]).is_none());
        assert!(linear_fit(&[1.0, 2.0, f64::NAN], &[1.0, 2.0, 3.0]).is_none());
        let two = linear_fit(&[1.0, 2.0], &[1.0, 3.0]).expect("two points");
        assert!((two.slope - 2.0).abs() < 1e-12 && two.slope_se.is_nan());
    }

    /// With Gaussian noise of known σ, the reported standard errors must match the spread of
    /// the estimates over many data sets, and slope ± t·se must cover the truth ~95 % of the time.
    #[test]
    fn linear_fit_standard_errors_are_calibrated() {
        let mut rng = Normal(42);
        let x: Vec<f64> = (0..8).map(|i| i as f64 * 0.7).collect();
        let (trials, sigma) = (4000, 0.3);
        let (mut slopes, mut intercepts, mut covered) = (Vec::new(), Vec::new(), 0);
        let (mut se_s2, mut se_i2) = (0.0, 0.0);
        for _ in 0..trials {
            let y: Vec<f64> = x
                .iter()
                .map(|x| 1.5 * x + 4.0 + sigma * rng.sample())
                .collect();
            let f = linear_fit(&x, &y).expect("fit");
            slopes.push(f.slope);
            intercepts.push(f.intercept);
            se_s2 += f.slope_se.powi(2) / trials as f64;
            se_i2 += f.intercept_se.powi(2) / trials as f64;
            if (f.slope - 1.5).abs() <= student_t_975(x.len() - 2) * f.slope_se {
                covered += 1;
            }
        }
        let var = |v: &[f64]| {
            let m = v.iter().sum::<f64>() / v.len() as f64;
            v.iter().map(|a| (a - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64
        };
        assert!(
            rel(se_s2, var(&slopes)) < 0.08,
            "{se_s2} vs {}",
            var(&slopes)
        );
        assert!(
            rel(se_i2, var(&intercepts)) < 0.08,
            "{se_i2} vs {}",
            var(&intercepts)
        );
        let coverage = covered as f64 / trials as f64;
        assert!((coverage - 0.95).abs() < 0.015, "coverage {coverage}");
    }

    /// The quantile must put 97.5 % of an independently integrated t density below it, for the
    /// table (dof ≤ 30) and the asymptotic series alike.
    #[test]
    fn student_t_975_matches_integrated_density() {
        for dof in (1..=40).chain([50, 75, 100, 200, 500]) {
            let t = student_t_975(dof);
            let p = t_cdf(t, dof);
            assert!((p - 0.975).abs() < 2e-7, "dof {dof}: t {t}, cdf {p}");
        }
        assert!(student_t_975(0).is_infinite());
        assert!((student_t_975(1_000_000) - 1.959_964).abs() < 1e-5);
        assert!((student_t_975(1) - (0.475 * std::f64::consts::PI).tan()).abs() < 1e-9);
    }

    #[test]
    fn mean_ci95_known_values_and_coverage() {
        let (m, hw) = mean_ci95(&[1.0, 2.0, 3.0, 4.0, 5.0]).expect("ci");
        assert!((m - 3.0).abs() < 1e-12);
        // s = sqrt(2.5), t_4 = 2.7764451
        assert!((hw - 2.776_445_105_197_793 * 2.5f64.sqrt() / 5f64.sqrt()).abs() < 1e-12);
        assert!(mean_ci95(&[1.0]).is_none() && mean_ci95(&[]).is_none());

        let mut rng = Normal(7);
        let trials = 4000;
        let covered = (0..trials)
            .filter(|_| {
                let s: Vec<f64> = (0..4).map(|_| 10.0 + 2.0 * rng.sample()).collect();
                let (m, hw) = mean_ci95(&s).expect("ci");
                (m - 10.0).abs() <= hw
            })
            .count();
        let coverage = covered as f64 / trials as f64;
        assert!((coverage - 0.95).abs() < 0.015, "coverage {coverage}");
    }

    // Paper-like values: D from 11.8 to 48 mm, D_min = α2 ln α1 ≈ 8.3 mm.
    const C: f64 = 2900.0;
    const A1: f64 = 4.0;
    const A2: f64 = 0.006;
    fn janda(d: f64) -> f64 {
        C * (1.0 - A1 * (-d / A2).exp()) * d.powf(2.5)
    }
    fn orifices() -> Vec<f64> {
        vec![0.0118, 0.016, 0.02, 0.024, 0.028, 0.036, 0.042, 0.048]
    }

    #[test]
    fn janda_fit_recovers_generating_parameters() {
        let d = orifices();
        let q: Vec<f64> = d.iter().map(|&d| janda(d)).collect();
        let f = janda_fit(&d, &q, None).expect("fit");
        assert!(rel(f.c, C) < 1e-4, "{f:?}");
        assert!(rel(f.alpha1, A1) < 1e-4, "{f:?}");
        assert!(rel(f.alpha2_m, A2) < 1e-4, "{f:?}");
        let d_min = f.d_min_m.expect("α1 > 0");
        assert!(rel(d_min, A2 * A1.ln()) < 1e-4, "{f:?}");
        assert!(f.rms_residual_kg_per_s < 1e-6 * q[q.len() - 1], "{f:?}");
        assert!(rel(f.predict(0.03), janda(0.03)) < 1e-6);
        assert!(!f.alpha2_at_bound, "{f:?}");

        // Exactly three points still determine the three parameters.
        let three = janda_fit(&d[..3], &q[..3], None).expect("three points");
        assert!(rel(three.alpha2_m, A2) < 1e-3, "{three:?}");
        assert!(janda_fit(&d[..2], &q[..2], None).is_none());
    }

    /// Data made with α1 = 1 and α2 = 10 m, far beyond the search range (100 D_max = 4.8 m):
    /// Q ≈ C D^{7/2} / α2, which any large enough α2 fits. The search ends at its bound and
    /// says so.
    #[test]
    fn janda_fit_flags_an_alpha2_beyond_its_search_range() {
        let d = orifices();
        let q: Vec<f64> = d
            .iter()
            .map(|&d| C * (1.0 - (-d / 10.0).exp()) * d.powf(2.5))
            .collect();
        let f = janda_fit(&d, &q, None).expect("fit");
        assert!(f.alpha2_at_bound, "{f:?}");
        assert!(rel(f.alpha2_m, 100.0 * 0.048) < 1e-2, "{f:?}");
    }

    /// A zero weight must remove a corrupted point entirely; with equal weights it biases the fit.
    #[test]
    fn janda_fit_weights_exclude_outlier() {
        let d = orifices();
        let mut q: Vec<f64> = d.iter().map(|&d| janda(d)).collect();
        q[2] *= 1.3;
        let mut w = vec![1.0; d.len()];
        w[2] = 0.0;
        let f = janda_fit(&d, &q, Some(&w)).expect("weighted fit");
        assert!(
            rel(f.alpha1, A1) < 1e-4 && rel(f.alpha2_m, A2) < 1e-4,
            "{f:?}"
        );
        let biased = janda_fit(&d, &q, None).expect("unweighted fit");
        assert!(rel(biased.alpha2_m, A2) > 1e-2, "{biased:?}");
        assert!(janda_fit(&d, &q, Some(&w[..3])).is_none());
    }

    /// With 1 % multiplicative noise the fit must stay close to the law and not run to a bound.
    #[test]
    fn janda_fit_noisy_data_stays_near_truth() {
        let mut rng = Normal(3);
        let d: Vec<f64> = (0..15).map(|i| 0.0118 + 0.0026 * i as f64).collect();
        let q: Vec<f64> = d
            .iter()
            .map(|&d| janda(d) * (1.0 + 0.01 * rng.sample()))
            .collect();
        let f = janda_fit(&d, &q, None).expect("fit");
        assert!(rel(f.c, C) < 0.05, "{f:?}");
        let d_min = f.d_min_m.expect("α1 > 0");
        assert!((d_min - A2 * A1.ln()).abs() < 1.5e-3, "{f:?}");
    }

    #[test]
    fn beverloo_fit_recovers_c_and_k() {
        let (c, k, pd, rho, g): (f64, f64, f64, f64, f64) = (0.58, 1.5, 0.0058, 1600.0, 9.81);
        let d = orifices();
        let q: Vec<f64> = d
            .iter()
            .map(|&d| c * rho * g.sqrt() * (d - k * pd).powf(2.5))
            .collect();
        let f = beverloo_fit(&d, &q, pd, rho, g).expect("fit");
        assert!(rel(f.c, c) < 1e-6 && rel(f.k, k) < 1e-6, "{f:?}");
        assert!(
            rel(
                f.predict(0.03, pd, rho, g),
                q[0].max(0.0) * 0.0 + c * rho * g.sqrt() * (0.03 - k * pd).powf(2.5)
            ) < 1e-6
        );
        assert!(beverloo_fit(&d[..2], &q[..2], pd, rho, g).is_none());
        assert!(beverloo_fit(&d, &q, 0.0, rho, g).is_none());

        // Non-uniform error: the refinement in Q space must not move k away from the truth
        // by more than the linearised fit does.
        let noisy: Vec<f64> = q
            .iter()
            .enumerate()
            .map(|(i, q)| q * (1.0 + 0.002 * (i as f64 - 3.5)))
            .collect();
        let f = beverloo_fit(&d, &noisy, pd, rho, g).expect("fit");
        assert!((f.k - k).abs() < 0.1 && rel(f.c, c) < 0.02, "{f:?}");
    }
}
