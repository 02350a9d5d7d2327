//! Time average of z profiles: each linear sum averaged separately over snapshots, the derived
//! fields (V, σᵏ, γ̇) then taken from the averages (see `fields`).

use serde::{Deserialize, Serialize};

use super::z_grid::ZGrid;
use super::z_profile::ZProfile;

/// Running sum of snapshot profiles on one grid (checkpointed with its observer).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ZProfileAverage {
    sum: ZProfile,
    snapshots: u64,
}

impl ZProfileAverage {
    /// An empty average on `grid`.
    pub fn new(grid: ZGrid) -> Self {
        Self {
            sum: ZProfile::new(grid),
            snapshots: 0,
        }
    }

    /// Adds one snapshot.
    ///
    /// # Panics
    /// If the snapshot's grid differs from the average's.
    pub fn add(&mut self, snapshot: &ZProfile) {
        assert_eq!(snapshot.grid, self.sum.grid, "same grid");
        for (s, p) in self.sum.points.iter_mut().zip(&snapshot.points) {
            s.add_scaled(p, 1.0);
        }
        self.snapshots += 1;
    }

    /// Snapshots added so far.
    pub fn snapshots(&self) -> u64 {
        self.snapshots
    }

    /// The time-averaged profile; None before the first snapshot.
    pub fn mean(&self) -> Option<ZProfile> {
        if self.snapshots == 0 {
            return None;
        }
        let mut mean = ZProfile::new(self.sum.grid);
        let inv = 1.0 / self.snapshots as f64;
        for (m, s) in mean.points.iter_mut().zip(&self.sum.points) {
            m.add_scaled(s, inv);
        }
        Some(mean)
    }
}
