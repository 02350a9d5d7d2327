//! `sweep launch` and `sweep resume`, on either executor: this machine (the pool) or Slurm.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use anyhow::Context;
use sweep::campaign::ExecutorKind;
use sweep::runner::backend::{auto_summary, BackendChoice};
use sweep::runner::slurm;
use sweep::runner::{run_pending, PoolOptions};
use sweep::store::slurm_tasks;

use super::DbArg;

/// How pending jobs run (shared by launch and resume).
#[derive(clap::Args)]
pub struct RunArgs {
    #[command(flatten)]
    pub db: DbArg,
    /// auto (a GPU when there is one, else the CPU), gpu or cpu.
    #[arg(long, default_value = "auto")]
    pub backend: BackendChoice,
    /// Jobs run at the same time.
    #[arg(long, default_value_t = 1)]
    pub parallel: usize,
    /// Engine threads per job (0: cores / parallel).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
}

#[derive(clap::Args)]
pub struct Arguments {
    /// Campaign file (JSON).
    pub file: PathBuf,
    #[command(flatten)]
    pub run: RunArgs,
    #[command(flatten)]
    pub exec: super::submit::ExecutorArgs,
}

#[derive(clap::Args)]
pub struct ResumeArguments {
    #[command(flatten)]
    pub run: RunArgs,
    /// A running job whose heartbeat is older than this (s) is taken as dead.
    #[arg(long, default_value_t = 30.0)]
    pub stale_after: f64,
    /// Failed jobs are retried until they have had this many attempts.
    #[arg(long, default_value_t = 3)]
    pub max_attempts: i64,
    /// Where resumed jobs run: local or slurm (default: where each job last ran; Slurm jobs
    /// are resubmitted with the settings of their last submission).
    #[arg(long)]
    pub executor: Option<ExecutorKind>,
}

/// The work directory (checkpoints, shared stages) of a database.
pub fn work_dir(db: &Path) -> PathBuf {
    let stem = db
        .file_stem()
        .map_or_else(|| "sweep".into(), |s| s.to_string_lossy().into_owned());
    db.parent()
        .unwrap_or(Path::new("."))
        .join("sweep-work")
        .join(stem)
}

/// First Ctrl-C (or SIGTERM): checkpoint and stop at the next chunk; second: exit at once.
fn interrupt_flag() -> Arc<AtomicBool> {
    let flag = Arc::new(AtomicBool::new(false));
    let f = flag.clone();
    let _ = ctrlc::set_handler(move || {
        if f.swap(true, Ordering::SeqCst) {
            eprintln!("sweep: second interrupt, exiting without checkpoint");
            std::process::exit(130);
        }
        eprintln!("sweep: interrupt: writing checkpoints, then stopping (again to exit at once)");
    });
    flag
}

/// Runs the pending jobs (of `campaign`, or all) and prints how they ended; returns the exit code.
fn run_jobs(
    r: &RunArgs,
    campaign: Option<i64>,
    checkpoint_interval_s: f64,
    total: usize,
    done: usize,
) -> anyhow::Result<i32> {
    if r.backend == BackendChoice::Auto {
        eprintln!("sweep: backend auto: {}", auto_summary());
    }
    let opts = PoolOptions {
        db: r.db.db.clone(),
        work_dir: work_dir(&r.db.db),
        campaign,
        parallel: r.parallel,
        threads: r.threads,
        backend: r.backend,
        checkpoint_interval_s,
        interrupt: interrupt_flag(),
        bars: std::io::stderr().is_terminal(),
    };
    let s = run_pending(&opts, total, done).context("running jobs")?;
    Ok(finish(s, &r.db.db))
}

fn finish(s: sweep::runner::pool::PoolSummary, db: &Path) -> i32 {
    println!(
        "{} job(s) done, {} failed, {} paused",
        s.done, s.failed, s.paused
    );
    if s.paused > 0 {
        println!("continue with: sweep resume --db {}", db.display());
    }
    if s.failed > 0 {
        println!("see the errors with: sweep status --db {}", db.display());
        1
    } else {
        0
    }
}

pub fn launch(a: Arguments) -> anyhow::Result<i32> {
    let (file, jobs) = match sweep::campaign::load(&a.file) {
        Ok(x) => x,
        Err(e) => {
            eprintln!("sweep: error: {e}");
            return Ok(2);
        }
    };
    let executor = a.exec.executor.unwrap_or(file.run.executor);
    if executor == ExecutorKind::Slurm {
        return super::submit::launch_slurm(&a, &file, &jobs);
    }
    let flags = a.exec.slurm_flags();
    if !flags.is_empty() {
        eprintln!(
            "sweep: error: {} apply to the Slurm executor: add --executor slurm (`sweep plan FILE` is the local dry run)",
            flags.join(", ")
        );
        return Ok(2);
    }
    let mut conn = sweep::store::open(&a.run.db.db)?;
    let (cid, added) =
        sweep::store::jobs::register(&mut conn, &a.file.display().to_string(), &file, &jobs)?;
    let done: i64 = conn.query_row(
        "SELECT COUNT(*) FROM jobs j JOIN campaign_jobs cj ON cj.job_id = j.id WHERE cj.campaign_id = ?1 AND j.status = 'done'",
        [cid],
        |r| r.get(0),
    )?;
    println!(
        "campaign {}: {} job(s), {} new, {} already done (database {})",
        file.name,
        jobs.len(),
        added,
        done,
        a.run.db.db.display()
    );
    run_jobs(
        &a.run,
        Some(cid),
        file.run.checkpoint_interval_s,
        jobs.len(),
        done as usize,
    )
}

pub fn resume(a: ResumeArguments) -> anyhow::Result<i32> {
    if !a.run.db.db.exists() {
        eprintln!(
            "sweep: no database at {}: nothing to resume; start with `sweep launch FILE`",
            a.run.db.db.display()
        );
        return Ok(2);
    }
    let db = &a.run.db.db;
    let mut conn = sweep::store::open(db)?;
    let slurm_used = slurm_tasks::any(&conn)?;
    if slurm_used {
        let r = slurm::collect(&mut conn, &work_dir(db))?;
        super::collect::print_report(&r);
    }
    let n = slurm_tasks::release_stale_submissions(&conn, a.stale_after)?
        + sweep::store::jobs::requeue(&mut conn, a.stale_after, a.max_attempts)?;
    let (total, done): (i64, i64) = conn.query_row(
        "SELECT COUNT(*), COALESCE(SUM(status = 'done'), 0) FROM jobs",
        [],
        |r| Ok((r.get(0)?, r.get(1)?)),
    )?;
    println!("{n} job(s) to resume, {done} of {total} already done");
    if let Some(code) = super::submit::resume_on_slurm(&mut conn, db, &a, slurm_used)? {
        return Ok(code);
    }
    // Each job's own campaign sets its checkpoint interval; this is the fallback.
    run_jobs(
        &a.run,
        None,
        sweep::campaign::RunSettings::default().checkpoint_interval_s,
        total as usize,
        done as usize,
    )
}
