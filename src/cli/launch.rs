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
use sweep::store::job_counts;
use sweep::store::slurm_tasks;

use super::run_args::{Arguments, ResumeArguments, RunArgs};
use super::shared::{print_report, register, work_dir, EXIT_PAUSED};

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
    work: PathBuf,
    campaign: Option<i64>,
    max_attempts: Option<i64>,
    checkpoint_interval_s: f64,
    total: usize,
    done: usize,
) -> anyhow::Result<i32> {
    if r.backend == BackendChoice::Auto {
        eprintln!("sweep: backend auto: {}", auto_summary());
    }
    let opts = PoolOptions {
        db: r.db.db.clone(),
        work_dir: work,
        campaign,
        parallel: r.parallel,
        threads: r.threads,
        backend: r.backend,
        checkpoint_interval_s,
        max_attempts,
        interrupt: interrupt_flag(),
        bars: std::io::stderr().is_terminal(),
    };
    let s = run_pending(&opts, total, done).context("running jobs")?;
    let interrupted = opts.interrupt.load(Ordering::SeqCst);
    Ok(finish(s, interrupted, &r.db.db))
}

fn finish(s: sweep::runner::pool::PoolSummary, interrupted: bool, db: &Path) -> i32 {
    println!(
        "{} job(s) done, {} failed, {} paused",
        s.done, s.failed, s.paused
    );
    if s.failed > 0 {
        println!("see the errors with: sweep status --db {}", db.display());
    }
    if s.paused > 0 || interrupted {
        println!(
            "interrupted: continue with: sweep resume --db {}",
            db.display()
        );
        EXIT_PAUSED
    } else if s.failed > 0 {
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
    let db = &a.run.db.db;
    let mut conn = sweep::store::open(db)?;
    let (cid, version, added) = match register(&mut conn, &a, &file, &jobs)? {
        Ok(x) => x,
        Err(code) => return Ok(code),
    };
    let done = job_counts::campaign_done_count(&conn, cid)?;
    println!(
        "campaign {}{}: {} job(s), {} new, {} already done (database {})",
        file.name,
        if version > 1 {
            format!(" (version {version})")
        } else {
            String::new()
        },
        jobs.len(),
        added,
        done,
        db.display()
    );
    let work = work_dir(&conn, db)?;
    drop(conn);
    run_jobs(
        &a.run,
        work,
        Some(cid),
        None,
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
    let work = work_dir(&conn, db)?;
    let slurm_used = slurm_tasks::any(&conn)?;
    if slurm_used {
        let r = slurm::collect(&mut conn, &work)?;
        print_report(&r);
    }
    let released = slurm_tasks::release_stale_submissions(&conn, a.stale_after)?;
    let decisions = sweep::store::jobs::requeue(&mut conn, a.max_attempts, |j| {
        sweep::runner::job_lock::liveness(&work, j, a.stale_after)
    })?;
    let resumed = decisions.iter().filter(|d| d.action == "pending").count();
    let job_counts::JobTotals { total, done } = job_counts::job_totals(&conn)?;
    println!(
        "{} job(s) to resume, {done} of {total} already done",
        resumed + released
    );
    for d in &decisions {
        if d.why != "not started yet" {
            let what = match d.action {
                "pending" => "resumed",
                "failed" => "marked failed",
                _ => "left alone",
            };
            println!("  job {} {what}: {} ({})", d.job.id, d.why, d.job.label);
        }
    }
    if let Some(code) = super::submit::resume_on_slurm(&mut conn, db, &a, slurm_used)? {
        return Ok(code);
    }
    drop(conn);
    // Each job's own campaign sets its checkpoint interval; this is the fallback.
    let code = run_jobs(
        &a.run,
        work,
        None,
        a.max_attempts,
        sweep::campaign::RunSettings::default().checkpoint_interval_s,
        total as usize,
        done as usize,
    )?;
    let marked_failed = decisions.iter().any(|d| d.action == "failed");
    Ok(if code == 0 && marked_failed { 1 } else { code })
}
