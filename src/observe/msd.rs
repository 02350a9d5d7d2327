//! Mean squared displacement in z per block of height, as a stream (chute paper §3):
//! MSD_k(τ) = ⟨(z_i(t + τ) − z_i(t))²⟩ over the (particle, origin) pairs whose mean height over
//! [t, t + τ] lies in block k, and the diffusion coefficient from MSD_z = 2 D τ + c.
//!
//! Memory is O(N·W): a ring of the last W = max_lag/Δ + 1 heights per particle. Each sample adds,
//! for every particle and every lag kΔ (k = 1..W−1), one squared displacement to the sum of the
//! block of the window's mean height; that mean comes from a running suffix sum of the ring,
//! built in the same loop. The trajectory itself is never stored. Lags are k·Δ, Δ being the
//! nominal sample interval: the caller samples at that interval.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::fits::linear_fit;

/// Streaming MSD_z per block (checkpointed with its observer).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BlockMsd {
    /// Sample interval Δ = lag resolution (s).
    interval_s: f64,
    /// Ring length W: lags 1..W−1 samples.
    window: usize,
    /// Height of the blocks (m).
    block_height_m: f64,
    /// Bottom of block 0 (m).
    z_base_m: f64,
    blocks: usize,
    /// Particle id → slot in the rings.
    slots: BTreeMap<u32, usize>,
    /// Slot s holds heights at ring[s W .. (s + 1) W], sample n at position n mod W.
    ring: Vec<f64>,
    /// Consecutive samples held per slot (≤ W).
    filled: Vec<usize>,
    /// Index of the last sample each slot was seen in.
    last_seen: Vec<u64>,
    /// Samples taken.
    samples: u64,
    /// Σ (Δz)² per block and lag: [block W + k].
    sum_sq: Vec<f64>,
    /// Pairs per block and lag.
    pairs: Vec<u64>,
    /// Pairs whose window mean lay outside every block.
    outside_pairs: u64,
}

/// MSD_z(τ) of one block: lags with at least one pair.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MsdCurve {
    pub block: usize,
    /// τ (s).
    pub lags_s: Vec<f64>,
    /// MSD_z (m²).
    pub msd_m2: Vec<f64>,
    /// (particle, origin) pairs averaged at each lag.
    pub pairs: Vec<u64>,
}

/// D from a straight line MSD_z = 2 D τ + c.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DiffusionFit {
    /// D (m²/s): half the slope.
    pub d: f64,
    /// Standard error of D from the least-squares residuals (m²/s). The MSD at different lags
    /// are correlated (they share displacements), so this understates the true uncertainty.
    pub stderr: f64,
    /// Correlation coefficient of the line.
    pub r: f64,
    /// Smallest and largest lag actually used (s).
    pub min_lag: f64,
    pub max_lag: f64,
    /// Lags used.
    pub points: usize,
}

impl BlockMsd {
    /// Blocks k = 0..blocks of height `block_height_m` above `z_base_m`; lags Δ..max_lag in
    /// steps of Δ = `interval_s`.
    ///
    /// # Panics
    /// Unless Δ > 0, max_lag ≥ Δ and the block height > 0 (the observer's settings guarantee it).
    pub fn new(
        interval_s: f64,
        max_lag_s: f64,
        block_height_m: f64,
        z_base_m: f64,
        blocks: usize,
    ) -> Self {
        assert!(interval_s > 0.0 && max_lag_s >= interval_s && block_height_m > 0.0);
        let window = (max_lag_s / interval_s).round() as usize + 1;
        Self {
            interval_s,
            window,
            block_height_m,
            z_base_m,
            blocks,
            slots: BTreeMap::new(),
            ring: Vec::new(),
            filled: Vec::new(),
            last_seen: Vec::new(),
            samples: 0,
            sum_sq: vec![0.0; blocks * window],
            pairs: vec![0; blocks * window],
            outside_pairs: 0,
        }
    }

    /// Adds one sample: particle `ids[i]` at height `z[i]` (m), in any order. A particle absent
    /// from the previous sample starts a new history (no displacement spans the gap).
    ///
    /// # Panics
    /// If the slices differ in length.
    pub fn add_sample(&mut self, ids: &[u32], z: &[f64]) {
        assert_eq!(ids.len(), z.len());
        let w = self.window;
        let n = self.samples;
        let head = (n % w as u64) as usize;
        for (&id, &zi) in ids.iter().zip(z) {
            let next = self.filled.len();
            let s = *self.slots.entry(id).or_insert(next);
            if s == next {
                self.ring.resize(self.ring.len() + w, 0.0);
                self.filled.push(0);
                self.last_seen.push(n);
            } else if self.last_seen[s] + 1 != n {
                self.filled[s] = 0;
            }
            self.last_seen[s] = n;
            let ring = &mut self.ring[s * w..(s + 1) * w];
            ring[head] = zi;
            self.filled[s] = (self.filled[s] + 1).min(w);
            // Walk back through the ring: lag k pairs z(t) with z(t − kΔ), and the running sum
            // holds the k + 1 heights of that window.
            let mut sum = zi;
            for k in 1..self.filled[s] {
                let old = ring[(head + w - k) % w];
                sum += old;
                let mean = sum / (k + 1) as f64;
                let block = ((mean - self.z_base_m) / self.block_height_m).floor();
                if block >= 0.0 && block < self.blocks as f64 {
                    let at = block as usize * w + k;
                    self.sum_sq[at] += (zi - old) * (zi - old);
                    self.pairs[at] += 1;
                } else {
                    self.outside_pairs += 1;
                }
            }
        }
        self.samples += 1;
    }

    /// Number of blocks.
    pub fn blocks(&self) -> usize {
        self.blocks
    }

    /// Samples taken so far.
    pub fn samples(&self) -> u64 {
        self.samples
    }

    /// Pairs whose window mean height fell below block 0 or above the last block.
    pub fn outside_pairs(&self) -> u64 {
        self.outside_pairs
    }

    /// MSD_z(τ) of block `block`, lags with no pair left out.
    pub fn curve(&self, block: usize) -> MsdCurve {
        let w = self.window;
        let mut c = MsdCurve {
            block,
            lags_s: Vec::new(),
            msd_m2: Vec::new(),
            pairs: Vec::new(),
        };
        for k in 1..w {
            let p = self.pairs[block * w + k];
            if p > 0 {
                c.lags_s.push(k as f64 * self.interval_s);
                c.msd_m2.push(self.sum_sq[block * w + k] / p as f64);
                c.pairs.push(p);
            }
        }
        c
    }
}

/// Fits MSD_z = 2 D τ + c to the points with τ in [min_lag, max_lag] (s), both ends included
/// to within 10⁻⁹ relative (lags are k·Δ in floating point). In the chute the motion is
/// diffusive for τ > 1 s (the paper's Fig. 2), ballistic below.
///
/// None with fewer than 3 such points (no residual left for an error), non-finite values or a
/// non-positive slope.
pub fn fit_diffusion(
    lags: &[f64],
    msd: &[f64],
    min_lag: f64,
    max_lag: f64,
) -> Option<DiffusionFit> {
    let (lo, hi) = (min_lag * (1.0 - 1e-9), max_lag * (1.0 + 1e-9));
    let (x, y): (Vec<f64>, Vec<f64>) = lags
        .iter()
        .zip(msd)
        .filter(|(t, _)| **t >= lo && **t <= hi)
        .map(|(&t, &m)| (t, m))
        .unzip();
    if x.len() < 3 {
        return None;
    }
    let line = linear_fit(&x, &y)?;
    (line.slope > 0.0).then(|| DiffusionFit {
        d: 0.5 * line.slope,
        stderr: 0.5 * line.slope_se,
        r: line.r,
        min_lag: x.iter().copied().fold(f64::INFINITY, f64::min),
        max_lag: x.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        points: x.len(),
    })
}
