//! `sweep launch` and `sweep resume`.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use anyhow::Context;
use sweep::runner::backend::BackendChoice;
use sweep::runner::{run_pending, PoolOptions};

use super::DbArg;

#[derive(clap::Args)]
pub struct Arguments {
    /// Campaign file (JSON).
    pub file: PathBuf,
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
pub struct ResumeArguments {
    #[command(flatten)]
    pub db: DbArg,
    #[arg(long, default_value = "auto")]
    pub backend: BackendChoice,
    #[arg(long, default_value_t = 1)]
    pub parallel: usize,
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// A running job whose heartbeat is older than this (s) is taken as dead.
    #[arg(long, default_value_t = 30.0)]
    pub stale_after: f64,
    /// Failed jobs are retried until they have had this many attempts.
    #[arg(long, default_value_t = 3)]
    pub max_attempts: i64,
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

fn backend_note(b: BackendChoice) {
    if b == BackendChoice::Auto {
        eprintln!("sweep: backend auto: no GPU backend in this build yet, running on the CPU");
    }
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
    let mut conn = sweep::store::open(&a.db.db)?;
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
        a.db.db.display()
    );
    backend_note(a.backend);
    let opts = PoolOptions {
        db: a.db.db.clone(),
        work_dir: work_dir(&a.db.db),
        campaign: Some(cid),
        parallel: a.parallel,
        threads: a.threads,
        backend: a.backend,
        checkpoint_interval_s: file.run.checkpoint_interval_s,
        interrupt: interrupt_flag(),
        bars: std::io::stderr().is_terminal(),
    };
    let s = run_pending(&opts, jobs.len(), done as usize).context("running jobs")?;
    Ok(finish(s, &a.db.db))
}

pub fn resume(a: ResumeArguments) -> anyhow::Result<i32> {
    if !a.db.db.exists() {
        eprintln!(
            "sweep: no database at {}: nothing to resume; start with `sweep launch FILE`",
            a.db.db.display()
        );
        return Ok(2);
    }
    let mut conn = sweep::store::open(&a.db.db)?;
    let n = sweep::store::jobs::requeue(&mut conn, a.stale_after, a.max_attempts)?;
    let (total, done): (i64, i64) = conn.query_row(
        "SELECT COUNT(*), COALESCE(SUM(status = 'done'), 0) FROM jobs",
        [],
        |r| Ok((r.get(0)?, r.get(1)?)),
    )?;
    println!("{n} job(s) to resume, {done} of {total} already done");
    backend_note(a.backend);
    let opts = PoolOptions {
        db: a.db.db.clone(),
        work_dir: work_dir(&a.db.db),
        campaign: None,
        parallel: a.parallel,
        threads: a.threads,
        backend: a.backend,
        checkpoint_interval_s: 0.5,
        interrupt: interrupt_flag(),
        bars: std::io::stderr().is_terminal(),
    };
    let s = run_pending(&opts, total as usize, done as usize)?;
    Ok(finish(s, &a.db.db))
}
