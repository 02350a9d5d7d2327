//! Mean squared displacement in z per block of height, as a stream (chute paper §3):
//! MSD_k(τ) = ⟨(z_i(t + τ) − z_i(t))²⟩ over the (particle, origin) pairs of block k, the
//! diffusion coefficient from MSD_z = 2 D τ + c, and its standard error from independent time
//! windows. The same for another coordinate (the chute's D_y, from unwrapped y): the
//! displacements are of that coordinate, the blocks still of the height (`add_sample_of`), so
//! both assign every pair alike.
//!
//! Blocks (`MsdBlocks`): the paper assigns each particle once, by the mean height of its whole
//! tracked trajectory (`trajectory`, the default); `window` assigns each (particle, origin)
//! pair by the particle's mean height over [t, t + τ].
//!
//! Memory is O(N·W): a ring of the last W = max_lag/Δ + 1 heights per particle, from which each
//! sample adds one squared displacement per lag kΔ (k = 1..W−1). `window` sums them per block
//! as they come (`window.rs`); `trajectory` keeps them per particle (W more values each, plus
//! two per time cell) and forms the blocks at the end (`trajectory.rs`). The trajectory itself
//! is never stored. Lags are k·Δ, Δ being the nominal sample interval: the caller samples at
//! that interval.
//!
//! Error bars: the MSD at neighbouring lags share displacements, so the residuals of one fit
//! understate D's uncertainty. Instead the measurement is split into M consecutive windows
//! (`cells.rs`: their length adapts to a measurement of unknown length), D is fitted per block
//! in each window with the same lags and the same block assignment (trajectory: the whole
//! measurement's mean height), and the standard error is their scatter over √M
//! (`fit::window_stderr`). D itself comes from the whole measurement.

mod cells;
mod fit;
mod trajectory;
mod unwrap;
mod window;

use std::collections::BTreeMap;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use cells::TimeCells;
use fit::FitLags;
pub use fit::{fit_diffusion, window_stderr, DiffusionFit};
use trajectory::ParticleTracks;
pub use unwrap::Unwrapper;
use window::PairBlocks;

/// How MSD pairs are assigned to blocks of height.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum MsdBlocks {
    /// Each particle once, by the mean height of its whole tracked trajectory (the paper's).
    #[default]
    Trajectory,
    /// Each (particle, origin) pair by the particle's mean height over [t, t + τ].
    Window,
}

/// What a `BlockMsd` measures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MsdLayout {
    /// Sample interval Δ = lag resolution (s).
    pub interval_s: f64,
    /// Longest lag (s).
    pub max_lag_s: f64,
    /// Height of the blocks (m).
    pub block_height_m: f64,
    /// Bottom of block 0 (m).
    pub z_base_m: f64,
    pub blocks: usize,
    pub assignment: MsdBlocks,
    /// Lags of the diffusion fit (s), both ends included.
    pub fit_min_lag_s: f64,
    pub fit_max_lag_s: f64,
    /// Time windows M of the error estimate (≥ 2 for an error).
    pub error_windows: usize,
}

/// The per-mode sums.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
enum Sums {
    Trajectory(ParticleTracks),
    Window(PairBlocks),
}

/// Streaming MSD_z per block (checkpointed with its observer).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BlockMsd {
    layout: MsdLayout,
    /// Ring length W: lags 1..W−1 samples.
    window: usize,
    /// The fitted lags; None when fewer than 3 (no fit, no window error).
    fit: Option<FitLags>,
    cells: TimeCells,
    /// Particle id → slot in the rings.
    slots: BTreeMap<u32, usize>,
    /// Slot s holds heights at ring[s W .. (s + 1) W], sample n at position n mod W.
    ring: Vec<f64>,
    /// The displaced coordinate, laid out as `ring`, when it is not the height
    /// (`add_sample_of`); empty otherwise (and then left out of the JSON, so an MSD of z
    /// serialises as before it existed).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    values: Vec<f64>,
    /// Consecutive samples held per slot (≤ W).
    filled: Vec<usize>,
    /// Index of the last sample each slot was seen in.
    last_seen: Vec<u64>,
    /// Samples taken.
    samples: u64,
    sums: Sums,
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

/// One block's MSD and diffusion coefficient.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BlockDiffusion {
    pub curve: MsdCurve,
    /// The fit over the whole measurement.
    pub fit: Option<DiffusionFit>,
    /// D of each time window (m²/s, may be ≤ 0: noise), empty when some window had no fit.
    pub window_d: Vec<f64>,
    /// Standard error of `fit.d` from the windows (`window_stderr`); None without a fit or
    /// without M windows each at least the longest fitted lag long.
    pub stderr: Option<f64>,
}

impl BlockMsd {
    /// An empty MSD.
    ///
    /// # Panics
    /// Unless Δ > 0, max_lag ≥ Δ, the block height > 0 and M ≥ 1 (the observer's settings
    /// guarantee it).
    pub fn new(layout: MsdLayout) -> Self {
        let l = &layout;
        assert!(
            l.interval_s > 0.0
                && l.max_lag_s >= l.interval_s
                && l.block_height_m > 0.0
                && l.error_windows >= 1
        );
        let window = (l.max_lag_s / l.interval_s).round() as usize + 1;
        let fit = FitLags::new(l.interval_s, window, l.fit_min_lag_s, l.fit_max_lag_s);
        let cells = TimeCells::new(l.error_windows);
        let sums = match l.assignment {
            MsdBlocks::Trajectory => Sums::Trajectory(ParticleTracks::new(window, cells.max())),
            MsdBlocks::Window => Sums::Window(PairBlocks::new(l.blocks, window, cells.max())),
        };
        Self {
            window,
            fit,
            cells,
            slots: BTreeMap::new(),
            ring: Vec::new(),
            values: Vec::new(),
            filled: Vec::new(),
            last_seen: Vec::new(),
            samples: 0,
            sums,
            layout,
        }
    }

    /// Adds one sample: particle `ids[i]` at height `z[i]` (m), in any order. A particle absent
    /// from the previous sample starts a new history (no displacement spans the gap).
    ///
    /// # Panics
    /// If the slices differ in length, or this MSD was fed by `add_sample_of` before.
    pub fn add_sample(&mut self, ids: &[u32], z: &[f64]) {
        assert!(
            self.values.is_empty(),
            "an MSD of another coordinate is fed by add_sample_of"
        );
        self.add(ids, z, None);
    }

    /// Adds one sample of the coordinate `x` (m, continuous: unwrapped across periodic
    /// boundaries), particle `ids[i]` at height `z[i]`: displacements of x, blocks by z exactly
    /// as `add_sample` assigns them.
    ///
    /// # Panics
    /// If the slices differ in length, or this MSD was fed by `add_sample` before.
    pub fn add_sample_of(&mut self, ids: &[u32], z: &[f64], x: &[f64]) {
        assert_eq!(ids.len(), x.len());
        assert!(
            self.samples == 0 || self.values.len() == self.ring.len(),
            "an MSD of z is fed by add_sample"
        );
        self.add(ids, z, Some(x));
    }

    fn add(&mut self, ids: &[u32], z: &[f64], x: Option<&[f64]>) {
        assert_eq!(ids.len(), z.len());
        let w = self.window;
        let n = self.samples;
        let head = (n % w as u64) as usize;
        let (cell, merge) = self.cells.cell_of(n);
        if merge {
            match &mut self.sums {
                Sums::Trajectory(t) => t.merge_cells(),
                Sums::Window(b) => b.merge_cells(),
            }
        }
        let (z_base, height) = (self.layout.z_base_m, self.layout.block_height_m);
        for (i, (&id, &zi)) in ids.iter().zip(z).enumerate() {
            let next = self.filled.len();
            let s = *self.slots.entry(id).or_insert(next);
            if s == next {
                self.ring.resize(self.ring.len() + w, 0.0);
                if x.is_some() {
                    self.values.resize(self.values.len() + w, 0.0);
                }
                self.filled.push(0);
                self.last_seen.push(n);
                if let Sums::Trajectory(t) = &mut self.sums {
                    t.add_particle();
                }
            } else if self.last_seen[s] + 1 != n {
                self.filled[s] = 0;
                if let Sums::Trajectory(t) = &mut self.sums {
                    t.end_run(s);
                }
            }
            self.last_seen[s] = n;
            let ring = &mut self.ring[s * w..(s + 1) * w];
            ring[head] = zi;
            let heights: &[f64] = ring;
            let walk: &[f64] = match x {
                Some(x) => {
                    let v = &mut self.values[s * w..(s + 1) * w];
                    v[head] = x[i];
                    v
                }
                None => heights,
            };
            self.filled[s] = (self.filled[s] + 1).min(w);
            let filled = self.filled[s];
            match &mut self.sums {
                Sums::Trajectory(t) => {
                    t.add_walk(s, heights, walk, head, filled, cell, self.fit.as_ref());
                }
                Sums::Window(b) => b.add_walk(heights, walk, head, filled, cell, z_base, height),
            }
        }
        self.samples += 1;
    }

    /// Number of blocks.
    pub fn blocks(&self) -> usize {
        self.layout.blocks
    }

    /// Samples taken so far.
    pub fn samples(&self) -> u64 {
        self.samples
    }

    /// Pairs assigned to no block: their window's (window) or their particle's trajectory's
    /// (trajectory) mean height fell below block 0 or above the last block.
    pub fn outside_pairs(&self) -> u64 {
        match &self.sums {
            Sums::Window(b) => b.outside_pairs(),
            Sums::Trajectory(t) => {
                let l = &self.layout;
                t.block_sums(&t.assign(l.z_base_m, l.block_height_m, l.blocks), l.blocks)
                    .2
            }
        }
    }

    /// MSD_z(τ) of every block, lags with no pair left out.
    pub fn curves(&self) -> Vec<MsdCurve> {
        let l = &self.layout;
        let w = self.window;
        let curve = |block: usize, sum_sq: &[f64], pairs: &[u64]| {
            let mut c = MsdCurve {
                block,
                lags_s: Vec::new(),
                msd_m2: Vec::new(),
                pairs: Vec::new(),
            };
            for k in 1..w {
                if pairs[k] > 0 {
                    c.lags_s.push(k as f64 * l.interval_s);
                    c.msd_m2.push(sum_sq[k] / pairs[k] as f64);
                    c.pairs.push(pairs[k]);
                }
            }
            c
        };
        match &self.sums {
            Sums::Window(b) => (0..l.blocks)
                .map(|k| {
                    let (s, p) = b.block_sums(k);
                    curve(k, s, p)
                })
                .collect(),
            Sums::Trajectory(t) => {
                let assign = t.assign(l.z_base_m, l.block_height_m, l.blocks);
                let (s, p, _) = t.block_sums(&assign, l.blocks);
                (0..l.blocks)
                    .map(|k| curve(k, &s[k * w..(k + 1) * w], &p[k * w..(k + 1) * w]))
                    .collect()
            }
        }
    }

    /// MSD_z(τ) of block `block`.
    pub fn curve(&self, block: usize) -> MsdCurve {
        self.curves().swap_remove(block)
    }

    /// Per block: the MSD, D from the whole measurement and its standard error from the time
    /// windows. `lag_scale` = measured / nominal sample interval: lags are chosen by their
    /// nominal value kΔ (so every window fits the same lags) and reported as kΔ · lag_scale,
    /// and D and its error divided by it.
    pub fn results(&self, lag_scale: f64) -> Vec<BlockDiffusion> {
        let l = &self.layout;
        let windows = self
            .cells
            .windows(self.samples)
            .filter(|w| w.len() >= 2)
            .filter(|w| {
                // Windows shorter than the longest fitted lag are not independent.
                let hi = self.fit.as_ref().map_or(u64::MAX, |f| f.hi as u64);
                w.iter().all(|x| x.samples >= hi)
            });
        // Window slopes (nominal time) and weights, per block.
        let slopes: Vec<Option<Vec<(f64, f64)>>> = match (&windows, &self.fit) {
            (Some(wins), Some(fit)) => match &self.sums {
                Sums::Window(b) => (0..l.blocks)
                    .map(|k| {
                        wins.iter()
                            .map(|x| b.window_slope(k, x.cells.clone(), fit, l.interval_s))
                            .collect()
                    })
                    .collect(),
                Sums::Trajectory(t) => {
                    let assign = t.assign(l.z_base_m, l.block_height_m, l.blocks);
                    let sums = t.window_sums(&assign, l.blocks, wins);
                    let m = wins.len();
                    (0..l.blocks)
                        .map(|k| {
                            sums[k * m..(k + 1) * m]
                                .iter()
                                .map(|&(s, n)| (n > 0).then(|| (s / n as f64, n as f64)))
                                .collect()
                        })
                        .collect()
                }
            },
            _ => vec![None; l.blocks],
        };
        self.curves()
            .into_iter()
            .zip(slopes)
            .map(|(curve, slopes)| {
                let fit = fit_diffusion(
                    &curve.lags_s,
                    &curve.msd_m2,
                    l.fit_min_lag_s,
                    l.fit_max_lag_s,
                )
                .map(|f| DiffusionFit {
                    d: f.d / lag_scale,
                    stderr: f.stderr / lag_scale,
                    min_lag: f.min_lag * lag_scale,
                    max_lag: f.max_lag * lag_scale,
                    ..f
                });
                let (window_d, weights): (Vec<f64>, Vec<f64>) = slopes
                    .unwrap_or_default()
                    .iter()
                    .map(|&(slope, n)| (0.5 * slope / lag_scale, n))
                    .unzip();
                let stderr = fit.and(window_stderr(&window_d, &weights));
                BlockDiffusion {
                    curve: MsdCurve {
                        lags_s: curve.lags_s.iter().map(|t| t * lag_scale).collect(),
                        ..curve
                    },
                    fit,
                    window_d,
                    stderr,
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests;
