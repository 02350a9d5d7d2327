//! One job's lifecycle, whatever the study: resume from the latest valid checkpoint or start
//! afresh, build the backend and record it, then the chunk loop (snapshots, interrupt, advance,
//! observe, checkpoint, heartbeat, progress) and the results. A study (silo, chute, the next
//! one) plugs in through `Study`: how it starts, what it observes after each chunk, when it is
//! done and what it stores. Checkpoints are written only between chunks, so a resumed run
//! repeats exactly the same operations. (The claim, the OS lock and the heartbeat thread are
//! the executor's: `pool`, `slurm::task`.)

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

use anyhow::Context;
use rusqlite::Connection;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use super::backend::{self, BackendChoice, GpuSelect};
use crate::campaign::JobSpec;
use crate::checkpoint::{self, Header};
use crate::engine::cpu_clock;
use crate::engine::translated::{self, Translated};
use crate::engine::{Backend, ChunkReport, EngineConfig, State};
use crate::observe::snapshots::SnapshotWriter;
use crate::store::jobs::{self, JobRow, Lease};

/// How a job run ended.
#[derive(Debug, PartialEq)]
pub enum Outcome {
    Done,
    /// Interrupted (SIGINT/SIGTERM); its checkpoint is current (or, before the first one, the
    /// job starts again).
    Paused,
    Failed(String),
}

/// Progress callback: (simulated time, target, particle-steps/s).
pub type ProgressFn = Arc<dyn Fn(f64, f64, f64) + Send + Sync>;

/// Where and how jobs run.
#[derive(Clone)]
pub struct JobContext {
    /// Checkpoints and shared stages live under here.
    pub work_dir: PathBuf,
    pub backend: BackendChoice,
    /// Which GPU adapter (`--gpu N`, `--allow-software-gpu`).
    pub gpu: GpuSelect,
    /// The engines GPU jobs of this run share (`--batch`), if they do.
    pub batches: Option<Arc<super::gpu_batch::GpuBatches>>,
    pub threads: usize,
    /// Simulated seconds between checkpoints.
    pub checkpoint_interval_s: f64,
    pub interrupt: Arc<AtomicBool>,
    /// Called with (simulated time, target, particle-steps/s) after each chunk.
    pub progress: Option<ProgressFn>,
    /// Messages for the user (refused checkpoints, restarts, fill stage reuse).
    pub log: Arc<dyn Fn(String) + Send + Sync>,
}

pub use crate::campaign::job_dir;

/// What every study's checkpoint keeps about the run itself (flattened into its progress
/// record, so the checkpoint's JSON keeps its fields where they always were).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Ledger {
    /// Chunks run so far.
    pub chunk: u64,
    pub particle_steps: u64,
    pub wall_time_s: f64,
    #[serde(default)]
    pub numerics: crate::store::JobNumerics,
    /// The job's clock (s): chunks × chunk length, the time observers and snapshot frames are
    /// stamped with (the engine's own clock may include a shared fill stage). Read by `export`.
    #[serde(default)]
    pub job_time_s: f64,
    /// CPU seconds the job's threads have run: the thread that runs it and its engines'
    /// workers. None when part of the job ran before sweep counted it (a checkpoint without
    /// it), so that a partial count is never taken for the whole.
    #[serde(default)]
    pub cpu_time_s: Option<f64>,
}

impl Default for Ledger {
    fn default() -> Self {
        Self {
            chunk: 0,
            particle_steps: 0,
            wall_time_s: 0.0,
            numerics: Default::default(),
            job_time_s: 0.0,
            cpu_time_s: Some(0.0),
        }
    }
}

/// How a fresh start went.
pub enum Start<P> {
    Ready(Box<State<f64>>, P),
    /// Interrupted before the job had a state of its own (in the silo's fill stage).
    Paused,
}

/// The job, as a study's hooks see it.
pub struct JobRun<'a> {
    pub conn: &'a Connection,
    pub job: &'a JobRow,
    pub lease: &'a Lease,
    pub ctx: &'a JobContext,
}

impl JobRun<'_> {
    pub fn log(&self, message: String) {
        (self.ctx.log)(format!("job {}: {message}", self.job.id))
    }
}

/// A study plugged into the job lifecycle.
pub trait Study {
    /// What a checkpoint keeps besides the particles (with its `Ledger` flattened in).
    type Progress: Serialize + DeserializeOwned;

    fn spec(&self) -> &JobSpec;
    fn ledger(p: &Self::Progress) -> &Ledger;
    fn ledger_mut(p: &mut Self::Progress) -> &mut Ledger;
    /// A fresh start: the initial state and progress.
    ///
    /// # Errors
    /// Database and I/O errors.
    fn start(&self, run: &JobRun) -> anyhow::Result<Start<Self::Progress>>;
    /// The engine for the chunks.
    fn engine_config(&self) -> EngineConfig;
    /// Steps per chunk (a chunk is the sampling interval of the study's observers).
    fn chunk_steps(&self) -> u64;
    /// The time step (s).
    fn dt(&self) -> f64;
    /// Where a resumed job stands, for the log ("t = 1.2 s after opening").
    fn describe_resume(&self, s: &State<f64>, p: &Self::Progress) -> String;
    /// Why a checkpoint's progress cannot be continued (written by an older rule whose results
    /// would be wrong), if it cannot: it is then refused like a corrupt one.
    fn refuse_checkpoint(&self, _p: &Self::Progress) -> Option<String> {
        None
    }
    /// What the job is doing at this point ('discharge', 'flow', 'measure').
    fn stage(&self, p: &Self::Progress) -> &'static str;
    /// Whether the job has reached its end at simulated time `t`.
    fn done(&self, p: &Self::Progress, t: f64) -> bool;
    /// The simulated time the job is heading for, for progress and ETA.
    fn end_time(&self, p: &Self::Progress) -> f64;
    /// Observes the engine after a chunk ending at `t`. Ok(Err(reason)) fails the job.
    ///
    /// # Errors
    /// Database and I/O errors.
    fn observe(
        &self,
        run: &JobRun,
        p: &mut Self::Progress,
        engine: &mut dyn Backend,
        report: &ChunkReport,
        t: f64,
    ) -> anyhow::Result<Result<(), String>>;
    /// Stores the results and marks the job done, in one transaction.
    ///
    /// # Errors
    /// Database errors.
    fn finish(
        &self,
        conn: &mut Connection,
        job: &JobRow,
        ctx: &JobContext,
        p: Self::Progress,
        t_end: f64,
    ) -> anyhow::Result<()>;
}

/// Downloads the engine's state and writes it with the job's progress record `prog` as the
/// job's next checkpoint (only ever between chunks, so a resumed run repeats the same steps).
pub fn save_checkpoint<P: Serialize>(
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

/// Runs (or resumes) one job of `study` to its end, an interruption, or a failure.
///
/// # Errors
/// Database and I/O errors; physics failures are an `Outcome::Failed` instead.
pub fn run<S: Study>(
    conn: &mut Connection,
    job: &JobRow,
    lease: &Lease,
    ctx: &JobContext,
    study: &S,
) -> anyhow::Result<Outcome> {
    let dir = job_dir(&ctx.work_dir, &job.hash);
    let started = Instant::now();
    let thread_cpu0 = cpu_clock::this_thread_s();
    // This process holds the job's lock: temp files of a killed writer are leftovers.
    checkpoint::remove_leftovers(&dir);
    let Some((state, mut prog)) = resume_or_start(conn, job, lease, ctx, study, &dir)? else {
        return Ok(Outcome::Paused);
    };
    let spec = study.spec();
    let built = build_engine(ctx, study, &state);
    let (mut engine, note) = match built {
        Ok(b) => (b.engine, b.note),
        Err(e) => return Ok(Outcome::Failed(format!("{e:#}"))),
    };
    drop(state);
    if let Some(n) = &note {
        backend::say_once(n, ctx.log.as_ref());
    }
    let info = engine.describe();
    jobs::set_backend(
        conn,
        job.id,
        &info.kind,
        &info.adapter,
        &info.precision,
        note.as_deref(),
        ctx.threads,
    )?;
    jobs::set_stage(conn, job.id, lease, study.stage(&prog))?;

    let chunk_steps = study.chunk_steps();
    let chunk_dt = chunk_steps as f64 * study.dt();
    let ckpt_every = ((ctx.checkpoint_interval_s / chunk_dt).round() as u64).max(1);
    let wall0 = S::ledger(&prog).wall_time_s;
    let cpu0 = S::ledger(&prog).cpu_time_s;
    // The job's CPU time so far: what it had, this thread's since the start (its fill stage
    // included) and the engine's workers'.
    let cpu_now = |engine: &dyn Backend| -> Option<f64> {
        Some(cpu0? + cpu_clock::this_thread_s()? - thread_cpu0? + engine.workers_cpu_s()?)
    };
    // The ledger's wall and CPU time up to now.
    let account = |l: &mut Ledger, engine: &dyn Backend| {
        l.wall_time_s = wall0 + started.elapsed().as_secs_f64();
        l.cpu_time_s = cpu_now(engine);
    };
    let mut last_beat = Instant::now();
    let save = |engine: &mut Box<dyn Backend>, prog: &S::Progress| {
        save_checkpoint(&dir, &job.hash, engine.as_mut(), &info, prog)
    };
    let snapshots =
        SnapshotWriter::new(spec.observers.snapshots.as_ref(), &dir, &job.hash, chunk_dt);
    loop {
        let t = S::ledger(&prog).chunk as f64 * chunk_dt;
        // Frames at chunk boundaries only, so a resumed run rewrites the same ones.
        snapshots.at_chunk(S::ledger(&prog).chunk, t, || engine.try_download())?;
        if study.done(&prog, t) {
            break;
        }
        if ctx.interrupt.load(Ordering::SeqCst) {
            // The leg's time since its last chunk (all of it, when it ran none) goes too.
            account(S::ledger_mut(&mut prog), engine.as_ref());
            let path = save(&mut engine, &prog)?;
            let l = S::ledger(&prog);
            jobs::heartbeat(
                conn,
                job.id,
                lease,
                t,
                (t / study.end_time(&prog)).min(1.0),
                l.particle_steps,
                l.wall_time_s,
                l.cpu_time_s,
                Some(&path.display().to_string()),
            )?;
            return Ok(Outcome::Paused);
        }
        let t0 = Instant::now();
        let report = match engine.advance(chunk_steps) {
            Ok(r) => r,
            Err(e) => return Ok(Outcome::Failed(format!("{e} (last good checkpoint kept)"))),
        };
        let rate = report.particle_steps as f64 / t0.elapsed().as_secs_f64().max(1e-9);
        let l = S::ledger_mut(&mut prog);
        l.chunk += 1;
        l.particle_steps += report.particle_steps;
        l.numerics.add(&report);
        let t_now = l.chunk as f64 * chunk_dt;
        l.job_time_s = t_now;
        let run = JobRun {
            conn,
            job,
            lease,
            ctx,
        };
        if let Err(reason) = study.observe(&run, &mut prog, engine.as_mut(), &report, t_now)? {
            return Ok(Outcome::Failed(reason));
        }
        account(S::ledger_mut(&mut prog), engine.as_ref());
        let saved = if S::ledger(&prog).chunk % ckpt_every == 0 {
            Some(save(&mut engine, &prog)?)
        } else {
            None
        };
        let end = study.end_time(&prog);
        if saved.is_some() || last_beat.elapsed().as_secs_f64() > 2.0 {
            let path = saved.map(|p| p.display().to_string());
            let l = S::ledger(&prog);
            jobs::heartbeat(
                conn,
                job.id,
                lease,
                t_now,
                (t_now / end).min(1.0),
                l.particle_steps,
                l.wall_time_s,
                l.cpu_time_s,
                path.as_deref(),
            )?;
            last_beat = Instant::now();
        }
        if let Some(p) = &ctx.progress {
            p(t_now, end, rate);
        }
    }
    let t_end = S::ledger(&prog).chunk as f64 * chunk_dt;
    account(S::ledger_mut(&mut prog), engine.as_ref());
    jobs::set_cpu_time(conn, job.id, lease, S::ledger(&prog).cpu_time_s)?;
    study.finish(conn, job, ctx, prog, t_end)?;
    Ok(Outcome::Done)
}

/// The job's state and progress: from its latest valid checkpoint in `dir` (a checkpoint past
/// the job's end is skipped), else from the study's start; None when the start was interrupted
/// before the job had a state of its own.
fn resume_or_start<S: Study>(
    conn: &mut Connection,
    job: &JobRow,
    lease: &Lease,
    ctx: &JobContext,
    study: &S,
    dir: &Path,
) -> anyhow::Result<Option<(State<f64>, S::Progress)>> {
    // A checkpoint past the job's end (left by a longer run of the same job, its database
    // since deleted) would end the job at once with a longer run's results: skip it.
    let (found, refused) = checkpoint::load_latest_where(dir, &job.hash, |(_, _, _, extra)| {
        let Ok(p) = serde_json::from_str::<S::Progress>(extra) else {
            return Ok(());
        };
        if let Some(why) = study.refuse_checkpoint(&p) {
            return Err(why);
        }
        let (t, end) = (S::ledger(&p).job_time_s, study.end_time(&p));
        if t > end + 1e-9 {
            Err(format!(
                "it is at t = {t:.3} s, past this job's end ({end:.3} s)"
            ))
        } else {
            Ok(())
        }
    });
    for r in refused {
        (ctx.log)(format!("job {}: {r}", job.id));
    }
    Ok(Some(match found {
        Some((path, _, s, extra)) => {
            let prog = serde_json::from_str::<S::Progress>(&extra)
                .with_context(|| format!("{}: progress record unreadable", path.display()))?;
            (ctx.log)(format!(
                "job {}: resuming from {} ({})",
                job.id,
                path.display(),
                study.describe_resume(&s, &prog)
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
            let run = JobRun {
                conn,
                job,
                lease,
                ctx,
            };
            match study.start(&run)? {
                Start::Ready(s, p) => (*s, p),
                Start::Paused => return Ok(None),
            }
        }
    }))
}

/// The job's engine on its backend, translated to the scene's origin when it has one.
fn build_engine<S: Study>(
    ctx: &JobContext,
    study: &S,
    state: &State<f64>,
) -> anyhow::Result<backend::Built> {
    let spec = study.spec();
    let origin = spec.origin_m();
    if origin == [0.0; 3] {
        backend::build_shared(
            backend::for_job(spec, ctx.backend),
            &ctx.gpu,
            ctx.batches.as_deref(),
            spec.precision,
            study.engine_config(),
            state,
            ctx.threads,
        )
    } else {
        backend::build_shared(
            backend::for_job(spec, ctx.backend),
            &ctx.gpu,
            ctx.batches.as_deref(),
            spec.precision,
            translated::config(&study.engine_config(), origin),
            &translated::state(state, origin),
            ctx.threads,
        )
        .map(|b| backend::Built {
            engine: Box::new(Translated::new(b.engine, origin)) as Box<dyn Backend>,
            note: b.note,
        })
    }
}
