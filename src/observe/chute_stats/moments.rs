//! Streaming mean, standard deviation and skewness (the third standardised moment of the v_z
//! PDFs, chute paper Fig. 5c), updated one value at a time with the centred recurrences of
//! Welford and Terriberry, which stay accurate when |mean| ≫ spread.

use serde::{Deserialize, Serialize};

/// Count, mean and centred power sums M2 = Σ(x − x̄)², M3 = Σ(x − x̄)³.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Moments {
    pub n: u64,
    pub mean: f64,
    pub m2: f64,
    pub m3: f64,
}

impl Moments {
    /// Adds one value.
    pub fn add(&mut self, x: f64) {
        let n1 = self.n as f64;
        self.n += 1;
        let n = self.n as f64;
        let delta = x - self.mean;
        let delta_n = delta / n;
        let term1 = delta * delta_n * n1;
        self.mean += delta_n;
        // NOTE: M3 before M2: its update uses the old M2.
        self.m3 += term1 * delta_n * (n - 2.0) - 3.0 * delta_n * self.m2;
        self.m2 += term1;
    }

    /// Population standard deviation √(M2/n); None for n < 2.
    pub fn std(&self) -> Option<f64> {
        (self.n >= 2).then(|| (self.m2 / self.n as f64).sqrt())
    }

    /// Skewness g1 = √n M3 / M2^{3/2} (the population form, consistent with `std`); None for
    /// n < 3 or zero spread.
    pub fn skewness(&self) -> Option<f64> {
        (self.n >= 3 && self.m2 > 0.0).then(|| (self.n as f64).sqrt() * self.m3 / self.m2.powf(1.5))
    }
}
