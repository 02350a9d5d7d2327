//! Uncertainty of a flow-rate fit by bootstrap: the points are redrawn many times, the law
//! fitted to each draw, and the 2.5 and 97.5 percentiles of each parameter taken as its 95 %
//! interval. A point with ≥ 2 replicas is redrawn from its replicas (with replacement, their
//! mean then fitted); a point with one run from a normal of its own 95 % CI (the block
//! statistics of that run). The generator is seeded, so a figure redrawn gives the same
//! intervals. Janda's law and Beverloo's share it.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Bootstrap draws per fit: enough for stable 2.5 / 97.5 percentiles at a figure's precision.
pub const BOOTSTRAP_DRAWS: usize = 400;

/// One point of a flow-rate fit (Janda's or Beverloo's): orifice D (m), flow rate Q (kg/s), the replicas' own Q, the half-width
/// of Q's 95 % CI (kg/s).
#[derive(Debug, Clone)]
pub struct JandaPoint {
    pub d_m: f64,
    pub q: f64,
    pub replica_q: Vec<f64>,
    pub ci95: Option<f64>,
}

/// The fits of [`BOOTSTRAP_DRAWS`] redrawn sets of `points` (a draw `fit` rejects is left
/// out), the generator seeded by `seed`.
pub(super) fn fitted_draws<T>(
    points: &[JandaPoint],
    seed: u64,
    mut fit: impl FnMut(&[f64]) -> Option<T>,
) -> Vec<T> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut fits = Vec::with_capacity(BOOTSTRAP_DRAWS);
    for _ in 0..BOOTSTRAP_DRAWS {
        let q: Vec<f64> = points.iter().map(|p| redraw(p, &mut rng)).collect();
        if let Some(f) = fit(&q) {
            fits.push(f);
        }
    }
    fits
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
pub(super) fn percentiles(mut v: Vec<f64>) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    let at = |p: f64| v[((p * (v.len() - 1) as f64).round() as usize).min(v.len() - 1)];
    (at(0.025), at(0.975))
}
