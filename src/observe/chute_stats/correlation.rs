//! Spatial correlation of v_z fluctuations within layers (chute paper Eq. 3, Fig. 7):
//! C(r, z) = ⟨δv_i δv_j⟩ over pairs i < j in the same block whose distance falls in
//! [n b, (n + 1) b), b = L/4, and the correlation length from ln C(r)/C(0) ≈ a − r/l.
//!
//! Distances are 3-D with the minimum image in the periodic x and y. Fluctuations are about the
//! block's time-averaged v_z over the evaluated snapshots, applied at the end from raw sums
//! (Σ v_i v_j, Σ (v_i + v_j), pairs): subtracting each snapshot's own block mean instead would
//! remove the collective part of the motion, biasing C(r) down by ~⟨δv²⟩ × (correlated volume /
//! block volume), ~10 % of C(0) for l ≈ L in a 16 L × 16 L × L block. C(0) = ⟨δv²⟩ is the i = j
//! term, reported at r = 0. Each evaluation is O(n_block²).

use serde::{Deserialize, Serialize};

use super::super::fits::linear_fit;

/// Bins with C(r)/C(0) above this enter the correlation-length fit: below it the tail is
/// dominated by noise (the estimate's spread is ~C(0)/√pairs).
pub const CORRELATION_FIT_FLOOR: f64 = 0.1;

/// Raw pair sums per block and distance bin (checkpointed with its observer).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VzCorrelation {
    bin_m: f64,
    bins: usize,
    box_x_m: f64,
    box_y_m: f64,
    block_height_m: f64,
    z_base_m: f64,
    blocks: usize,
    /// Per [block bins + bin]: Σ v_i v_j, Σ (v_i + v_j), pairs.
    sum_vv: Vec<f64>,
    sum_v: Vec<f64>,
    pairs: Vec<u64>,
    /// Per block, the i = j terms: Σ v², Σ v, count.
    self_vv: Vec<f64>,
    self_v: Vec<f64>,
    self_n: Vec<u64>,
    evaluations: u64,
}

/// C(r) of one block: r[0] = 0 holds C(0) = ⟨δv_z²⟩ (pairs = particle samples), then the bin
/// centres with at least one pair.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CorrelationCurve {
    pub block: usize,
    /// r (m).
    pub r_m: Vec<f64>,
    /// C (m²/s²).
    pub c: Vec<f64>,
    pub pairs: Vec<u64>,
}

impl VzCorrelation {
    /// Bins of `bin_m` up to `r_max_m` (m); blocks k = 0..blocks of `block_height_m` above
    /// `z_base_m`; periodic box lengths `box_x_m`, `box_y_m`.
    pub fn new(
        bin_m: f64,
        r_max_m: f64,
        box_x_m: f64,
        box_y_m: f64,
        block_height_m: f64,
        z_base_m: f64,
        blocks: usize,
    ) -> Self {
        let bins = (r_max_m / bin_m).round().max(1.0) as usize;
        Self {
            bin_m,
            bins,
            box_x_m,
            box_y_m,
            block_height_m,
            z_base_m,
            blocks,
            sum_vv: vec![0.0; blocks * bins],
            sum_v: vec![0.0; blocks * bins],
            pairs: vec![0; blocks * bins],
            self_vv: vec![0.0; blocks],
            self_v: vec![0.0; blocks],
            self_n: vec![0; blocks],
            evaluations: 0,
        }
    }

    /// Snapshots evaluated so far.
    pub fn evaluations(&self) -> u64 {
        self.evaluations
    }

    /// Adds every same-block pair of one snapshot: positions `pos` (m, x and y in the periodic
    /// box), vertical velocities `vz` (m/s).
    ///
    /// # Panics
    /// If the slices differ in length.
    pub fn add_snapshot(&mut self, pos: &[[f64; 3]], vz: &[f64]) {
        assert_eq!(pos.len(), vz.len());
        let mut members: Vec<Vec<usize>> = vec![Vec::new(); self.blocks];
        for (i, p) in pos.iter().enumerate() {
            let k = ((p[2] - self.z_base_m) / self.block_height_m).floor();
            if k >= 0.0 && k < self.blocks as f64 {
                members[k as usize].push(i);
            }
        }
        let r_max2 = (self.bins as f64 * self.bin_m).powi(2);
        let image = |d: f64, len: f64| d - len * (d / len).round();
        for (k, idx) in members.iter().enumerate() {
            for (a, &i) in idx.iter().enumerate() {
                let (pi, vi) = (pos[i], vz[i]);
                self.self_vv[k] += vi * vi;
                self.self_v[k] += vi;
                self.self_n[k] += 1;
                for &j in &idx[a + 1..] {
                    let dx = image(pos[j][0] - pi[0], self.box_x_m);
                    let dy = image(pos[j][1] - pi[1], self.box_y_m);
                    let dz = pos[j][2] - pi[2];
                    let r2 = dx * dx + dy * dy + dz * dz;
                    if r2 >= r_max2 {
                        continue;
                    }
                    let bin = ((r2.sqrt() / self.bin_m) as usize).min(self.bins - 1);
                    let at = k * self.bins + bin;
                    self.sum_vv[at] += vi * vz[j];
                    self.sum_v[at] += vi + vz[j];
                    self.pairs[at] += 1;
                }
            }
        }
        self.evaluations += 1;
    }

    /// C(r) of block `block` about the block's mean v_z over the evaluated snapshots; None
    /// before any particle was seen in it.
    pub fn curve(&self, block: usize) -> Option<CorrelationCurve> {
        let n0 = self.self_n[block];
        if n0 == 0 {
            return None;
        }
        let mu = self.self_v[block] / n0 as f64;
        // ⟨(v_i − μ)(v_j − μ)⟩ = ⟨v_i v_j⟩ − μ ⟨v_i + v_j⟩ + μ².
        let mut curve = CorrelationCurve {
            block,
            r_m: vec![0.0],
            c: vec![self.self_vv[block] / n0 as f64 - mu * mu],
            pairs: vec![n0],
        };
        for b in 0..self.bins {
            let at = block * self.bins + b;
            let p = self.pairs[at];
            if p > 0 {
                let pf = p as f64;
                curve.r_m.push((b as f64 + 0.5) * self.bin_m);
                curve
                    .c
                    .push(self.sum_vv[at] / pf - mu * self.sum_v[at] / pf + mu * mu);
                curve.pairs.push(p);
            }
        }
        Some(curve)
    }
}

/// Correlation length l (m) from C(r) with r[0] = 0 holding C(0) (as `CorrelationCurve`s are):
/// a least-squares line ln(C/C(0)) = a − r/l through the bins r > 0 from the first one up to the
/// last before C/C(0) first drops to `CORRELATION_FIT_FLOOR` or below.
///
/// The intercept a is free, as in the paper's fits of the tails: C(0) includes each particle's
/// uncorrelated rattle, so C jumps down between r = 0 and the first pair distances, and forcing
/// a = 0 would fold that jump into l.
///
/// None when r[0] ≠ 0, C(0) ≤ 0, fewer than 3 bins qualify, or the fitted slope is not negative.
pub fn correlation_length(r: &[f64], c: &[f64]) -> Option<f64> {
    if r.len() != c.len() || r.first() != Some(&0.0) || !(c[0] > 0.0) {
        return None;
    }
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for (&ri, &ci) in r.iter().zip(c).skip(1) {
        let ratio = ci / c[0];
        if !(ratio > CORRELATION_FIT_FLOOR) {
            break;
        }
        x.push(ri);
        y.push(ratio.ln());
    }
    if x.len() < 3 {
        return None;
    }
    let line = linear_fit(&x, &y)?;
    (line.slope < 0.0).then(|| -1.0 / line.slope)
}
