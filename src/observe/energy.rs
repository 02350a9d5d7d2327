//! The kinetic energy of a run over its measurement window, streamed: its mean and its linear
//! trend (least-squares slope), what the accuracy–cost map compares between numerical settings.
//!
//! A dissipative granular flow conserves no energy, so "energy drift" here is the trend of the
//! kinetic energy in a window where the flow should be steady: a run whose integration is off
//! (too large a dt, too soft a contact) heats or cools and shows it as a slope, and its mean
//! differs from the reference's. The integrator's drift proper is measured on an elastic gas in
//! the validation tests.

use serde::{Deserialize, Serialize};

/// Running sums for the mean and the least-squares line E(t) = a + b t.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct EnergyTrend {
    pub samples: u64,
    pub t_first_s: f64,
    pub t_last_s: f64,
    sum_t: f64,
    sum_e: f64,
    sum_tt: f64,
    sum_te: f64,
}

impl EnergyTrend {
    /// Adds the kinetic energy `e` (J) at time `t` (s).
    pub fn add(&mut self, t: f64, e: f64) {
        if self.samples == 0 {
            self.t_first_s = t;
        }
        self.t_last_s = t;
        // Times relative to the first sample keep the sums well conditioned.
        let u = t - self.t_first_s;
        self.samples += 1;
        self.sum_t += u;
        self.sum_e += e;
        self.sum_tt += u * u;
        self.sum_te += u * e;
    }

    /// Mean kinetic energy (J); None before the first sample.
    pub fn mean_j(&self) -> Option<f64> {
        (self.samples > 0).then(|| self.sum_e / self.samples as f64)
    }

    /// Least-squares slope dE/dt (J/s); None with fewer than 3 samples.
    pub fn slope_j_per_s(&self) -> Option<f64> {
        if self.samples < 3 {
            return None;
        }
        let n = self.samples as f64;
        let var = self.sum_tt - self.sum_t * self.sum_t / n;
        (var > 0.0).then(|| (self.sum_te - self.sum_t * self.sum_e / n) / var)
    }

    /// The slope relative to the mean (1/s): the fraction of its kinetic energy the flow gains
    /// (> 0) or loses per second.
    pub fn relative_drift_per_s(&self) -> Option<f64> {
        let (m, b) = (self.mean_j()?, self.slope_j_per_s()?);
        (m > 0.0).then(|| b / m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_line_and_a_constant() {
        let mut t = EnergyTrend::default();
        for k in 0..101 {
            let time = 10.0 + 0.05 * k as f64;
            t.add(time, 2.0 + 0.3 * (time - 10.0));
        }
        // E = 2 + 0.3 u over u in [0, 5]: mean 2.75, slope 0.3 (exact up to rounding).
        assert!((t.mean_j().unwrap() - 2.75).abs() < 1e-12);
        assert!((t.slope_j_per_s().unwrap() - 0.3).abs() < 1e-12);
        assert!((t.relative_drift_per_s().unwrap() - 0.3 / 2.75).abs() < 1e-12);
        let mut c = EnergyTrend::default();
        for k in 0..10 {
            c.add(k as f64, 5.0);
        }
        assert_eq!(c.slope_j_per_s(), Some(0.0));
        assert_eq!(EnergyTrend::default().mean_j(), None);
    }
}
