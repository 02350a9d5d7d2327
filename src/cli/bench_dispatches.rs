//! What `sweep bench` reports of the GPU's dispatches and pass times (one engine's runs and a
//! batch's alike).

use sweep::engine::DispatchCount;

/// The counts of the timed run alone (the engine counts from its start).
pub fn since(d1: &DispatchCount, d0: &DispatchCount) -> DispatchCount {
    DispatchCount {
        steps: d1.steps - d0.steps,
        dispatches: d1.dispatches - d0.dispatches,
        steady_steps: d1.steady_steps - d0.steady_steps,
        steady_dispatches: d1.steady_dispatches - d0.steady_dispatches,
        max_steady_step: d1.max_steady_step,
        builds: d1.builds - d0.builds,
        sorting_builds: d1.sorting_builds - d0.sorting_builds,
        voided_steps: d1.voided_steps - d0.voided_steps,
        submissions: d1.submissions - d0.submissions,
        fused_steps: d1.fused_steps - d0.fused_steps,
        copies_back: d1.copies_back - d0.copies_back,
    }
}

pub fn dispatch_json(d: &DispatchCount) -> serde_json::Value {
    serde_json::json!({
        "per_step": d.dispatches as f64 / d.steps.max(1) as f64,
        "per_steady_step": d.max_steady_step,
        "steady_steps": d.steady_steps,
        "steps": d.steps,
        "total": d.dispatches,
        "list_builds": d.builds,
        "list_builds_sorting_by_cell": d.sorting_builds,
        "voided_steps": d.voided_steps,
        "submissions": d.submissions,
        "fused_steps": d.fused_steps,
        "copies_back": d.copies_back,
    })
}

/// Steps of the profiled chunk (`Backend::profile_passes`).
pub const PROFILED_STEPS: u64 = 100;

/// Device time per step of each kernel, the most costly first, and the chunk's once-only passes.
pub fn describe_passes(p: &[sweep::engine::PassTime]) -> String {
    let steps = p.first().map_or(0, |t| t.steps_timed).max(1) as f64;
    let total: f64 = p.iter().map(|t| t.ns).sum();
    let mut sorted: Vec<&sweep::engine::PassTime> = p.iter().collect();
    sorted.sort_by(|a, b| b.ns.total_cmp(&a.ns));
    let each: Vec<String> = sorted
        .iter()
        .map(|t| {
            format!(
                "{} {:.1} µs ×{}",
                t.kernel,
                t.ns / t.calls as f64 / 1e3,
                t.calls
            )
        })
        .collect();
    format!(
        "pass times over one chunk of {steps} steps: {:.1} µs per step in all; {}",
        total / steps / 1e3,
        each.join(", ")
    )
}
