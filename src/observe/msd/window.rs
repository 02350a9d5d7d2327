//! Window assignment: each (particle, origin) pair goes to the block of the particle's mean
//! height over [t, t + τ], so the sums are per block from the start: Σ (Δz)² and pair counts
//! per block and lag, for the whole measurement and per time cell.

use serde::{Deserialize, Serialize};

use super::cells::merge_cells;
use super::fit::FitLags;
use crate::observe::fits::linear_fit;

/// Per-block sums of the window assignment (checkpointed with `BlockMsd`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(super) struct PairBlocks {
    blocks: usize,
    /// Ring length W: lags 1..W−1 samples.
    window: usize,
    /// Σ (Δz)² per block and lag over the measurement: [block W + k].
    sum_sq: Vec<f64>,
    /// Pairs per block and lag.
    pairs: Vec<u64>,
    /// The same per time cell: [(cell B + block) W + k].
    cell_sum_sq: Vec<f64>,
    cell_pairs: Vec<u64>,
    /// Pairs whose window mean lay outside every block.
    outside_pairs: u64,
}

impl PairBlocks {
    pub fn new(blocks: usize, window: usize, max_cells: usize) -> Self {
        Self {
            blocks,
            window,
            sum_sq: vec![0.0; blocks * window],
            pairs: vec![0; blocks * window],
            cell_sum_sq: vec![0.0; max_cells * blocks * window],
            cell_pairs: vec![0; max_cells * blocks * window],
            outside_pairs: 0,
        }
    }

    /// Adds the pairs ending at the newest sample (`filled` held): lag k pairs the displaced
    /// coordinate `walk[head]` with its value k samples back, and a running sum of `heights`
    /// gives the window's mean height (`walk` is `heights` for MSD_z).
    #[allow(clippy::too_many_arguments)]
    pub fn add_walk(
        &mut self,
        heights: &[f64],
        walk: &[f64],
        head: usize,
        filled: usize,
        cell: usize,
        z_base_m: f64,
        block_height_m: f64,
    ) {
        let w = self.window;
        let zi = walk[head];
        let cell_base = cell * self.blocks * w;
        let mut sum = heights[head];
        for k in 1..filled {
            let old = walk[(head + w - k) % w];
            sum += heights[(head + w - k) % w];
            let mean = sum / (k + 1) as f64;
            let block = ((mean - z_base_m) / block_height_m).floor();
            if block >= 0.0 && block < self.blocks as f64 {
                let at = block as usize * w + k;
                let sq = (zi - old) * (zi - old);
                self.sum_sq[at] += sq;
                self.pairs[at] += 1;
                self.cell_sum_sq[cell_base + at] += sq;
                self.cell_pairs[cell_base + at] += 1;
            } else {
                self.outside_pairs += 1;
            }
        }
    }

    /// Halves the time cells (see `cells`).
    pub fn merge_cells(&mut self) {
        let size = self.blocks * self.window;
        merge_cells(&mut self.cell_sum_sq, size);
        merge_cells(&mut self.cell_pairs, size);
    }

    /// Σ (Δz)² and pairs per lag (k = 0..W) of `block` over the measurement.
    pub fn block_sums(&self, block: usize) -> (&[f64], &[u64]) {
        let r = block * self.window..(block + 1) * self.window;
        (&self.sum_sq[r.clone()], &self.pairs[r])
    }

    pub fn outside_pairs(&self) -> u64 {
        self.outside_pairs
    }

    /// The least-squares slope of `block`'s MSD over the fitted lags from the pairs that ended
    /// in `cells`, and the window's data: mean pairs per fitted lag. None with fewer than 3
    /// fitted lags holding a pair.
    pub fn window_slope(
        &self,
        block: usize,
        cells: std::ops::Range<usize>,
        fit: &FitLags,
        interval_s: f64,
    ) -> Option<(f64, f64)> {
        let w = self.window;
        let (mut x, mut y, mut n) = (Vec::new(), Vec::new(), 0u64);
        for k in fit.lo..=fit.hi {
            let (mut s, mut p) = (0.0, 0u64);
            for c in cells.clone() {
                let at = (c * self.blocks + block) * w + k;
                s += self.cell_sum_sq[at];
                p += self.cell_pairs[at];
            }
            if p > 0 {
                x.push(k as f64 * interval_s);
                y.push(s / p as f64);
                n += p;
            }
        }
        if x.len() < 3 {
            return None;
        }
        let line = linear_fit(&x, &y)?;
        Some((line.slope, n as f64 / fit.len() as f64))
    }
}
