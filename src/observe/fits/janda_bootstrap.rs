//! Uncertainty of the Janda fit by bootstrap: the points are redrawn many times, the law fitted
//! to each draw, and the 2.5 and 97.5 percentiles of each parameter taken as its 95 % interval.
//! A point with ≥ 2 replicas is redrawn from its replicas (with replacement, their mean then
//! fitted); a point with one run from a normal of its own 95 % CI (the block statistics of that
//! run). The generator is seeded, so a figure redrawn gives the same intervals.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::janda::{janda_fit, JandaFit};

/// The parameters of Eq. (1): C, α1, α2. A fit through this many points or fewer has no
/// degree of freedom left: it passes through them whatever the law, and proves nothing.
pub const JANDA_PARAMETERS: usize = 3;

/// Bootstrap draws per fit: enough for stable 2.5 / 97.5 percentiles at a figure's precision.
pub const BOOTSTRAP_DRAWS: usize = 400;

/// One point of the fit: orifice D (m), flow rate Q (kg/s), the replicas' own Q, the half-width
/// of Q's 95 % CI (kg/s).
#[derive(Debug, Clone)]
pub struct JandaPoint {
    pub d_m: f64,
    pub q: f64,
    pub replica_q: Vec<f64>,
    pub ci95: Option<f64>,
}

/// 95 % intervals (2.5 and 97.5 percentiles over the draws) of the fitted parameters.
#[derive(Debug, Clone, Copy)]
pub struct JandaIntervals {
    pub c: (f64, f64),
    pub alpha1: (f64, f64),
    pub alpha2_m: (f64, f64),
    /// Over the draws with a D_min (α1 > 0); None when fewer than half had one.
    pub d_min_m: Option<(f64, f64)>,
    /// Draws fitted (a draw the law cannot fit is left out).
    pub draws: usize,
    /// Fraction of the fitted draws whose α2 ended at its search bound.
    pub alpha2_at_bound_fraction: f64,
}

/// The 95 % intervals of the Janda fit of `points` (weights 1/CI² as the fit itself when every
/// point has a positive CI), from [`BOOTSTRAP_DRAWS`] draws seeded by `seed`. None with fewer
/// than [`JANDA_PARAMETERS`] + 1 points (no degree of freedom: nothing to resample against) or
/// when fewer than half the draws can be fitted.
pub fn janda_bootstrap(points: &[JandaPoint], seed: u64) -> Option<JandaIntervals> {
    if points.len() <= JANDA_PARAMETERS {
        return None;
    }
    let d: Vec<f64> = points.iter().map(|p| p.d_m).collect();
    let w: Option<Vec<f64>> = points
        .iter()
        .map(|p| {
            p.ci95
                .filter(|c| c.is_finite() && *c > 0.0)
                .map(|c| 1.0 / (c * c))
        })
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut fits: Vec<JandaFit> = Vec::with_capacity(BOOTSTRAP_DRAWS);
    for _ in 0..BOOTSTRAP_DRAWS {
        let q: Vec<f64> = points.iter().map(|p| redraw(p, &mut rng)).collect();
        if let Some(f) = janda_fit(&d, &q, w.as_deref()) {
            fits.push(f);
        }
    }
    if fits.len() * 2 < BOOTSTRAP_DRAWS {
        return None;
    }
    let interval = |v: Vec<f64>| percentiles(v);
    let d_mins: Vec<f64> = fits.iter().filter_map(|f| f.d_min_m).collect();
    Some(JandaIntervals {
        c: interval(fits.iter().map(|f| f.c).collect()),
        alpha1: interval(fits.iter().map(|f| f.alpha1).collect()),
        alpha2_m: interval(fits.iter().map(|f| f.alpha2_m).collect()),
        d_min_m: (d_mins.len() * 2 >= fits.len()).then(|| interval(d_mins)),
        draws: fits.len(),
        alpha2_at_bound_fraction: fits.iter().filter(|f| f.alpha2_at_bound).count() as f64
            / fits.len() as f64,
    })
}

/// One bootstrap value of a point's Q: the mean of its replicas drawn with replacement, or with
/// one run a normal draw of standard deviation CI/1.96 (Q itself when it has no CI).
fn redraw(p: &JandaPoint, rng: &mut ChaCha8Rng) -> f64 {
    let n = p.replica_q.len();
    if n >= 2 {
        let sum: f64 = (0..n).map(|_| p.replica_q[rng.random_range(0..n)]).sum();
        return sum / n as f64;
    }
    match p.ci95.filter(|c| c.is_finite() && *c > 0.0) {
        Some(ci) => p.q + ci / 1.96 * standard_normal(rng),
        None => p.q,
    }
}

/// A standard normal deviate (Box–Muller; rand has no normal distribution without rand_distr).
fn standard_normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = 1.0 - rng.random::<f64>(); // (0, 1]: ln is finite
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// The 2.5 and 97.5 percentiles of `v` (nearest rank).
fn percentiles(mut v: Vec<f64>) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    let at = |p: f64| v[((p * (v.len() - 1) as f64).round() as usize).min(v.len() - 1)];
    (at(0.025), at(0.975))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn law(d: f64) -> f64 {
        2900.0 * (1.0 - 3.0 * (-d / 0.005).exp()) * d.powf(2.5)
    }

    fn points(n: usize, rel_ci: f64) -> Vec<JandaPoint> {
        (0..n)
            .map(|i| {
                let d = 0.012 + 0.004 * i as f64;
                JandaPoint {
                    d_m: d,
                    q: law(d),
                    replica_q: vec![law(d)],
                    ci95: Some(rel_ci * law(d)),
                }
            })
            .collect()
    }

    #[test]
    fn no_interval_without_a_degree_of_freedom() {
        assert!(janda_bootstrap(&points(3, 0.02), 7).is_none());
        assert!(janda_bootstrap(&points(6, 0.02), 7).is_some());
    }

    #[test]
    fn intervals_contain_the_law_widen_with_the_noise_and_repeat_with_the_seed() {
        let tight = janda_bootstrap(&points(7, 0.005), 7).expect("fit");
        let loose = janda_bootstrap(&points(7, 0.05), 7).expect("fit");
        let d_min_true = 0.005 * 3.0f64.ln();
        for iv in [tight, loose] {
            let (lo, hi) = iv.d_min_m.expect("D_min");
            assert!(lo <= d_min_true && d_min_true <= hi, "{iv:?}");
            assert!(iv.alpha1.0 <= 3.0 && 3.0 <= iv.alpha1.1, "{iv:?}");
        }
        let width = |iv: JandaIntervals| iv.d_min_m.map(|(a, b)| b - a).expect("D_min");
        assert!(width(loose) > 3.0 * width(tight), "{loose:?} {tight:?}");
        let again = janda_bootstrap(&points(7, 0.05), 7).expect("fit");
        assert_eq!(again.d_min_m, loose.d_min_m, "same seed, same draws");
    }

    #[test]
    fn replicas_are_resampled_when_present() {
        let mut pts = points(6, 0.0);
        for p in &mut pts {
            p.replica_q = vec![p.q * 0.9, p.q * 1.1];
            p.ci95 = None;
        }
        let iv = janda_bootstrap(&pts, 1).expect("fit");
        assert!(
            iv.c.1 > iv.c.0,
            "the replicas' spread gives a spread of C: {iv:?}"
        );
    }
}
