//! A standardised PDF, (x − mean)/std histogrammed and normalised, built from a stream in
//! bounded memory (chute paper Fig. 5: v_z PDFs per block).
//!
//! Standardising needs the final mean and std, which a stream only knows at its end. So: the
//! first `WARMUP_VALUES` values are kept; then a fine histogram of the raw values is fixed,
//! centred on the warm-up mean, `FINE_HALF_RANGE_STD` warm-up standard deviations each side, in
//! bins of 1/`FINE_BINS_PER_STD` of one, and the kept values go into it. At the end each fine bin
//! is spread over the standardised bins in proportion to overlap (uniform within a fine bin).
//! Memory: the warm-up buffer until it fills, then a fixed 480 counters.
//!
//! What this costs: the standardised bins are resolved to one fine bin (0.05 σ_warm, against
//! bins of 0.25 σ by default); values beyond ±12 σ_warm are only counted (`outside`), and if the
//! final std exceeded the warm-up one by more than 2.4× the outer standardised bins would lose
//! mass. In a steady chute the warm-up (the first snapshots' ~10⁴ values of a block) and the final
//! std agree to a few per cent. Until the buffer fills, the PDF is exact.

use serde::{Deserialize, Serialize};

/// Values kept before the fine histogram is laid out.
pub const WARMUP_VALUES: usize = 10_000;
/// Fine bins per warm-up standard deviation.
pub const FINE_BINS_PER_STD: f64 = 20.0;
/// Half-width of the fine histogram, in warm-up standard deviations.
pub const FINE_HALF_RANGE_STD: f64 = 12.0;

/// The fine raw-value histogram laid out after the warm-up.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct FineHistogram {
    lo: f64,
    width: f64,
    counts: Vec<u64>,
    outside: u64,
}

/// Streaming standardised PDF of one quantity (checkpointed with its observer).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StandardisedPdf {
    warmup: Vec<f64>,
    fine: Option<FineHistogram>,
    n: u64,
}

impl StandardisedPdf {
    /// Adds one value.
    pub fn add(&mut self, x: f64) {
        self.n += 1;
        match &mut self.fine {
            Some(h) => h.add(x),
            None => {
                self.warmup.push(x);
                if self.warmup.len() >= WARMUP_VALUES {
                    self.lay_out_fine();
                }
            }
        }
    }

    /// Values added.
    pub fn count(&self) -> u64 {
        self.n
    }

    /// Values beyond the fine histogram (counted in the normalisation, placed in no bin).
    pub fn outside(&self) -> u64 {
        self.fine.as_ref().map_or(0, |h| h.outside)
    }

    fn lay_out_fine(&mut self) {
        let n = self.warmup.len() as f64;
        let mean = self.warmup.iter().sum::<f64>() / n;
        let std = (self.warmup.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt();
        // A constant warm-up has no scale; take a tiny one rather than none.
        let std = if std > 0.0 {
            std
        } else {
            1e-12 * mean.abs().max(1.0)
        };
        let bins = (2.0 * FINE_HALF_RANGE_STD * FINE_BINS_PER_STD).round() as usize;
        let mut h = FineHistogram {
            lo: mean - FINE_HALF_RANGE_STD * std,
            width: std / FINE_BINS_PER_STD,
            counts: vec![0; bins],
            outside: 0,
        };
        for &x in &self.warmup {
            h.add(x);
        }
        self.warmup = Vec::new();
        self.fine = Some(h);
    }

    /// The PDF of (x − mean)/std in bins of `bin_std` from −`half_range_std` to +`half_range_std`:
    /// (bin centre, density), density = values in the bin / (all values × bin width), so the
    /// area is the fraction of values within the range (≈ 1; the PDF stays comparable with a
    /// unit Gaussian). `mean` and `std` are the stream's final moments. Empty when std ≤ 0 or no
    /// value was added.
    pub fn standardised(
        &self,
        mean: f64,
        std: f64,
        bin_std: f64,
        half_range_std: f64,
    ) -> Vec<(f64, f64)> {
        let bins = (2.0 * half_range_std / bin_std).round() as usize;
        if !(std > 0.0) || self.n == 0 || bins == 0 {
            return Vec::new();
        }
        let mut mass = vec![0.0; bins];
        let edge = |s: f64| (s + half_range_std) / bin_std;
        // Spreads `count` uniformly over the standardised interval [s0, s1].
        let mut spread = |s0: f64, s1: f64, count: f64| {
            let (b0, b1) = (edge(s0), edge(s1));
            if b1 <= 0.0 || b0 >= bins as f64 {
                return;
            }
            if b1 <= b0 {
                mass[b0.floor() as usize] += count;
                return;
            }
            let first = b0.floor().max(0.0) as usize;
            let last = (b1.ceil() as usize).min(bins);
            for (b, m) in mass.iter_mut().enumerate().take(last).skip(first) {
                let overlap = b1.min(b as f64 + 1.0) - b0.max(b as f64);
                if overlap > 0.0 {
                    *m += count * overlap / (b1 - b0);
                }
            }
        };
        match &self.fine {
            None => {
                for &x in &self.warmup {
                    let s = (x - mean) / std;
                    spread(s, s, 1.0);
                }
            }
            Some(h) => {
                for (j, &c) in h.counts.iter().enumerate() {
                    if c > 0 {
                        let a = h.lo + j as f64 * h.width;
                        spread((a - mean) / std, (a + h.width - mean) / std, c as f64);
                    }
                }
            }
        }
        let norm = 1.0 / (self.n as f64 * bin_std);
        mass.iter()
            .enumerate()
            .map(|(b, m)| (-half_range_std + (b as f64 + 0.5) * bin_std, m * norm))
            .collect()
    }
}

impl FineHistogram {
    fn add(&mut self, x: f64) {
        let j = ((x - self.lo) / self.width).floor();
        if j >= 0.0 && j < self.counts.len() as f64 {
            self.counts[j as usize] += 1;
        } else {
            self.outside += 1;
        }
    }
}
