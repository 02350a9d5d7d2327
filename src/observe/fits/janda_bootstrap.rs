//! Uncertainty of the Janda fit by bootstrap (`bootstrap.rs`): C, α1, α2 and D_min, each with
//! its 95 % interval over the redrawn points.

use super::bootstrap::{fitted_draws, percentiles, JandaPoint, BOOTSTRAP_DRAWS};
use super::janda::{janda_fit, JandaFit};

/// The parameters of Eq. (1): C, α1, α2. A fit through this many points or fewer has no
/// degree of freedom left: it passes through them whatever the law, and proves nothing.
pub const JANDA_PARAMETERS: usize = 3;

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
    let fits: Vec<JandaFit> = fitted_draws(points, seed, |q| janda_fit(&d, q, w.as_deref()));
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
