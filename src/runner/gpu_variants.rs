//! Variants of the GPU engine chosen at run time: how many steps go into one command buffer
//! (`SWEEP_GPU_STEPS_PER_SUBMIT`), whether list builds sort the particles by cell
//! (`SWEEP_GPU_SORT_BY_CELL`, 1 or 0), and whether a step is one dispatch (`SWEEP_GPU_FUSED_STEP`,
//! 1 or 0: the forces fused with the next kick and drift, over two copies of the state). None
//! changes a result, with one caveat for the one-dispatch step: a driver that fuses a·b + c in
//! one kernel and not in another can make its bits depend on where chunks end (docs/design.md
//! § Fused multiply-adds). The GPU machine's check times them side by side in one run
//! (`scripts/gpu-device-check.sh`); `sweep bench` records them.

use crate::engine::gpu::GpuOptions;

pub const STEPS_PER_SUBMIT_ENV: &str = "SWEEP_GPU_STEPS_PER_SUBMIT";
pub const SORT_BY_CELL_ENV: &str = "SWEEP_GPU_SORT_BY_CELL";
pub const FUSED_STEP_ENV: &str = "SWEEP_GPU_FUSED_STEP";

/// The GPU engine's options: the defaults, changed by the variables that are set.
///
/// # Errors
/// A variable set to something else than it takes, naming it.
pub fn gpu_options() -> anyhow::Result<GpuOptions> {
    let mut o = GpuOptions::default();
    if let Ok(v) = std::env::var(STEPS_PER_SUBMIT_ENV) {
        o.steps_per_submit = v
            .trim()
            .parse::<u64>()
            .ok()
            .filter(|&n| n >= 1)
            .ok_or_else(|| {
                anyhow::anyhow!(
                    "{STEPS_PER_SUBMIT_ENV}={v:?}: expected a whole number of steps >= 1"
                )
            })?;
    }
    if let Ok(v) = std::env::var(SORT_BY_CELL_ENV) {
        o.reorder_by_cell = match v.trim() {
            "1" => true,
            "0" => false,
            _ => anyhow::bail!("{SORT_BY_CELL_ENV}={v:?}: expected 1 (sort by cell) or 0"),
        };
    }
    if let Ok(v) = std::env::var(FUSED_STEP_ENV) {
        o.fused_step = match v.trim() {
            "1" => true,
            "0" => false,
            _ => anyhow::bail!("{FUSED_STEP_ENV}={v:?}: expected 1 (one dispatch per step) or 0"),
        };
    }
    Ok(o)
}

/// The options as the bench's JSON records them.
pub fn describe(o: &GpuOptions) -> serde_json::Value {
    serde_json::json!({
        "steps_per_submit": o.steps_per_submit,
        "sort_by_cell": o.reorder_by_cell,
        "fused_step": o.fused_step,
    })
}
