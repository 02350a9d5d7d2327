//! Trajectory assignment (the chute paper's): each particle belongs to one block, that of the
//! mean height of its whole tracked trajectory. That mean is known only at the end, so each
//! particle keeps its own sums and blocks are formed in `curves` and `window_slopes`:
//! - Σ (Δz)² per lag (W values) and Σ z;
//! - its runs of consecutive samples (pairs at lag k = Σ_runs max(0, len − k): no count array);
//! - per time cell, the fit's weighted sum Σ_k c_k (Δz_k)² over the samples that pair with every
//!   fitted lag, and how many such samples. Since those samples contribute one pair at every
//!   fitted lag, a block's window MSD has the same pair count at each lag, and its least-squares
//!   slope Σ_k c_k MSD_k is exactly Σ_particles (weighted sum) / Σ_particles (samples): the
//!   window fit at block granularity from two numbers per particle and cell, not W.
//!
//! The window estimate leaves out the first `hi` samples of each run (a pair at the longest
//! fitted lag needs them), i.e. the start of the measurement: the first window is that much
//! shorter, and weighted so.

use serde::{Deserialize, Serialize};

use super::cells::{merge_cells, TimeWindow};
use super::fit::FitLags;

/// Per-particle sums of the trajectory assignment (checkpointed with `BlockMsd`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(super) struct ParticleTracks {
    /// Ring length W: lags 1..W−1 samples.
    window: usize,
    /// Time cells per particle.
    max_cells: usize,
    /// Σ (Δz)² per particle and lag: [slot W + k].
    sum_sq: Vec<f64>,
    /// Σ z and samples per particle: the trajectory's mean height.
    z_sum: Vec<f64>,
    z_count: Vec<u64>,
    /// Length of each particle's current run of consecutive samples.
    run_len: Vec<u64>,
    /// Runs that ended (slot, length), in the order they ended.
    ended_runs: Vec<(usize, u64)>,
    /// Per particle and cell: Σ_k c_k (Δz_k)² over samples pairing with every fitted lag
    /// ([slot max_cells + cell]), and their number.
    cell_weighted: Vec<f64>,
    cell_full: Vec<u32>,
}

/// A block's window: Σ weighted sums and Σ samples over its particles.
type WindowSums = (f64, u64);

impl ParticleTracks {
    pub fn new(window: usize, max_cells: usize) -> Self {
        Self {
            window,
            max_cells,
            sum_sq: Vec::new(),
            z_sum: Vec::new(),
            z_count: Vec::new(),
            run_len: Vec::new(),
            ended_runs: Vec::new(),
            cell_weighted: Vec::new(),
            cell_full: Vec::new(),
        }
    }

    /// Room for the next slot.
    pub fn add_particle(&mut self) {
        self.sum_sq.resize(self.sum_sq.len() + self.window, 0.0);
        self.z_sum.push(0.0);
        self.z_count.push(0);
        self.run_len.push(0);
        self.cell_weighted
            .resize(self.cell_weighted.len() + self.max_cells, 0.0);
        self.cell_full
            .resize(self.cell_full.len() + self.max_cells, 0);
    }

    /// Slot `s` was absent from the previous sample: its current run (if any) ended.
    pub fn end_run(&mut self, s: usize) {
        if self.run_len[s] > 0 {
            self.ended_runs.push((s, self.run_len[s]));
            self.run_len[s] = 0;
        }
    }

    /// Adds slot `s`'s newest height `heights[head]` and the pairs its newest displaced
    /// coordinate `walk[head]` ends (`filled` samples held; `walk` is `heights` for MSD_z).
    #[allow(clippy::too_many_arguments)]
    pub fn add_walk(
        &mut self,
        s: usize,
        heights: &[f64],
        walk: &[f64],
        head: usize,
        filled: usize,
        cell: usize,
        fit: Option<&FitLags>,
    ) {
        let w = self.window;
        self.z_sum[s] += heights[head];
        let zi = walk[head];
        self.z_count[s] += 1;
        self.run_len[s] += 1;
        let sums = &mut self.sum_sq[s * w..(s + 1) * w];
        let mut weighted = 0.0;
        match fit {
            Some(f) => {
                for k in 1..filled {
                    let dz = zi - walk[(head + w - k) % w];
                    sums[k] += dz * dz;
                    weighted += f.weights[k] * dz * dz;
                }
                if filled > f.hi {
                    self.cell_weighted[s * self.max_cells + cell] += weighted;
                    self.cell_full[s * self.max_cells + cell] += 1;
                }
            }
            None => {
                for k in 1..filled {
                    let dz = zi - walk[(head + w - k) % w];
                    sums[k] += dz * dz;
                }
            }
        }
    }

    /// Halves the time cells (see `cells`).
    pub fn merge_cells(&mut self) {
        let m = self.max_cells;
        for chunk in self.cell_weighted.chunks_mut(m) {
            merge_cells(chunk, 1);
        }
        for chunk in self.cell_full.chunks_mut(m) {
            merge_cells(chunk, 1);
        }
    }

    /// Each slot's block: that of its mean height, None outside every block.
    pub fn assign(&self, z_base_m: f64, block_height_m: f64, blocks: usize) -> Vec<Option<usize>> {
        self.z_sum
            .iter()
            .zip(&self.z_count)
            .map(|(&s, &n)| {
                let k = ((s / n as f64 - z_base_m) / block_height_m).floor();
                (k >= 0.0 && k < blocks as f64).then_some(k as usize)
            })
            .collect()
    }

    /// Pairs at lag k of one run of `len` samples.
    fn run_pairs(len: u64, k: usize) -> u64 {
        len.saturating_sub(k as u64)
    }

    /// Σ (Δz)² and pairs per block and lag ([block W + k]), and the pairs of particles outside
    /// every block. Particles are summed in slot order (first appearance): deterministic.
    pub fn block_sums(&self, assign: &[Option<usize>], blocks: usize) -> (Vec<f64>, Vec<u64>, u64) {
        let w = self.window;
        let (mut sum_sq, mut pairs, mut outside) =
            (vec![0.0; blocks * w], vec![0u64; blocks * w], 0u64);
        let runs = self
            .run_len
            .iter()
            .enumerate()
            .map(|(s, &len)| (s, len))
            .chain(self.ended_runs.iter().copied());
        for (s, len) in runs {
            match assign[s] {
                Some(b) => {
                    for k in 1..w {
                        pairs[b * w + k] += Self::run_pairs(len, k);
                    }
                }
                None => outside += (1..w).map(|k| Self::run_pairs(len, k)).sum::<u64>(),
            }
        }
        for (s, b) in assign.iter().enumerate() {
            if let Some(b) = b {
                for k in 1..w {
                    sum_sq[b * w + k] += self.sum_sq[s * w + k];
                }
            }
        }
        (sum_sq, pairs, outside)
    }

    /// Per block and window: Σ weighted sums and Σ samples over the block's particles
    /// ([block M + window]).
    pub fn window_sums(
        &self,
        assign: &[Option<usize>],
        blocks: usize,
        windows: &[TimeWindow],
    ) -> Vec<WindowSums> {
        let m = windows.len();
        let mut out = vec![(0.0, 0u64); blocks * m];
        for (s, b) in assign.iter().enumerate() {
            let Some(b) = b else { continue };
            let base = s * self.max_cells;
            for (j, win) in windows.iter().enumerate() {
                let o = &mut out[b * m + j];
                for c in win.cells.clone() {
                    o.0 += self.cell_weighted[base + c];
                    o.1 += u64::from(self.cell_full[base + c]);
                }
            }
        }
        out
    }
}
