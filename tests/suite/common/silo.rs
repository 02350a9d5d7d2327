//! A silo run driven the way the runner drives it (src/runner/silo_job.rs): fill until settled,
//! then discharge in chunks of one sampling interval, recording each sink event in `Discharge`
//! and re-inserting the removed particles above the bed between chunks (`SiloScene::reinsert`).

use sweep::engine::{Backend, State};
use sweep::observe::discharge::{Discharge, DischargeSettings, DischargeSummary};
use sweep::scene::silo::SiloScene;

/// Settles the bed on `b` (built with the scene's fill configuration) in chunks of 0.01 s, until
/// `SiloScene::settled` after 0.05 s, or `settle_max_time_s`.
pub fn fill(b: &mut dyn Backend, scene: &SiloScene) -> State<f64> {
    let chunk = (0.01 / scene.dt).round().max(1.0) as u64;
    loop {
        b.advance(chunk).unwrap();
        let s = b.download();
        if (scene.settled(&s) && s.time > 0.05) || s.time >= scene.p.settle_max_time_s {
            return s;
        }
    }
}

/// Discharges `b` (built with the scene's discharge configuration from a settled state opened at
/// `t_open`) for `scene.p.discharge_time_s`, re-inserting removed particles when the scene says
/// so (seeded by `seed ^ step`, as the runner). Returns the summary and the count out.
pub fn discharge(
    b: &mut dyn Backend,
    scene: &SiloScene,
    settings: &DischargeSettings,
    t_open: f64,
    seed: u64,
) -> (DischargeSummary, u64) {
    let chunk_steps = (settings.sample_interval_s / scene.dt).round().max(1.0) as u64;
    let chunk_dt = chunk_steps as f64 * scene.dt;
    let chunks = (scene.p.discharge_time_s / chunk_dt).round() as u64;
    let mut d = Discharge::new(settings.clone());
    let floor = scene.refill_floor(&b.download());
    for k in 1..=chunks {
        let report = b.advance(chunk_steps).unwrap();
        for ev in &report.removed {
            d.record_exit(ev.time_s - t_open, ev.mass_kg);
        }
        if scene.p.reinsert && !report.removed.is_empty() {
            let mut s = b.download();
            let step = s.step;
            scene
                .reinsert(&mut s, &report.removed, floor, seed ^ step)
                .unwrap();
            b.upload(&s);
        }
        d.sample(k as f64 * chunk_dt);
    }
    (d.summarize(chunks as f64 * chunk_dt), d.count)
}
