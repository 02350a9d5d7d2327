//! Is a correlated time series free of a trend? The test behind the chute's steady state.
//!
//! Successive samples of a granular flow's kinetic energy or mean velocity are correlated over
//! many samples, so the least-squares slope's textbook error (independent residuals) is far too
//! small. The series is cut into `batches` consecutive batches of equal duration; when a batch
//! is long against the correlation time the batch means are nearly independent, and the line
//! through them gives the trend with an honest standard error (the batch-means method).
//!
//! A series passes when its trend is zero both
//! - within the tolerance: |slope| · T / |mean| ≤ `tol` (T the window's span), and
//! - within its own statistical error: |slope| ≤ t₀.₉₇₅(B − 2) · se(slope), B the batches.
//!
//! The first alone passes a noisy series that drifts; the second alone fails a steady flow whose
//! tiny, real fluctuations are well resolved in a long window. Passing is the strict reading,
//! for deciding that a transient has ended; [`Trend::drifts`] is the lenient one, for deciding
//! that a measured window must be discarded: a trend both beyond the tolerance and significant.

use serde::{Deserialize, Serialize};

use super::fits::{linear_fit, student_t_975};

/// The trend of one series over one window.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Trend {
    /// Mean of the samples.
    pub mean: f64,
    /// |slope| · T / |mean|: the relative change the trend makes over the window.
    pub relative_change: f64,
    /// |slope| / se(slope), the trend in units of its batch-means standard error.
    pub t_statistic: f64,
    /// t₀.₉₇₅ with B − 2 degrees of freedom: the largest `t_statistic` taken as no trend.
    pub t_critical: f64,
    /// Whether both criteria hold.
    pub passed: bool,
}

impl Trend {
    /// Whether the trend is a drift: beyond `tol` and beyond its batch-means error. A small,
    /// well-resolved trend is no drift, and neither is a large one that the series' own slow
    /// fluctuations could make.
    pub fn drifts(&self, tol: f64) -> bool {
        is_drift(self.relative_change, self.t_statistic, self.t_critical, tol)
    }
}

/// [`Trend::drifts`] on a trend's numbers (as `chute_stationarity` stores them).
pub fn is_drift(relative_change: f64, t_statistic: f64, t_critical: f64, tol: f64) -> bool {
    relative_change > tol && t_statistic > t_critical
}

/// Fewest batches the test accepts: three leave a single degree of freedom.
pub const MIN_BATCHES: usize = 4;

/// Tests (`t`, `y`) (times increasing) for a trend, with `batches` batch means and relative
/// tolerance `tol`. None when there are fewer than two samples per batch, fewer than
/// [`MIN_BATCHES`] batches, the times span nothing, or the mean is zero.
pub fn trend(t: &[f64], y: &[f64], batches: usize, tol: f64) -> Option<Trend> {
    let n = t.len();
    if n != y.len() || batches < MIN_BATCHES || n < 2 * batches {
        return None;
    }
    let (t0, t1) = (t[0], t[n - 1]);
    let span = t1 - t0;
    if !(span > 0.0) {
        return None;
    }
    // Batches of equal duration (samples may be unevenly spaced after a resume or a change of
    // sampling); an empty batch fails the test rather than being skipped.
    let mut sum = vec![(0.0, 0.0, 0usize); batches];
    for (&ti, &yi) in t.iter().zip(y) {
        let k = (((ti - t0) / span * batches as f64) as usize).min(batches - 1);
        sum[k].0 += ti;
        sum[k].1 += yi;
        sum[k].2 += 1;
    }
    if sum.iter().any(|b| b.2 == 0) {
        return None;
    }
    let (bt, by): (Vec<f64>, Vec<f64>) = sum
        .iter()
        .map(|&(st, sy, c)| (st / c as f64, sy / c as f64))
        .unzip();
    let fit = linear_fit(&bt, &by)?;
    let mean = y.iter().sum::<f64>() / n as f64;
    if mean == 0.0 || !mean.is_finite() {
        return None;
    }
    let relative_change = (fit.slope * span / mean).abs();
    let t_statistic = if fit.slope_se > 0.0 {
        fit.slope.abs() / fit.slope_se
    } else if fit.slope == 0.0 {
        0.0
    } else {
        f64::INFINITY
    };
    let t_critical = student_t_975(batches - 2);
    Some(Trend {
        mean,
        relative_change,
        t_statistic,
        t_critical,
        passed: relative_change <= tol && t_statistic <= t_critical,
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_chute_checks_the_same_fewest_batches() {
        assert_eq!(super::MIN_BATCHES, crate::scene::chute::MIN_STEADY_BATCHES);
    }

    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// An AR(1) series (correlation time ~ 1 / (1 − φ) samples) around `level + slope · t`.
    fn correlated(n: usize, phi: f64, level: f64, slope: f64, noise: f64, seed: u64) -> Vec<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut x = 0.0;
        (0..n)
            .map(|i| {
                // Uniform noise with unit variance, scaled so the stationary variance is noise².
                let u: f64 = (rng.random::<f64>() - 0.5) * 12f64.sqrt();
                x = phi * x + (1.0 - phi * phi).sqrt() * noise * u;
                level + slope * i as f64 + x
            })
            .collect()
    }

    fn times(n: usize) -> Vec<f64> {
        (0..n).map(|i| i as f64).collect()
    }

    #[test]
    fn a_line_is_a_trend_and_a_constant_is_not() {
        let t = times(100);
        let line: Vec<f64> = t.iter().map(|x| 10.0 + 0.01 * x).collect();
        let r = trend(&t, &line, 10, 0.02).unwrap();
        // Slope 0.01 over a span of 99 around a mean of 10.495: 9.4 % change.
        assert!((r.relative_change - 0.01 * 99.0 / 10.495).abs() < 1e-9);
        assert!(!r.passed);
        let flat = vec![3.0; 100];
        let r = trend(&t, &flat, 10, 0.02).unwrap();
        assert!(r.passed && r.relative_change == 0.0 && r.t_statistic == 0.0);
    }

    #[test]
    fn correlated_noise_without_trend_passes_at_the_stated_rate() {
        // 200 stationary series, correlation time ~20 samples, batches of 100 samples: the test
        // must reject about 5 % (the t quantile's level), not the ~50 % a test on raw samples
        // would reject. Allow 1–12 %: a binomial 95 % range for 200 tries at 5 % is 2–9 %.
        let t = times(1000);
        let rejected = (0..200)
            .filter(|&s| {
                let y = correlated(1000, 0.95, 100.0, 0.0, 1.0, s);
                !trend(&t, &y, 10, 0.02).unwrap().passed
            })
            .count();
        assert!((2..=24).contains(&rejected), "rejected {rejected} of 200");
    }

    #[test]
    fn a_drift_hidden_in_correlated_noise_is_caught() {
        // A 1 % rise over the window (inside a 2 % tolerance) that is 10 standard errors: the
        // statistical criterion fails it.
        let t = times(1000);
        let y = correlated(1000, 0.95, 100.0, 1.0 / 1000.0, 0.1, 7);
        let r = trend(&t, &y, 10, 0.02).unwrap();
        assert!(r.relative_change < 0.02 && r.t_statistic > r.t_critical && !r.passed);
        // A 5 % rise buried in large noise: the tolerance criterion fails it.
        let y = correlated(1000, 0.95, 100.0, 5.0 / 1000.0, 20.0, 8);
        let r = trend(&t, &y, 10, 0.02).unwrap();
        assert!(r.relative_change > 0.02 && !r.passed, "{r:?}");
    }

    #[test]
    fn too_few_samples_or_batches_say_so() {
        let t = times(10);
        let y = vec![1.0; 10];
        assert!(trend(&t, &y, 10, 0.02).is_none());
        assert!(trend(&t, &y, 3, 0.02).is_none());
        assert!(trend(&t, &[0.0; 10], 4, 0.02).is_none());
        assert!(trend(&t, &y, 4, 0.02).is_some());
    }
}
