//! One array task (`sweep run-job`): runs one job with the local executor's job runner, in the
//! job's own directory on shared storage, against a job-local store kept in memory (built from
//! the job file written at submission). The main database is never opened here.
//!
//! - Done: the in-memory store is written as `result.db` (VACUUM INTO, fsync, rename), then
//!   `result.json` with its checksum and row counts. `sweep collect` verifies and ingests them.
//! - SIGUSR1 (Slurm's warning before the time limit or a preemption): checkpoint, then
//!   `scontrol requeue` of itself, so the job continues from that checkpoint when Slurm next
//!   schedules it. SIGTERM or SIGINT (`scontrol requeue`, preemption, `scancel`, the time
//!   limit): checkpoint and exit; Slurm requeues it if that was the reason.
//! - Failed: `failed.json` with the error.
//! - Started again on a job whose result verifies: nothing to do (a job finishes once).

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use anyhow::Context;

use super::files::{self, FailedMarker, ProgressFile, TaskSpec};
use super::query;
use crate::runner::backend::{BackendChoice, GpuSelect};
use crate::runner::chute_job::run_chute_job;
use crate::runner::job::{JobContext, Outcome, ProgressFn};
use crate::runner::silo_job::run_silo_job;
use crate::store::jobs::{self, JobRow, Lease, TaskJob};

/// What `sweep run-job` was asked to do.
pub struct TaskOptions {
    /// The work directory of the database (shared storage).
    pub work_dir: PathBuf,
    pub job_id: i64,
    pub backend: BackendChoice,
    /// Which GPU adapter (`--gpu N`, `--allow-software-gpu`).
    pub gpu: GpuSelect,
    /// Engine threads; 0: SLURM_CPUS_PER_TASK, else 1.
    pub threads: usize,
}

/// How a task ended.
#[derive(Debug, PartialEq)]
pub enum TaskEnd {
    /// The job finished here; its result files are written.
    Done,
    /// The job had already finished (its result verifies): nothing was run.
    AlreadyDone,
    /// Checkpointed on a signal; `requeued` is the Slurm job id that asked to be requeued.
    Paused {
        requeued: Option<String>,
    },
    Failed(String),
}

/// `array_task` of the calling task, or its job id, when run by Slurm.
fn slurm_task() -> Option<String> {
    match (
        std::env::var("SLURM_ARRAY_JOB_ID"),
        std::env::var("SLURM_ARRAY_TASK_ID"),
    ) {
        (Ok(a), Ok(t)) => Some(format!("{a}_{t}")),
        _ => std::env::var("SLURM_JOB_ID").ok(),
    }
}

/// Runs the job of an array task to its end, a signal or a failure.
///
/// # Errors
/// Signal handlers that cannot be installed, a missing job file, I/O and database errors.
pub fn run_task(o: &TaskOptions) -> anyhow::Result<TaskEnd> {
    use signal_hook::consts::{SIGINT, SIGTERM, SIGUSR1};
    // NOTE: first of all, so that a signal never finds the default action (USR1 would kill us
    // without a checkpoint).
    let interrupt = Arc::new(AtomicBool::new(false));
    let usr1 = Arc::new(AtomicBool::new(false));
    for sig in [SIGINT, SIGTERM, SIGUSR1] {
        signal_hook::flag::register(sig, interrupt.clone())?;
    }
    signal_hook::flag::register(SIGUSR1, usr1.clone())?;

    let spec = files::read_spec(&o.work_dir, o.job_id)?;
    let dir = files::job_dir(&o.work_dir, &spec.hash);
    std::fs::create_dir_all(&dir).with_context(|| format!("{}", dir.display()))?;
    let me = slurm_task();
    let restarts = std::env::var("SLURM_RESTART_COUNT").unwrap_or_else(|_| "0".into());
    eprintln!(
        "sweep run-job: job {} ({}) in {}, Slurm task {}, restart {restarts}",
        spec.job_id,
        spec.label,
        dir.display(),
        me.as_deref().unwrap_or("(none)")
    );
    match files::verify_result(&dir, spec.job_id, &spec.hash) {
        Ok(Some(_)) => return Ok(TaskEnd::AlreadyDone),
        Ok(None) => {}
        Err(why) => {
            eprintln!(
                "sweep run-job: job {}: the result in {} does not verify ({why}): running the job again from its last checkpoint",
                spec.job_id,
                dir.display()
            );
            files::remove_result(&dir);
        }
    }
    let _ = std::fs::remove_file(dir.join("failed.json"));

    let threads = if o.threads > 0 {
        o.threads
    } else {
        std::env::var("SLURM_CPUS_PER_TASK")
            .ok()
            .and_then(|n| n.parse().ok())
            .unwrap_or(1)
    };
    let last_sim = files::read_json::<ProgressFile>(&dir.join("progress.json"))
        .ok()
        .flatten()
        .map_or(0.0, |p| p.sim_time_s);
    let mut conn = crate::store::open_in_memory(None)?;
    let lease = Lease::new();
    jobs::insert_running(
        &conn,
        &TaskJob {
            id: spec.job_id,
            hash: &spec.hash,
            scene: &spec.scene,
            params_json: &spec.params_json,
            seed: spec.seed,
            sim_time_s: spec.sim_time_s.max(last_sim),
            target_time_s: spec.target_time_s,
            lease: &lease,
        },
    )?;
    let job = JobRow {
        id: spec.job_id,
        hash: spec.hash.clone(),
        params_json: spec.params_json.clone(),
        status: "running".into(),
        attempts: 1,
        sim_time_s: spec.sim_time_s.max(last_sim),
        target_time_s: spec.target_time_s,
        label: spec.label.clone(),
        max_attempts: 1,
    };
    let ctx = JobContext {
        work_dir: o.work_dir.clone(),
        backend: o.backend,
        gpu: o.gpu,
        // One device for the job's fill and run; a task runs one job, so no engine is shared.
        batches: Some(std::sync::Arc::new(
            crate::runner::gpu_batch::GpuBatches::new(1),
        )),
        threads,
        checkpoint_interval_s: spec.checkpoint_interval_s,
        interrupt: interrupt.clone(),
        progress: Some(progress_writer(&dir, &spec, me.clone())),
        log: Arc::new(|s| eprintln!("{s}")),
    };
    let run = match spec.scene.as_str() {
        "chute" => run_chute_job,
        _ => run_silo_job,
    };
    let outcome = match run(&mut conn, &job, &lease, &ctx) {
        Ok(o) => o,
        // Stopped while waiting for a shared stage: nothing of this job is lost.
        Err(e) if interrupt.load(Ordering::SeqCst) => {
            eprintln!("sweep run-job: job {}: {e:#}", spec.job_id);
            Outcome::Paused
        }
        Err(e) => Outcome::Failed(format!("{e:#}")),
    };
    match outcome {
        Outcome::Done => {
            files::write_result(&dir, &conn, &spec, me, files::host())?;
            println!("job {} done: {}", spec.job_id, spec.label);
            Ok(TaskEnd::Done)
        }
        Outcome::Paused if usr1.load(Ordering::SeqCst) => {
            println!(
                "job {} checkpointed on SIGUSR1 (time limit or preemption near)",
                spec.job_id
            );
            match query::requeue_self() {
                Ok(id) => Ok(TaskEnd::Paused { requeued: Some(id) }),
                Err(e) => {
                    eprintln!("sweep run-job: job {}: cannot requeue itself: {e}; `sweep resume` resubmits it from its checkpoint", spec.job_id);
                    Ok(TaskEnd::Paused { requeued: None })
                }
            }
        }
        Outcome::Paused => {
            println!(
                "job {} checkpointed on SIGTERM/SIGINT and stopped",
                spec.job_id
            );
            Ok(TaskEnd::Paused { requeued: None })
        }
        Outcome::Failed(e) => {
            files::write_json(
                &dir.join("failed.json"),
                &FailedMarker {
                    job_id: spec.job_id,
                    hash: spec.hash.clone(),
                    error: e.clone(),
                    slurm_job: me,
                },
            )?;
            println!("job {} failed: {e}", spec.job_id);
            Ok(TaskEnd::Failed(e))
        }
    }
}

/// The progress callback: `progress.json` rewritten at most every second.
fn progress_writer(dir: &Path, spec: &TaskSpec, me: Option<String>) -> ProgressFn {
    let path = dir.join("progress.json");
    let job_id = spec.job_id;
    let started = Instant::now();
    let last: Mutex<Option<Instant>> = Mutex::new(None);
    Arc::new(move |t, target, rate| {
        let mut last = last.lock().expect("progress lock");
        if last.is_some_and(|l| l.elapsed().as_secs_f64() < 1.0) {
            return;
        }
        *last = Some(Instant::now());
        let p = ProgressFile {
            job_id,
            sim_time_s: t,
            target_time_s: target,
            particle_steps_per_s: rate,
            wall_time_s: started.elapsed().as_secs_f64(),
            slurm_job: me.clone(),
        };
        // Progress is a courtesy to `sweep status`: a failed write costs nothing else.
        let _ = files::write_json(&path, &p);
    })
}
