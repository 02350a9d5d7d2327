//! Running one silo job: shared fill stage, discharge in chunks of one sampling interval,
//! checkpoints at chunk boundaries (so a resumed run repeats exactly the same operations), and
//! the results written with the job's completion in one transaction.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

use anyhow::Context;
use rusqlite::Connection;
use serde::{Deserialize, Serialize};

use super::backend::{self, BackendChoice};
use super::job_lock::DirLock;
use crate::campaign::JobSpec;
use crate::checkpoint::{self, Header};
use crate::engine::{Backend, State};
use crate::observe::discharge::Discharge;
use crate::observe::silo_fields::SiloFieldObserver;
use crate::observe::snapshots::SnapshotWriter;
use crate::scene::silo::{SiloPhase, SiloScene};
use crate::store::jobs::{self, JobRow, Lease};
use crate::store::SiloResults;

/// How a job run ended.
#[derive(Debug, PartialEq)]
pub enum Outcome {
    Done,
    /// Interrupted (SIGINT/SIGTERM); its checkpoint is current.
    Paused,
    Failed(String),
}

/// Progress callback: (simulated time since opening, target, particle-steps/s).
pub type ProgressFn = Arc<dyn Fn(f64, f64, f64) + Send + Sync>;

/// Where and how jobs run.
#[derive(Clone)]
pub struct JobContext {
    /// Checkpoints and shared stages live under here.
    pub work_dir: PathBuf,
    pub backend: BackendChoice,
    pub threads: usize,
    /// Simulated seconds between checkpoints.
    pub checkpoint_interval_s: f64,
    pub interrupt: Arc<AtomicBool>,
    /// Called with (simulated time since opening, target, particle-steps/s) after each chunk.
    pub progress: Option<ProgressFn>,
    /// Messages for the user (refused checkpoints, restarts, fill stage reuse).
    pub log: Arc<dyn Fn(String) + Send + Sync>,
}

/// What a checkpoint keeps besides the particles.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Progress {
    t_open: f64,
    step_open: u64,
    chunk: u64,
    bulk_density: f64,
    discharge: Discharge,
    particle_steps: u64,
    wall_time_s: f64,
    initial_count: usize,
    #[serde(default)]
    numerics: crate::store::JobNumerics,
    /// The coarse-grained field observer (absent unless the campaign asks for it).
    #[serde(default)]
    fields: Option<SiloFieldObserver>,
    /// Wall time spent sampling fields (s), for the observer's cost.
    #[serde(default)]
    fields_wall_s: f64,
}

/// A job's own directory (checkpoints) under the work directory.
pub fn job_dir(work: &Path, hash: &str) -> PathBuf {
    work.join("jobs").join(&hash[..16])
}

/// Downloads the engine's state and writes it with the job's progress record `prog` as the
/// job's next checkpoint (only ever between chunks, so a resumed run repeats the same steps).
pub(super) fn save_checkpoint<P: Serialize>(
    dir: &Path,
    job_hash: &str,
    engine: &mut dyn Backend,
    info: &crate::engine::BackendInfo,
    prog: &P,
) -> anyhow::Result<PathBuf> {
    let s = engine.try_download()?;
    let h = Header {
        job_hash: job_hash.to_string(),
        step: s.step,
        time_s: s.time,
        backend: info.kind.clone(),
        precision: info.precision.clone(),
    };
    Ok(checkpoint::save(
        dir,
        &h,
        &s,
        &serde_json::to_string(prog)?,
    )?)
}

/// Fills and settles the silo (orifice closed, bottom still), or reuses the stored result of the
/// same fill parameters. Returns the settled state and the particle-steps it cost (0 if reused).
fn fill_stage(
    spec: &JobSpec,
    scene: &SiloScene,
    ctx: &JobContext,
) -> anyhow::Result<(State<f64>, u64)> {
    let (key, seed) = spec.fill_key();
    let dir = ctx.work_dir.join("stages").join(&key[..16]);
    // One process fills (holding the stage's OS lock); the others sharing the stage wait for its
    // checkpoint, or take the stage over when the filler dies (the kernel drops its lock).
    let mut waited = false;
    let _lock = loop {
        let (found, refused) = checkpoint::load_latest(&dir, &key);
        for r in refused {
            (ctx.log)(r);
        }
        if let Some((path, _, s, _)) = found {
            (ctx.log)(format!(
                "fill stage {}: reusing {}",
                &key[..16],
                path.display()
            ));
            return Ok((s, 0));
        }
        if let Some(lock) = DirLock::try_take(&dir)? {
            // The filler may have finished between the look and the lock.
            if checkpoint::load_latest(&dir, &key).0.is_none() {
                break lock;
            }
            continue;
        }
        if !waited {
            (ctx.log)(format!(
                "fill stage {}: waiting for the job that is filling it",
                &key[..16]
            ));
            waited = true;
        }
        if ctx.interrupt.load(Ordering::SeqCst) {
            return Err(Interrupted.into());
        }
        std::thread::sleep(std::time::Duration::from_millis(200));
    };
    fill_stage_run(spec, scene, ctx, &dir, &key, seed)
}

/// The run was interrupted (SIGINT/SIGTERM) before its first checkpoint: the job is paused.
#[derive(Debug, thiserror::Error)]
#[error("interrupted before the first checkpoint")]
pub struct Interrupted;

fn fill_stage_run(
    spec: &JobSpec,
    scene: &SiloScene,
    ctx: &JobContext,
    dir: &Path,
    key: &str,
    seed: u64,
) -> anyhow::Result<(State<f64>, u64)> {
    let config = scene.engine_config(SiloPhase::Fill);
    let init = scene.initial_state(seed);
    let mut engine = backend::build(
        BackendChoice::Cpu,
        spec.precision,
        config,
        &init,
        ctx.threads,
    )?;
    let chunk = (0.01 / scene.dt).round().max(1.0) as u64;
    let mut steps = 0u64;
    let mut s;
    loop {
        // Every loop that runs the engine stops on an interrupt; a fill has no checkpoint of its
        // own, so the job starts it again when resumed.
        if ctx.interrupt.load(Ordering::SeqCst) {
            return Err(Interrupted.into());
        }
        let r = engine
            .advance(chunk)
            .map_err(|e| anyhow::anyhow!("fill stage: {e}"))?;
        steps += r.particle_steps;
        s = engine
            .try_download()
            .map_err(|e| anyhow::anyhow!("fill stage: {e}"))?;
        if scene.settled(&s) && s.time > 0.05 {
            break;
        }
        if s.time >= scene.p.settle_max_time_s {
            (ctx.log)(format!(
                "fill stage {}: not settled after {} s (kinetic energy {:.3e} J); continuing with this state — raise settle_max_time_s for a quieter bed",
                &key[..16],
                scene.p.settle_max_time_s,
                s.kinetic_energy()
            ));
            break;
        }
    }
    let bed = scene.bed_height(&s);
    if bed > scene.p.cylinder_height_m {
        anyhow::bail!(
            "fill stage: the settled bed is {bed:.3} m high, taller than the silo (cylinder_height_m = {} m): use fewer particles or a taller silo",
            scene.p.cylinder_height_m
        );
    }
    let h = Header {
        job_hash: key.to_string(),
        step: s.step,
        time_s: s.time,
        backend: "cpu".into(),
        precision: spec.precision.name().into(),
    };
    checkpoint::save(dir, &h, &s, "{}")?;
    Ok((s, steps))
}

/// Runs (or resumes) one silo job to its end, an interruption, or a failure.
///
/// # Errors
/// Database and I/O errors; physics failures are an `Outcome::Failed` instead.
pub fn run_silo_job(
    conn: &mut Connection,
    job: &JobRow,
    lease: &Lease,
    ctx: &JobContext,
) -> anyhow::Result<Outcome> {
    let spec: JobSpec = serde_json::from_str(&job.params_json)
        .with_context(|| format!("job {}: stored parameters unreadable", job.id))?;
    let scene = match SiloScene::new(spec.silo().clone()) {
        Ok(s) => s,
        Err(e) => return Ok(Outcome::Failed(e)),
    };
    let dir = job_dir(&ctx.work_dir, &job.hash);
    let started = Instant::now();
    let (found, refused) = checkpoint::load_latest(&dir, &job.hash);
    for r in refused {
        (ctx.log)(format!("job {}: {r}", job.id));
    }
    let (state, mut prog) = match found {
        Some((path, _, s, extra)) => {
            let prog = serde_json::from_str::<Progress>(&extra)
                .with_context(|| format!("{}: progress record unreadable", path.display()))?;
            (ctx.log)(format!(
                "job {}: resuming from {} (t = {:.3} s after opening)",
                job.id,
                path.display(),
                s.time - prog.t_open
            ));
            (s, prog)
        }
        None => {
            if job.sim_time_s > 0.0 {
                (ctx.log)(format!(
                    "job {}: no valid checkpoint; restarting from the beginning",
                    job.id
                ));
            }
            jobs::set_stage(conn, job.id, lease, "fill")?;
            let (s, fill_steps) = match fill_stage(&spec, &scene, ctx) {
                Ok(x) => x,
                Err(e) if e.is::<Interrupted>() => return Ok(Outcome::Paused),
                Err(e) => return Err(e),
            };
            let bulk = scene.bulk_density(&s);
            let prog = Progress {
                t_open: s.time,
                step_open: s.step,
                chunk: 0,
                bulk_density: bulk,
                discharge: Discharge::new(spec.observers.discharge.clone()),
                particle_steps: fill_steps,
                wall_time_s: 0.0,
                initial_count: s.len(),
                numerics: Default::default(),
                fields: None,
                fields_wall_s: 0.0,
            };
            (s, prog)
        }
    };
    let config = scene.engine_config(SiloPhase::Discharge);
    let mut engine: Box<dyn Backend> = match backend::build(
        backend::for_job(&spec, ctx.backend),
        spec.precision,
        config,
        &state,
        ctx.threads,
    ) {
        Ok(e) => e,
        Err(e) => return Ok(Outcome::Failed(format!("{e:#}"))),
    };
    let info = engine.describe();
    jobs::set_backend(conn, job.id, &info.kind, &info.adapter, &info.precision)?;
    jobs::set_stage(conn, job.id, lease, "discharge")?;

    let st = &spec.observers.discharge;
    let chunk_steps = (st.sample_interval_s / scene.dt).round().max(1.0) as u64;
    let chunk_dt = chunk_steps as f64 * scene.dt;
    let ckpt_every = ((ctx.checkpoint_interval_s / chunk_dt).round() as u64).max(1);
    if prog.fields.is_none() {
        prog.fields = spec
            .observers
            .fields
            .as_ref()
            .map(|f| SiloFieldObserver::new(f, &scene.p, chunk_dt));
    }
    let target = scene.p.discharge_time_s;
    let wall0 = prog.wall_time_s;
    let mut last_beat = Instant::now();
    let seed = spec.seed();
    let save = |engine: &mut Box<dyn Backend>, prog: &Progress| {
        save_checkpoint(&dir, &job.hash, engine.as_mut(), &info, prog)
    };
    let snapshots =
        SnapshotWriter::new(spec.observers.snapshots.as_ref(), &dir, &job.hash, chunk_dt);
    loop {
        let t_rel = prog.chunk as f64 * chunk_dt;
        // Frames at chunk boundaries only, so a resumed run rewrites the same ones.
        snapshots.at_chunk(prog.chunk, t_rel, || engine.try_download())?;
        // Without re-insertion the particles left are the initial ones minus those counted out.
        let remaining = prog.initial_count - prog.discharge.count as usize;
        let done = t_rel >= target - 1e-12
            || prog.discharge.permanently_clogged(t_rel)
            || (!scene.p.reinsert
                && (remaining as f64)
                    < scene.p.stop_remaining_fraction * prog.initial_count as f64);
        if done {
            break;
        }
        if ctx.interrupt.load(Ordering::SeqCst) {
            let path = save(&mut engine, &prog)?;
            jobs::heartbeat(
                conn,
                job.id,
                lease,
                t_rel,
                t_rel / target,
                prog.particle_steps,
                prog.wall_time_s,
                Some(&path.display().to_string()),
            )?;
            return Ok(Outcome::Paused);
        }
        let t0 = Instant::now();
        let report = match engine.advance(chunk_steps) {
            Ok(r) => r,
            Err(e) => return Ok(Outcome::Failed(format!("{e} (last good checkpoint kept)"))),
        };
        prog.chunk += 1;
        prog.particle_steps += report.particle_steps;
        prog.numerics.add(&report);
        let rate = report.particle_steps as f64 / t0.elapsed().as_secs_f64().max(1e-9);
        let t_now = prog.chunk as f64 * chunk_dt;
        for ev in &report.removed {
            prog.discharge
                .record_exit(ev.time_s - prog.t_open, ev.mass_kg);
        }
        if scene.p.reinsert && !report.removed.is_empty() {
            let mut s = match engine.try_download() {
                Ok(s) => s,
                Err(e) => return Ok(Outcome::Failed(format!("{e} (last good checkpoint kept)"))),
            };
            let step = s.step;
            scene.reinsert(&mut s, &report.removed, seed ^ step);
            engine.upload(&s);
        }
        prog.discharge.sample(t_now);
        if let Some(obs) = prog.fields.as_mut() {
            if obs.samples_at(prog.chunk) && obs.wanted_at(t_now) {
                let t_f = Instant::now();
                let s = match engine.try_download() {
                    Ok(s) => s,
                    Err(e) => {
                        return Ok(Outcome::Failed(format!("{e} (last good checkpoint kept)")))
                    }
                };
                let contacts = if obs.needs_contacts() {
                    match engine.contacts() {
                        Ok(c) => Some(c),
                        Err(e) => {
                            return Ok(Outcome::Failed(format!(
                                "contact stress: {e} (last good checkpoint kept)"
                            )))
                        }
                    }
                } else {
                    None
                };
                obs.sample(t_now, &s, contacts.as_deref());
                prog.fields_wall_s += t_f.elapsed().as_secs_f64();
            }
        }
        if t_now >= st.skip_initial_s - 1e-12 {
            match engine.kinetic_energy() {
                Ok(e) => prog.numerics.energy.add(t_now, e),
                Err(e) => return Ok(Outcome::Failed(format!("{e} (last good checkpoint kept)"))),
            }
        }
        prog.wall_time_s = wall0 + started.elapsed().as_secs_f64();
        let saved = if prog.chunk % ckpt_every == 0 {
            Some(save(&mut engine, &prog)?)
        } else {
            None
        };
        if saved.is_some() || last_beat.elapsed().as_secs_f64() > 2.0 {
            let path = saved.map(|p| p.display().to_string());
            jobs::heartbeat(
                conn,
                job.id,
                lease,
                t_now,
                t_now / target,
                prog.particle_steps,
                prog.wall_time_s,
                path.as_deref(),
            )?;
            last_beat = Instant::now();
        }
        if let Some(p) = &ctx.progress {
            p(t_now, target, rate);
        }
    }
    let t_end = prog.chunk as f64 * chunk_dt;
    let summary = prog.discharge.summarize(t_end);
    let results = SiloResults {
        orifice_diameter_m: scene.p.orifice_diameter_m,
        rotation_frequency_hz: scene.p.rotation_frequency_hz,
        particle_diameter_m: scene.p.particle_diameter_m,
        bulk_density_kg_per_m3: prog.bulk_density,
        discharge: prog.discharge.clone(),
        summary,
        wall_time_s: wall0 + started.elapsed().as_secs_f64(),
        particle_steps: prog.particle_steps,
        sim_time_s: t_end,
        dt_s: scene.dt,
        numerics: prog.numerics.clone(),
        fields: prog.fields.clone(),
    };
    if prog.fields.is_some() {
        (ctx.log)(format!(
            "job {}: field observer took {:.2} s of {:.2} s wall time",
            job.id, prog.fields_wall_s, results.wall_time_s
        ));
    }
    results.commit(conn, job.id)?;
    Ok(Outcome::Done)
}
