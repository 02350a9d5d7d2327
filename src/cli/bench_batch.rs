//! `sweep bench --batch J`: J copies of the bench scene (as the frequencies of one orifice share
//! their fill) advanced together by one GPU engine; reports the aggregate particle-steps/s and
//! the dispatches per step. Not stored: `sweep plan` estimates single jobs.

use std::time::Instant;

use sweep::bench::BenchScene;
use sweep::engine::gpu::GpuEngine;

use sweep::engine::{Backend, State};
use sweep::runner::backend::{self, BackendChoice};

use super::bench_args::Arguments;
use super::bench_dispatches::{dispatch_json, since};

pub fn run(a: &Arguments, sc: &BenchScene, scene_name: &str, jobs: usize) -> anyhow::Result<i32> {
    anyhow::ensure!(
        a.backend == BackendChoice::Gpu,
        "--batch {jobs}: batches run on the GPU only; add --backend gpu"
    );
    anyhow::ensure!(
        a.precision == "f32",
        "--batch: the GPU backend runs f32; got --precision {}",
        a.precision
    );
    let (dev, note) = backend::gpu_device(&a.gpu.select())?;
    if let Some(n) = note {
        eprintln!("{n}");
    }
    let configs = vec![sc.config.clone(); jobs];
    let states: Vec<&State<f64>> = vec![&sc.state; jobs];
    let options = sweep::runner::gpu_variants::gpu_options()?;
    let mut engine = GpuEngine::batch(&dev, configs, &states, options)?;
    let first = |r: Vec<Result<_, _>>| -> anyhow::Result<Vec<sweep::engine::ChunkReport>> {
        r.into_iter()
            .map(|x| x.map_err(|e: sweep::engine::EngineError| anyhow::anyhow!("{e}")))
            .collect()
    };
    first(engine.advance_batch(100)?)?;
    let d0 = engine.dispatches().unwrap_or_default();
    let t0 = Instant::now();
    let mut particle_steps: u64 = 0;
    let mut steps = 0;
    // At least one chunk of --steps; more until the window lasts --min-seconds.
    while steps == 0 || t0.elapsed().as_secs_f64() < a.min_seconds {
        let reports = first(engine.advance_batch(a.steps)?)?;
        particle_steps += reports.iter().map(|r| r.particle_steps).sum::<u64>();
        steps += a.steps;
    }
    let secs = t0.elapsed().as_secs_f64();
    let d = since(&engine.dispatches().unwrap_or_default(), &d0);
    let rate = particle_steps as f64 / secs;
    let mobile = sc.state.inv_mass.iter().filter(|&&m| m > 0.0).count();
    let info = engine.describe();
    if a.json {
        println!(
            "{}",
            serde_json::json!({
                "scene": scene_name, "particles": mobile, "jobs": jobs, "steps": steps, "chunk_steps": a.steps,
                "dt_s": sc.config.dt_s, "backend": "gpu", "adapter": info.adapter, "precision": "f32",
                "particle_steps_per_s": rate, "per_job_particle_steps_per_s": rate / jobs as f64,
                "seconds": secs, "dispatches": dispatch_json(&d),
                "gpu_options": sweep::runner::gpu_variants::describe(&options)
            })
        );
    } else {
        println!(
            "{scene_name}: {jobs} jobs × N = {mobile}, {} steps, dt = {:.3e} s, gpu f32 ({}): {rate:.3e} particle-steps/s in all, {:.3e} per job, {secs:.2} s",
            steps,
            sc.config.dt_s,
            info.adapter,
            rate / jobs as f64
        );
        println!(
            "  dispatches: {:.2} per step, {} per steady step, {} list builds ({} sorting by cell), {} steps voided and redone",
            d.dispatches as f64 / d.steps.max(1) as f64,
            d.max_steady_step,
            d.builds,
            d.sorting_builds,
            d.voided_steps
        );
    }
    Ok(0)
}
