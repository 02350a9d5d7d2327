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
    let norm =
        (ln_gamma((v + 1.0) / 2.0) - ln_gamma(v / 2.0)).exp() / (v * std::f64::consts::PI).sqrt();
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

#[test]
fn beverloo_intervals_hold_the_law_and_widen_with_the_replicas_spread() {
    let (c, k, pd, rho, g): (f64, f64, f64, f64, f64) = (0.58, 1.5, 0.0058, 1600.0, 9.81);
    let law = |d: f64| c * rho * g.sqrt() * (d - k * pd).powf(2.5);
    let points = |spread: f64| -> Vec<JandaPoint> {
        orifices()
            .iter()
            .enumerate()
            .map(|(i, &d)| {
                // Replicas on either side of the law, by turns, so no draw is the law itself.
                let s = if i % 2 == 0 { spread } else { -spread };
                JandaPoint {
                    d_m: d,
                    q: law(d),
                    replica_q: vec![law(d) * (1.0 + s), law(d) * (1.0 - s)],
                    ci95: None,
                }
            })
            .collect()
    };
    let tight = beverloo_bootstrap(&points(0.005), pd, rho, g, 3).expect("intervals");
    let loose = beverloo_bootstrap(&points(0.05), pd, rho, g, 3).expect("intervals");
    for iv in [tight, loose] {
        assert!(
            iv.c.0 <= c && c <= iv.c.1 && iv.k.0 <= k && k <= iv.k.1,
            "{iv:?}"
        );
    }
    assert!(
        loose.k.1 - loose.k.0 > 3.0 * (tight.k.1 - tight.k.0),
        "{loose:?} {tight:?}"
    );
    let again = beverloo_bootstrap(&points(0.05), pd, rho, g, 3).expect("intervals");
    assert_eq!(
        (again.c, again.k),
        (loose.c, loose.k),
        "same seed, same draws"
    );
    assert!(beverloo_bootstrap(&points(0.05)[..2], pd, rho, g, 3).is_none());
}
