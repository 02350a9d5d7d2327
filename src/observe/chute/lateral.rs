//! D_y per block: the streaming MSD of y across the flow, from y unwrapped across the periodic
//! box (`msd::Unwrapper`; the snapshot's y is wrapped into [0, box_y)), with the blocks, lags,
//! fit and time windows of D_z (the same `MsdLayout`, and blocks by the height z as
//! `msd_blocks` assigns them: the same pairs go to the same block).

use serde::{Deserialize, Serialize};

use crate::observe::msd::{BlockDiffusion, BlockMsd, MsdLayout, Unwrapper};

/// The y MSD's state (checkpointed with the chute observer).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LateralMsd {
    unwrap: Unwrapper,
    msd: BlockMsd,
}

impl LateralMsd {
    /// An empty MSD of y for a box `box_y_m` wide, laid out as D_z's (`layout`).
    pub fn new(layout: MsdLayout, box_y_m: f64) -> Self {
        Self {
            unwrap: Unwrapper::new(box_y_m),
            msd: BlockMsd::new(layout),
        }
    }

    /// Adds one sample: particle `ids[i]` at height `z[i]` and centre `pos[i]` (y wrapped).
    pub fn add_sample(&mut self, ids: &[u32], z: &[f64], pos: &[[f64; 3]]) {
        let wrapped: Vec<f64> = pos.iter().map(|p| p[1]).collect();
        let y = self.unwrap.unwrap(ids, &wrapped);
        self.msd.add_sample_of(ids, z, &y);
    }

    /// Per block, MSD_y and D_y with its window error, as `BlockMsd::results` gives D_z.
    pub fn results(&self, lag_scale: f64) -> Vec<BlockDiffusion> {
        self.msd.results(lag_scale)
    }
}
