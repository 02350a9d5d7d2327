//! The local executor: runs pending jobs K at a time, each worker with its own database
//! connection and its own engine threads; a failed job does not stop the campaign.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

use super::backend::{BackendChoice, GpuSelect};
use super::job::{job_dir, JobContext, Outcome};
use super::job_lock::{DirLock, Heartbeat};
use super::pool_tail::Tail;
use super::silo_job::run_silo_job;
use crate::store::jobs::{self, JobScope, Lease};
use crate::store::silo_done::{silo_done, SiloDone};

/// Options of a run of pending jobs.
#[derive(Clone)]
pub struct PoolOptions {
    pub db: PathBuf,
    pub work_dir: PathBuf,
    /// Which pending jobs the pool takes.
    pub scope: JobScope,
    /// While the scope's last jobs run, idle workers take pending jobs of these scopes, the
    /// first that has one, and hand them back at a checkpoint when the scope's jobs have ended
    /// (`pool_tail.rs`).
    pub backfill: Vec<JobScope>,
    pub parallel: usize,
    /// Engine threads per job; 0 = cores / parallel.
    pub threads: usize,
    pub backend: BackendChoice,
    /// Which GPU adapter (`--gpu N`, `--allow-software-gpu`).
    pub gpu: GpuSelect,
    /// GPU jobs running at the same time share an engine, this many at most (1: each its own).
    pub batch: usize,
    pub checkpoint_interval_s: f64,
    /// Overrides each job's own `run.max_attempts` (`sweep resume --max-attempts`).
    pub max_attempts: Option<i64>,
    pub interrupt: Arc<AtomicBool>,
    /// Draw progress bars (a terminal); otherwise print plain lines.
    pub bars: bool,
}

/// Counts of how jobs ended.
#[derive(Debug, Default, Clone, Copy)]
pub struct PoolSummary {
    pub done: usize,
    pub failed: usize,
    pub paused: usize,
    /// Jobs of the backfill scope run on idle workers: ended, or handed back at a checkpoint.
    pub lent: usize,
}

/// Runs pending jobs until none is left or an interrupt arrives.
///
/// # Errors
/// The database cannot be opened; per-job errors are recorded on the job instead.
pub fn run_pending(
    opts: &PoolOptions,
    total_jobs: usize,
    already_done: usize,
) -> anyhow::Result<PoolSummary> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let parallel = opts.parallel.max(1);
    let threads = if opts.threads > 0 {
        opts.threads
    } else {
        (cores / parallel).max(1)
    };
    let multi = MultiProgress::with_draw_target(if opts.bars {
        ProgressDrawTarget::stderr()
    } else {
        ProgressDrawTarget::hidden()
    });
    let overall = multi.add(ProgressBar::new(total_jobs as u64));
    overall.set_style(
        ProgressStyle::with_template("campaign [{bar:30}] {pos}/{len} jobs done  {msg}")
            .expect("template")
            .progress_chars("=> "),
    );
    overall.set_position(already_done as u64);
    let summary = Arc::new(Mutex::new(PoolSummary::default()));
    let done_count = Arc::new(AtomicUsize::new(already_done));
    let mut handles = Vec::new();
    let tail = Arc::new(Tail::default());
    // GPU jobs share one device (a silo job's fill and run included), and those running at the
    // same time share engines (CPU jobs never join one).
    let capacity = if parallel > 1 {
        opts.batch.clamp(1, parallel)
    } else {
        1
    };
    let batches = Some(Arc::new(super::gpu_batch::GpuBatches::new(capacity)));
    for _ in 0..parallel {
        let w = Worker {
            opts: opts.clone(),
            batches: batches.clone(),
            multi: multi.clone(),
            overall: overall.clone(),
            summary: summary.clone(),
            done_count: done_count.clone(),
            tail: tail.clone(),
            threads,
        };
        handles.push(std::thread::spawn(move || worker(w)));
    }
    let mut first_err = None;
    for h in handles {
        match h.join() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => first_err = first_err.or(Some(e)),
            Err(_) => first_err = first_err.or(Some(anyhow::anyhow!("a worker thread panicked"))),
        }
    }
    overall.finish_and_clear();
    if let Some(b) = batches.filter(|b| b.largest() > 1) {
        eprintln!(
            "sweep: GPU jobs shared engines, up to {} jobs in one batch",
            b.largest()
        );
    }
    if let Some(e) = first_err {
        return Err(e);
    }
    let s = *summary.lock().expect("summary");
    Ok(s)
}

/// What one worker thread of the pool shares with the others.
struct Worker {
    opts: PoolOptions,
    batches: Option<Arc<super::gpu_batch::GpuBatches>>,
    multi: MultiProgress,
    overall: ProgressBar,
    summary: Arc<Mutex<PoolSummary>>,
    done_count: Arc<AtomicUsize>,
    tail: Arc<Tail>,
    /// Engine threads per job.
    threads: usize,
}

/// One worker: claims pending jobs one at a time and runs each to its end, a pause or a
/// failure, until none is left or an interrupt arrives. With none left while other workers'
/// jobs still run, it runs a job of the backfill scope until they end.
fn worker(w: Worker) -> anyhow::Result<()> {
    let mut conn = crate::store::open(&w.opts.db)?;
    let lease = Lease::new();
    let opts = &w.opts;
    loop {
        if opts.interrupt.load(Ordering::SeqCst) {
            return Ok(());
        }
        // The job's OS lock is taken inside the claim's transaction, so `resume` (whose
        // requeue waits for that transaction) never sees it running and unlocked.
        let hold = |j: &jobs::JobRow| Ok(DirLock::try_take(&job_dir(&opts.work_dir, &j.hash))?);
        let claim = w.tail.claiming();
        if let Some((job, _lock)) =
            jobs::claim(&mut conn, opts.scope, &lease, opts.max_attempts, hold)?
        {
            run_one(&w, &mut conn, &job, &lease, opts.interrupt.clone(), false)?;
            continue;
        }
        w.tail.exhausted();
        drop(claim);
        if opts.backfill.is_empty() || !w.tail.own_running() {
            return Ok(());
        }
        let mut lent = None;
        for &scope in &opts.backfill {
            lent = jobs::claim(&mut conn, scope, &lease, opts.max_attempts, hold)?;
            if lent.is_some() {
                break;
            }
        }
        let Some((job, _lock)) = lent else {
            return Ok(());
        };
        if w.tail.over() {
            // The last own job ended during the claim: hand it back unstarted.
            jobs::release(&conn, job.id, &lease, "pending", None)?;
            return Ok(());
        }
        let (interrupt, _watch) = w.tail.lent_interrupt(opts.interrupt.clone());
        run_one(&w, &mut conn, &job, &lease, interrupt, true)?;
    }
}

/// Runs one claimed job and records how it ended. A `lent` job (of the backfill scope) that
/// pauses while the run goes on is handed back as pending, its attempt given back; one that
/// fails is handed back as pending with its error, its attempt spent.
fn run_one(
    w: &Worker,
    conn: &mut rusqlite::Connection,
    job: &jobs::JobRow,
    lease: &Lease,
    interrupt: Arc<AtomicBool>,
    lent: bool,
) -> anyhow::Result<()> {
    let opts = &w.opts;
    let _beat = Heartbeat::start(&opts.db, job.id, &lease.owner);
    let bar = w.multi.add(ProgressBar::new(1000));
    bar.set_style(
        ProgressStyle::with_template("job {prefix:>4} [{bar:25}] eta {eta:>4} {msg}")
            .expect("template")
            .progress_chars("=> "),
    );
    bar.set_prefix(job.id.to_string());
    let label = job.label.clone();
    let b2 = bar.clone();
    let progress: Arc<dyn Fn(f64, f64, f64) + Send + Sync> = Arc::new(move |t, target, rate| {
        b2.set_position(((t / target).min(1.0) * 1000.0) as u64);
        let eta = if rate > 0.0 {
            format!("{:.1e} particle-steps/s", rate)
        } else {
            String::new()
        };
        b2.set_message(format!("t = {t:.2}/{target:.2} s  {eta}  {label}"));
    });
    let bars = opts.bars;
    let m2 = w.multi.clone();
    let log: Arc<dyn Fn(String) + Send + Sync> = Arc::new(move |s| {
        if bars {
            let _ = m2.println(s);
        } else {
            eprintln!("{s}");
        }
    });
    let ctx = JobContext {
        work_dir: opts.work_dir.clone(),
        backend: opts.backend,
        gpu: opts.gpu,
        batches: w.batches.clone(),
        threads: w.threads,
        checkpoint_interval_s: checkpoint_interval(conn, job.id)
            .unwrap_or(opts.checkpoint_interval_s),
        interrupt,
        progress: Some(progress),
        log: log.clone(),
    };
    let started = format!("job {} started: {}", job.id, job.label);
    if lent {
        log(format!(
            "{started} (on an idle core while the campaign's last jobs run)"
        ));
    } else if !bars {
        println!("{started}");
    }
    let outcome = run_caught(conn, job, lease, &ctx);
    bar.finish_and_clear();
    let run_interrupted = opts.interrupt.load(Ordering::SeqCst);
    // Counted under the lock; written and logged after it.
    {
        let mut s = w.summary.lock().expect("summary");
        match (&outcome, lent) {
            (Outcome::Done, false) => s.done += 1,
            (Outcome::Paused, true) if run_interrupted => s.paused += 1,
            (_, true) => s.lent += 1,
            (Outcome::Paused, false) => s.paused += 1,
            (Outcome::Failed(_), false) => s.failed += 1,
        }
    }
    match outcome {
        Outcome::Done if lent => {
            log(format!(
                "job {} done: {} (on an idle core)",
                job.id, job.label
            ));
        }
        Outcome::Done => {
            let n = w.done_count.fetch_add(1, Ordering::SeqCst) + 1;
            w.overall.set_position(n as u64);
            let line = describe_done(conn, job.id).unwrap_or_default();
            if bars {
                log(format!("job {} done: {} {}", job.id, job.label, line));
            } else {
                println!("job {} done: {} {}", job.id, job.label, line);
            }
        }
        Outcome::Paused if lent && !run_interrupted => {
            jobs::release(conn, job.id, lease, "pending", None)?;
            log(format!(
                "job {} handed back at its checkpoint: the campaign's own jobs have ended; its own campaign's turn continues it",
                job.id
            ));
        }
        Outcome::Paused => {
            jobs::release(conn, job.id, lease, "paused", None)?;
            log(format!(
                "job {} paused at its checkpoint; `sweep resume` continues it",
                job.id
            ));
        }
        Outcome::Failed(e) if lent => {
            // Its own campaign's turn tries it again (the attempt stays spent), as its own
            // failure would have stopped that campaign's look.
            jobs::release(conn, job.id, lease, "pending", Some(&e))?;
            log(format!(
                "job {} failed on an idle core: {e}; its own campaign's turn tries it again if attempts are left",
                job.id
            ));
        }
        Outcome::Failed(e) => {
            jobs::release(conn, job.id, lease, "failed", Some(&e))?;
            log(format!("job {} failed: {e}", job.id));
        }
    }
    Ok(())
}

/// Runs `job` with the study of its scene; a panic fails the job (with its message) instead of
/// killing the worker.
fn run_caught(
    conn: &mut rusqlite::Connection,
    job: &jobs::JobRow,
    lease: &Lease,
    ctx: &JobContext,
) -> Outcome {
    let scene = serde_json::from_str::<serde_json::Value>(&job.params_json)
        .ok()
        .and_then(|v| v["scene"].as_str().map(String::from));
    let run = match scene.as_deref() {
        Some("chute") => super::chute_job::run_chute_job,
        _ => run_silo_job,
    };
    let attempt = std::panic::AssertUnwindSafe(|| run(conn, job, lease, ctx));
    match std::panic::catch_unwind(attempt) {
        Ok(Ok(o)) => o,
        Ok(Err(e)) => Outcome::Failed(format!("{e:#}")),
        Err(panic) => Outcome::Failed(format!(
            "the job panicked: {}",
            panic
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| panic.downcast_ref::<&str>().copied())
                .unwrap_or("(no message)")
        )),
    }
}

fn describe_done(conn: &rusqlite::Connection, job: i64) -> anyhow::Result<String> {
    let SiloDone {
        q_kg_per_s: q,
        q_ci95_kg_per_s: ci,
        clogs,
        permanently_clogged: perm,
        wall_time_s: wall,
        particle_steps: ps,
    } = silo_done(conn, job)?;
    let q = match (q, ci) {
        (Some(q), Some(c)) => format!("Q = {q:.4} ± {c:.4} kg/s"),
        _ => "Q = n/a (no flowing interval long enough)".into(),
    };
    Ok(format!(
        "{q}, {clogs} clog(s){}, {wall:.1} s wall, {:.2e} particle-steps/s",
        if perm { " (permanent)" } else { "" },
        ps as f64 / wall.max(1e-9)
    ))
}

/// The checkpoint interval of the (first) campaign a job belongs to.
fn checkpoint_interval(conn: &rusqlite::Connection, job: i64) -> Option<f64> {
    let spec = jobs::first_campaign_spec(conn, job).ok().flatten()?;
    let c: crate::campaign::CampaignFile = serde_json::from_str(&spec).ok()?;
    Some(c.run.checkpoint_interval_s)
}
