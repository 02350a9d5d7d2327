//! Translation invariance on the GPU (`translation.rs` has the CPU's and the scenes): the tiny
//! silo at the origin and 10 km up discharges at the same rate. Only the far place, where plain
//! f32 failed: each job costs a minute on lavapipe, and the split positions are the same code at
//! 100 m. (A module of its own so that this long test starts among the GPU tests, not last.)

use crate::common::gpu::device;
use crate::translation::{silo_is_invariant, MOVED};

#[test]
fn a_silo_moved_10_km_discharges_at_the_same_rate_on_the_gpu() {
    if device().is_none() {
        return;
    }
    silo_is_invariant("gpu", &MOVED[1..]);
}
