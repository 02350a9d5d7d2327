//! The silo study: a shared fill stage, then the discharge in chunks of one sampling interval
//! (M(t), clogs, Q; optionally coarse-grained fields), and the results written with the job's
//! completion in one transaction. The lifecycle around it is `job::run`.

use std::path::Path;
use std::sync::atomic::Ordering;
use std::time::Instant;

use anyhow::Context;
use rusqlite::Connection;
use serde::{Deserialize, Serialize};

use super::backend::{self, BackendChoice};
use super::job::{self, JobContext, JobRun, Ledger, Outcome, Start, Study};
use super::job_lock::DirLock;
use crate::campaign::JobSpec;
use crate::checkpoint::{self, Header};
use crate::engine::cpu_clock;
use crate::engine::{Backend, ChunkReport, EngineConfig, State};
use crate::observe::discharge::Discharge;
use crate::observe::silo_fields::SiloFieldObserver;
use crate::scene::silo::{SiloPhase, SiloScene};
use crate::store::jobs::{self, JobRow, Lease};
use crate::store::SiloResults;

/// What a checkpoint keeps besides the particles.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Progress {
    t_open: f64,
    step_open: u64,
    #[serde(flatten)]
    ledger: Ledger,
    bulk_density: f64,
    discharge: Discharge,
    initial_count: usize,
    /// The coarse-grained field observer (absent unless the campaign asks for it).
    #[serde(default)]
    fields: Option<SiloFieldObserver>,
    /// Wall time spent sampling fields (s), for the observer's cost.
    #[serde(default)]
    fields_wall_s: f64,
    /// Re-insertion's floor (m), fixed at the opening (scene/silo_refill.rs). Absent from
    /// checkpoints written before it was fixed: those are refused (`refuse_checkpoint`).
    #[serde(default)]
    refill_floor_m: Option<f64>,
}

/// Fills and settles the silo (orifice closed, bottom still), or reuses the stored result of the
/// same fill parameters. Returns the settled state, the particle-steps it cost (0 if reused) and
/// the CPU seconds of its workers and earlier legs (None: part of it ran before sweep counted it).
/// A GPU job fills on its GPU; its fill is stored apart from the CPU's (and each adapter's),
/// since the bits differ.
fn fill_stage(
    spec: &JobSpec,
    scene: &SiloScene,
    ctx: &JobContext,
) -> anyhow::Result<(State<f64>, u64, Option<f64>)> {
    let dev = backend::job_device(
        backend::for_job(spec, ctx.backend),
        &ctx.gpu,
        ctx.batches.as_deref(),
        spec.precision,
    )?;
    let (mut key, seed) = spec.fill_key();
    if let Some(d) = &dev {
        key = crate::campaign::key_with(&key, &format!("gpu {}", d.info.name));
    }
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
            return Ok((s, 0, Some(0.0)));
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
    fill_stage_run(spec, scene, ctx, dev.as_ref(), &dir, &key, seed)
}

/// The run was interrupted (SIGINT/SIGTERM) before its first checkpoint: the job is paused.
#[derive(Debug, thiserror::Error)]
#[error("interrupted before the first checkpoint")]
pub struct Interrupted;

fn fill_stage_run(
    spec: &JobSpec,
    scene: &SiloScene,
    ctx: &JobContext,
    dev: Option<&crate::engine::gpu::GpuDevice>,
    dir: &Path,
    key: &str,
    seed: u64,
) -> anyhow::Result<(State<f64>, u64, Option<f64>)> {
    let config = scene.engine_config(SiloPhase::Fill);
    let interrupted = || ctx.interrupt.load(Ordering::SeqCst);
    let fill_backend = if dev.is_some() { "gpu" } else { "cpu" };
    // The settling is checkpointed apart from the finished fill (which jobs reuse), so that a
    // preempted fill goes on from where it stopped instead of starting again.
    let settling = dir.join("settling");
    let (found, refused) = checkpoint::load_latest(&settling, key);
    for r in refused {
        (ctx.log)(r);
    }
    let thread0 = cpu_clock::this_thread_s();
    let (init, mut steps, cpu_before) = match found {
        Some((path, _, s, extra)) => {
            (ctx.log)(format!(
                "fill stage {}: settling goes on from {} (t = {:.3} s)",
                &key[..16],
                path.display(),
                s.time
            ));
            let spent = serde_json::from_str::<SettlingProgress>(&extra)
                .map_or((0, None), |p| (p.particle_steps, p.cpu_time_s));
            (s, spent.0, spent.1)
        }
        None => (
            scene
                .initial_state_until(seed, &interrupted)
                .ok_or(Interrupted)?,
            0,
            Some(0.0),
        ),
    };
    let mut engine: Box<dyn Backend> = match dev {
        Some(d) => Box::new(crate::engine::gpu::GpuEngine::new(
            d,
            config,
            &init,
            super::gpu_variants::gpu_options()?,
        )?),
        None => backend::build(
            BackendChoice::Cpu,
            spec.precision,
            config,
            &init,
            ctx.threads,
        )?,
    };
    let mut next_checkpoint_s = init.time + ctx.checkpoint_interval_s;
    drop(init);
    let chunk = (0.01 / scene.dt).round().max(1.0) as u64;
    // The fill's CPU time in a settling checkpoint: the earlier legs', this leg's workers' and
    // this thread's; what the job is given at the end leaves this leg's thread out (the job
    // counts its own thread from its start).
    let cpu_with_thread = |workers: Option<f64>| -> Option<f64> {
        Some(cpu_before? + workers? + cpu_clock::this_thread_s()? - thread0?)
    };
    let header = |s: &State<f64>| Header {
        job_hash: key.to_string(),
        step: s.step,
        time_s: s.time,
        backend: fill_backend.into(),
        precision: spec.precision.name().into(),
    };
    let save_settling =
        |s: &State<f64>, steps: u64, cpu_time_s: Option<f64>| -> anyhow::Result<()> {
            let h = header(s);
            let extra = serde_json::to_string(&SettlingProgress {
                particle_steps: steps,
                cpu_time_s,
            })?;
            checkpoint::save(&settling, &h, s, &extra)?;
            Ok(())
        };
    let mut s;
    loop {
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
        // Every loop that runs the engine stops on an interrupt, here after a checkpoint.
        if interrupted() {
            save_settling(&s, steps, cpu_with_thread(engine.workers_cpu_s()))?;
            return Err(Interrupted.into());
        }
        if s.time >= next_checkpoint_s {
            save_settling(&s, steps, cpu_with_thread(engine.workers_cpu_s()))?;
            next_checkpoint_s = s.time + ctx.checkpoint_interval_s;
        }
    }
    let bed = scene.bed_height(&s);
    if bed > scene.p.cylinder_height_m {
        anyhow::bail!(
            "fill stage: the settled bed is {bed:.3} m high, taller than the silo (cylinder_height_m = {} m): use fewer particles or a taller silo",
            scene.p.cylinder_height_m
        );
    }
    checkpoint::save(dir, &header(&s), &s, "{}")?;
    // The finished fill is kept: its settling checkpoints are not needed again.
    let _ = std::fs::remove_dir_all(&settling);
    let cpu = cpu_before.zip(engine.workers_cpu_s()).map(|(a, b)| a + b);
    Ok((s, steps, cpu))
}

/// What a settling checkpoint keeps besides the particles.
#[derive(Serialize, Deserialize)]
struct SettlingProgress {
    /// Particle-steps the fill has cost so far.
    particle_steps: u64,
    /// CPU seconds the fill has run so far, its workers' and its callers' (None: part of it ran
    /// before sweep counted CPU time).
    #[serde(default)]
    cpu_time_s: Option<f64>,
}

/// Mass of the free (not fixed) particles of `s` (kg): the silo's charge at opening.
fn silo_mass(s: &State<f64>) -> f64 {
    (0..s.len())
        .filter(|&i| s.inv_mass[i] != 0.0)
        .map(|i| s.mass[i])
        .sum()
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
    let chunk_steps = (spec.observers.discharge.sample_interval_s / scene.dt)
        .round()
        .max(1.0) as u64;
    // A campaign's target may have run the job on past its own discharge time.
    let end_s = job.target_time_s.max(spec.silo().discharge_time_s);
    let study = SiloStudy {
        spec,
        scene,
        chunk_steps,
        end_s,
    };
    job::run(conn, job, lease, ctx, &study)
}

/// A silo job: its parameters, its scene, its chunk and its end.
struct SiloStudy {
    spec: JobSpec,
    scene: SiloScene,
    chunk_steps: u64,
    /// Discharge time it runs to (s): its own, or longer where a target extended it.
    end_s: f64,
}

impl SiloStudy {
    fn chunk_dt(&self) -> f64 {
        self.chunk_steps as f64 * self.scene.dt
    }

    fn field_observer(&self) -> Option<SiloFieldObserver> {
        self.spec
            .observers
            .fields
            .as_ref()
            .map(|f| SiloFieldObserver::new(f, &self.scene.p, self.chunk_dt()))
    }
}

impl Study for SiloStudy {
    type Progress = Progress;

    fn spec(&self) -> &JobSpec {
        &self.spec
    }

    fn ledger(p: &Progress) -> &Ledger {
        &p.ledger
    }

    fn ledger_mut(p: &mut Progress) -> &mut Ledger {
        &mut p.ledger
    }

    fn start(&self, run: &JobRun) -> anyhow::Result<Start<Progress>> {
        jobs::set_stage(run.conn, run.job.id, run.lease, "fill")?;
        let (s, fill_steps, fill_cpu_s) = match fill_stage(&self.spec, &self.scene, run.ctx) {
            Ok(x) => x,
            Err(e) if e.is::<Interrupted>() => return Ok(Start::Paused),
            Err(e) => return Err(e),
        };
        let prog = Progress {
            t_open: s.time,
            step_open: s.step,
            ledger: Ledger {
                particle_steps: fill_steps,
                // The fill's workers; the job's own thread counts from the job's start.
                cpu_time_s: fill_cpu_s,
                ..Ledger::default()
            },
            bulk_density: self.scene.bulk_density(&s),
            discharge: Discharge::at_orifice(
                self.spec.observers.discharge.clone(),
                self.scene.p.sink_depth_m,
                self.scene.p.gravity_m_per_s2,
                (!self.scene.p.reinsert).then(|| silo_mass(&s)),
            ),
            initial_count: s.len(),
            fields: self.field_observer(),
            fields_wall_s: 0.0,
            refill_floor_m: self.scene.p.reinsert.then(|| self.scene.refill_floor(&s)),
        };
        Ok(Start::Ready(Box::new(s), prog))
    }

    fn engine_config(&self) -> EngineConfig {
        self.scene.engine_config(SiloPhase::Discharge)
    }

    fn chunk_steps(&self) -> u64 {
        self.chunk_steps
    }

    fn dt(&self) -> f64 {
        self.scene.dt
    }

    fn describe_resume(&self, s: &State<f64>, p: &Progress) -> String {
        format!("t = {:.3} s after opening", s.time - p.t_open)
    }

    fn refuse_checkpoint(&self, p: &Progress) -> Option<String> {
        (self.scene.p.reinsert && p.refill_floor_m.is_none()).then(|| {
            "it was written before re-insertion kept a fixed floor (particles could be lost \
             at a large orifice: scene/silo_refill.rs); the job starts over"
                .to_string()
        })
    }

    fn stage(&self, _: &Progress) -> &'static str {
        "discharge"
    }

    fn done(&self, p: &Progress, t_rel: f64) -> bool {
        let sp = &self.scene.p;
        // Without re-insertion the particles left are the initial ones minus those counted out.
        let remaining = p.initial_count.saturating_sub(p.discharge.count as usize);
        t_rel >= self.end_s - 1e-12
            || p.discharge.permanently_clogged(t_rel)
            || (!sp.reinsert
                && (remaining as f64) < sp.stop_remaining_fraction * p.initial_count as f64)
    }

    fn end_time(&self, _: &Progress) -> f64 {
        self.end_s
    }

    fn observe(
        &self,
        _run: &JobRun,
        p: &mut Progress,
        engine: &mut dyn Backend,
        report: &ChunkReport,
        t_now: f64,
    ) -> anyhow::Result<Result<(), String>> {
        let kept = |e: &dyn std::fmt::Display| format!("{e} (last good checkpoint kept)");
        for ev in &report.removed {
            p.discharge.record_exit(ev.time_s - p.t_open, ev.mass_kg);
        }
        if self.scene.p.reinsert && !report.removed.is_empty() {
            let mut s = match engine.try_download() {
                Ok(s) => s,
                Err(e) => return Ok(Err(kept(&e))),
            };
            let step = s.step;
            let Some(floor) = p.refill_floor_m else {
                return Ok(Err(kept(&"re-insertion has no floor")));
            };
            if let Err(e) =
                self.scene
                    .reinsert(&mut s, &report.removed, floor, self.spec.seed() ^ step)
            {
                return Ok(Err(kept(&e)));
            }
            engine.upload(&s);
        }
        p.discharge.sample(t_now);
        // A checkpoint of an older sweep may lack the observer its campaign asks for.
        if p.fields.is_none() {
            p.fields = self.field_observer();
        }
        if let Some(obs) = p.fields.as_mut() {
            if obs.samples_at(p.ledger.chunk) && obs.wanted_at(t_now) {
                let t_f = Instant::now();
                let s = match engine.try_download() {
                    Ok(s) => s,
                    Err(e) => return Ok(Err(kept(&e))),
                };
                let contacts = if obs.needs_contacts() {
                    match engine.contacts() {
                        Ok(c) => Some(c),
                        Err(e) => return Ok(Err(format!("contact stress: {}", kept(&e)))),
                    }
                } else {
                    None
                };
                obs.sample(t_now, &s, contacts.as_deref());
                p.fields_wall_s += t_f.elapsed().as_secs_f64();
            }
            // The exits of this chunk may decide whether earlier samples were flowing.
            let known = p.discharge.known_until(t_now);
            obs.settle(|t| p.discharge.flowing_at(t, known));
        }
        if t_now >= self.spec.observers.discharge.skip_initial_s - 1e-12 {
            match engine.kinetic_energy() {
                Ok(e) => p.ledger.numerics.energy.add(t_now, e),
                Err(e) => return Ok(Err(kept(&e))),
            }
        }
        Ok(Ok(()))
    }

    fn finish(
        &self,
        conn: &mut Connection,
        job: &JobRow,
        ctx: &JobContext,
        p: Progress,
        t_end: f64,
    ) -> anyhow::Result<()> {
        let sp = &self.scene.p;
        let summary = p.discharge.summarize(t_end);
        let mut p = p;
        if let Some(obs) = p.fields.as_mut() {
            // The run is over: the last gap is a clog only if it outlasted the clog time.
            obs.settle(|t| Some(p.discharge.flowing_at_end(t, t_end)));
        }
        if p.fields.is_some() {
            (ctx.log)(format!(
                "job {}: field observer took {:.2} s of {:.2} s wall time",
                job.id, p.fields_wall_s, p.ledger.wall_time_s
            ));
        }
        let results = SiloResults {
            orifice_diameter_m: sp.orifice_diameter_m,
            rotation_frequency_hz: sp.rotation_frequency_hz,
            particle_diameter_m: sp.particle_diameter_m,
            bulk_density_kg_per_m3: p.bulk_density,
            discharge: p.discharge,
            summary,
            wall_time_s: p.ledger.wall_time_s,
            particle_steps: p.ledger.particle_steps,
            sim_time_s: t_end,
            dt_s: self.scene.dt,
            numerics: p.ledger.numerics,
            fields: p.fields,
        };
        results.commit(conn, job.id)?;
        Ok(())
    }
}
