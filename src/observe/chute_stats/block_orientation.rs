//! Orientation per block of height (chute): the nematic order S2 and ⟨|cos θ|⟩ to the flow
//! direction of the rods whose centre is in the block.
//!
//! Each snapshot's Q over a block's rods (`nematic::q_tensor`) is summed, and S2 is the largest
//! eigenvalue of the mean of those Q over the snapshots in which the block held a rod. Our
//! reading of "Q over the block's rods, averaged over snapshots": the eigenvalue is taken after
//! the average, so S2 has the bias of the whole measurement's rods (≲ 1/√(rods · snapshots) for
//! isotropic axes), not of one snapshot's (≲ 1/√rods, which averaging eigenvalues would keep).
//! ⟨|cos θ|⟩ is over every (rod, snapshot) in the block.

use serde::{Deserialize, Serialize};

use super::nematic::{abs_cos_to, largest_eigenvalue, q_of, Sym3};

/// Streaming per-block orientation sums (checkpointed with the chute observer).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BlockOrientation {
    /// Σ over snapshots of the snapshot's Q over the block's rods.
    q_sum: Vec<Sym3>,
    /// Snapshots in which the block held a rod.
    snapshots: Vec<u64>,
    /// Σ |cos θ| over (rod, snapshot) pairs in the block, and their number.
    abs_cos_sum: Vec<f64>,
    rods: Vec<u64>,
}

impl BlockOrientation {
    /// Empty sums for `blocks` blocks.
    pub fn new(blocks: usize) -> Self {
        Self {
            q_sum: vec![[0.0; 6]; blocks],
            snapshots: vec![0; blocks],
            abs_cos_sum: vec![0.0; blocks],
            rods: vec![0; blocks],
        }
    }

    /// Adds one snapshot: rod i in block `block[i]` (None: in none) with unit axis `axes[i]`.
    ///
    /// # Panics
    /// If the slices differ in length or a block is out of range.
    pub fn add_snapshot(&mut self, block: &[Option<usize>], axes: &[[f64; 3]], flow_dir: [f64; 3]) {
        assert_eq!(block.len(), axes.len());
        let n = self.rods.len();
        let mut q = vec![[0.0; 6]; n];
        let mut count = vec![0u64; n];
        for (&b, &u) in block.iter().zip(axes) {
            let Some(k) = b else { continue };
            for (s, v) in q[k].iter_mut().zip(q_of(u)) {
                *s += v;
            }
            count[k] += 1;
            self.abs_cos_sum[k] += abs_cos_to(u, flow_dir);
        }
        for k in 0..n {
            if count[k] > 0 {
                for (s, v) in self.q_sum[k].iter_mut().zip(q[k]) {
                    *s += v / count[k] as f64;
                }
                self.snapshots[k] += 1;
                self.rods[k] += count[k];
            }
        }
    }

    /// S2 of block k; None when no rod was ever in it.
    pub fn order(&self, k: usize) -> Option<f64> {
        let n = self.snapshots[k];
        (n > 0).then(|| largest_eigenvalue(self.q_sum[k].map(|s| s / n as f64)))
    }

    /// ⟨|cos θ|⟩ of block k; None when no rod was ever in it.
    pub fn mean_abs_cos(&self, k: usize) -> Option<f64> {
        let n = self.rods[k];
        (n > 0).then(|| self.abs_cos_sum[k] / n as f64)
    }

    /// (rod, snapshot) pairs seen in block k.
    pub fn rods(&self, k: usize) -> u64 {
        self.rods[k]
    }
}
