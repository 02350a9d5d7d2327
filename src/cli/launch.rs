//! `sweep launch` and `sweep resume`, on either executor: this machine (the pool) or Slurm.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;

use sweep::campaign::ExecutorKind;
use sweep::project::{
    Executor, JobScope, Local, Outcome, PointRow, Project, Slurm, Submission, WorkRow,
};
use sweep::runner::backend::{announce_auto, BackendChoice};
use sweep::runner::pool::PoolSummary;
use sweep::runner::PoolOptions;

use super::run_args::{Arguments, ResumeArguments, RunArgs};
use super::shared::{print_report, register, EXIT_PAUSED};

/// Runs the pending jobs of `turn`'s campaign (`total` of them, `done` already done) and prints
/// how they ended; returns the exit code.
fn run_jobs(
    r: &RunArgs,
    work: PathBuf,
    turn: &Turn,
    max_attempts: Option<i64>,
    total: usize,
    done: usize,
) -> anyhow::Result<i32> {
    if r.backend == BackendChoice::Auto {
        announce_auto(r.gpu.index);
    }
    let mut local = Local {
        pool: PoolOptions {
            db: r.db.db.clone(),
            work_dir: work,
            scope: JobScope::Campaign(turn.cid),
            backfill: turn.backfill.clone(),
            parallel: r.parallel,
            threads: r.threads,
            backend: r.backend,
            gpu: r.gpu.select(),
            batch: r.batch,
            checkpoint_interval_s: turn.checkpoint_interval_s,
            max_attempts,
            interrupt: super::interrupt::interrupt_flag(),
            bars: std::io::stderr().is_terminal(),
        },
    };
    let submission = Submission {
        campaign: None,
        campaign_name: "",
        jobs: &[],
        total,
        done,
    };
    // A failure of the machinery (the disk full, the store unwritable) is a failed run, not bad
    // input: the jobs it held are resumed by `sweep resume` (their locks end with this process).
    let run = |local: &mut Local| -> anyhow::Result<Outcome> {
        local.submit(&mut Project::open(&r.db.db)?, &submission)
    };
    let s = match run(&mut local) {
        Ok(Outcome::Ran(s)) => s,
        Ok(Outcome::Handed(_)) => PoolSummary::default(),
        Err(e) => {
            eprintln!(
                "sweep: error: running jobs: {e:#}\nsweep: the jobs this run held stay resumable: free what is missing, then `sweep resume --db {}`",
                r.db.db.display()
            );
            return Ok(1);
        }
    };
    let interrupted = local.pool.interrupt.load(Ordering::SeqCst);
    Ok(finish(s, interrupted, &r.db.db))
}

fn finish(s: PoolSummary, interrupted: bool, db: &Path) -> i32 {
    println!(
        "{} job(s) done, {} failed, {} paused",
        s.done, s.failed, s.paused
    );
    if s.lent > 0 {
        println!(
            "{} job(s) of other campaigns ran on idle cores (done, or handed back for their own turn)",
            s.lent
        );
    }
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

/// Starts `--time-limit`'s timer, or refuses it (Err: the exit code) on the Slurm executor,
/// whose jobs take their wall-time limit from `--time`.
fn start_time_limit(r: &RunArgs, on_slurm: bool) -> Result<(), i32> {
    match r.time_limit {
        Some(_) if on_slurm => {
            eprintln!("sweep: error: --time-limit stops runs on this machine; a Slurm job's wall-time limit is its --time (the campaign's slurm settings or --time)");
            Err(2)
        }
        Some(limit) => {
            super::interrupt::stop_after(limit);
            Ok(())
        }
        None => Ok(()),
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
    if let Err(code) = start_time_limit(&a.run, executor == ExecutorKind::Slurm) {
        return Ok(code);
    }
    if executor == ExecutorKind::Slurm && !a.register_only {
        if file.target.is_some() {
            println!(
                "target: its rounds run on this machine: once the Slurm jobs have ended, `sweep resume --executor local` evaluates it and runs the work it adds"
            );
        }
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
    let mut project = Project::open_checked(db)?;
    let (cid, version, added) = match register(&mut project, &a, &file, &jobs)? {
        Ok(x) => x,
        Err(code) => return Ok(code),
    };
    let done = project.done_count(cid)?;
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
    // The work directory is recorded now, while the store has room for it.
    let work = project.work_dir()?;
    drop(project);
    if a.register_only {
        println!(
            "registered only: `sweep resume --db {}` runs it in turn with the store's other campaigns",
            db.display()
        );
        return Ok(0);
    }
    let turn = Turn {
        cid,
        backfill: Vec::new(),
        checkpoint_interval_s: file.run.checkpoint_interval_s,
    };
    let code = run_jobs(&a.run, work.clone(), &turn, None, jobs.len(), done as usize)?;
    if file.target.is_none() {
        if !file.claims.is_empty() && code == 0 {
            look_once(&a.run.db.db, cid)?;
        }
        return Ok(code);
    }
    pursue_target(&a.run, &work, &turn, code)
}

/// One campaign's turn: its id, what idle workers may run meanwhile, its checkpoint interval.
struct Turn {
    cid: i64,
    backfill: Vec<JobScope>,
    checkpoint_interval_s: f64,
}

/// The claims of a campaign without a target, looked at once its jobs have ended.
fn look_once(db: &Path, cid: i64) -> anyhow::Result<()> {
    let mut project = Project::open(db)?;
    if let Some((rows, reread)) = sweep::runner::claim_rounds::look_once(project.conn_mut(), cid)? {
        super::claims::print_verdicts(&rows);
        super::claims::print_reread(&reread);
    }
    Ok(())
}

/// Rounds of a campaign's target: evaluate, add the work, run it, until nothing is added or a
/// run does not end cleanly (an interrupt, a failure: `sweep resume` continues from there).
fn pursue_target(r: &RunArgs, work: &Path, turn: &Turn, mut code: i32) -> anyhow::Result<i32> {
    let cid = turn.cid;
    use sweep::runner::adaptive::{next_round, RoundOutcome};
    loop {
        if code == 0 && super::interrupt::interrupt_flag().load(Ordering::SeqCst) {
            // Stopped (a time limit, Ctrl-C) after a clean run: no look and no round now.
            code = EXIT_PAUSED;
        }
        if code != 0 {
            println!(
                "target: not evaluated (the last run did not end cleanly); continue with: sweep resume --db {}",
                r.db.db.display()
            );
            return Ok(code);
        }
        let mut project = Project::open(&r.db.db)?;
        match next_round(project.conn_mut(), cid)? {
            RoundOutcome::Unsettled(n) => {
                println!("target: {n} job(s) of the campaign have not ended; not evaluated");
                return Ok(code);
            }
            RoundOutcome::Finished(points) => {
                print_points(&points);
                return Ok(code);
            }
            RoundOutcome::Claims(round) => {
                super::claims::print_round(&round);
                if round.work.is_empty() {
                    return Ok(code);
                }
                print_work(&round.work);
                code = run_round(r, work, &project, turn)?;
            }
            RoundOutcome::Work {
                round: _,
                work: added,
                points,
            } => {
                print_points(&points);
                print_work(&added);
                code = run_round(r, work, &project, turn)?;
            }
        }
    }
}

/// Runs the work a round added to campaign `cid`; returns the exit code.
fn run_round(r: &RunArgs, work: &Path, project: &Project, turn: &Turn) -> anyhow::Result<i32> {
    let done = project.done_count(turn.cid)?;
    let total = project.campaign_job_count(turn.cid)?;
    run_jobs(r, work.to_path_buf(), turn, None, total, done as usize)
}

/// One line per piece of work a round added.
fn print_work(added: &[WorkRow]) {
    let Some(first) = added.first() else { return };
    println!(
        "target: round {}: {} piece(s) of work",
        first.round,
        added.len()
    );
    for w in added {
        let what = if w.action == "extend" {
            format!(
                "job {} runs on {:.2} -> {:.2} s",
                w.job_id, w.from_s, w.to_s
            )
        } else {
            format!("new replica, job {}", w.job_id)
        };
        println!(
            "  {}: {what}  (CI {} -> expected {}, {:.2e} particle-steps)",
            w.point,
            pct(w.ci95_rel_before),
            pct(w.ci95_rel_expected),
            w.particle_steps_expected
        );
    }
}

fn pct(v: Option<f64>) -> String {
    v.map_or_else(|| "n/a".into(), |x| format!("±{:.1} %", 100.0 * x))
}

/// One line per point of a target: its interval, replicas, time, and where it stands.
fn print_points(points: &[PointRow]) {
    let met = points.iter().filter(|p| p.met).count();
    println!("target: {met} of {} point(s) met", points.len());
    for p in points {
        println!(
            "  {:<50} {} = {}  CI {:>9}  {} replica(s), {:.1} s  {}",
            p.point,
            p.observable,
            p.mean.map_or_else(|| "n/a".into(), |m| format!("{m:.4e}")),
            pct(p.ci95_rel),
            p.replicas,
            p.measured_s,
            p.status
        );
    }
}

pub fn resume(a: ResumeArguments) -> anyhow::Result<i32> {
    if !a.run.db.db.exists() {
        eprintln!(
            "sweep: no database at {}: nothing to resume; start with `sweep launch FILE`",
            a.run.db.db.display()
        );
        return Ok(2);
    }
    if let Err(code) = start_time_limit(&a.run, a.executor == Some(ExecutorKind::Slurm)) {
        return Ok(code);
    }
    let db = &a.run.db.db;
    let mut project = Project::open_checked(db)?;
    let work = project.work_dir()?;
    let slurm_used = project.uses_slurm()?;
    if slurm_used {
        let r = Slurm::reading().collect(&mut project)?;
        print_report(&r);
    }
    // A plain resume continues each campaign's latest version; an older one that a new
    // version replaces is left as it is unless named.
    let named = named_campaigns(&project, &a.campaign)?;
    let scopes: Vec<JobScope> = if named.is_empty() {
        vec![JobScope::LatestVersions]
    } else {
        named.iter().map(|&c| JobScope::Campaign(c)).collect()
    };
    let released = project.release_stale_submissions(a.stale_after)?;
    let mut decisions = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for &scope in &scopes {
        let found = project.requeue(scope, a.max_attempts, |j| {
            sweep::runner::job_lock::liveness(&work, j, a.stale_after)
        })?;
        // A job two named campaigns share is decided once, with the first.
        decisions.extend(found.into_iter().filter(|d| seen.insert(d.job.id)));
    }
    let resumed = decisions.iter().filter(|d| d.action == "pending").count();
    let in_scope = if named.is_empty() {
        project.latest_campaign_ids()?
    } else {
        named.clone()
    };
    let done_text = if named.is_empty() {
        let t = project.totals()?;
        format!("{} of {} already done", t.done, t.total)
    } else if let [cid] = named[..] {
        let (total, done) = campaign_totals(&project, cid)?;
        format!("{done} of {total} already done")
    } else {
        let mut parts = Vec::new();
        for &cid in &named {
            let (total, done) = campaign_totals(&project, cid)?;
            let name = project
                .campaign_file(cid)?
                .map_or(cid.to_string(), |f| f.name);
            parts.push(format!("{name}: {done} of {total} already done"));
        }
        parts.join("; ")
    };
    println!("{} job(s) to resume, {done_text}", resumed + released);
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
    if named.is_empty() {
        // `decisions` has one row per open job of the latest versions.
        let older = project
            .open_jobs(JobScope::All)?
            .len()
            .saturating_sub(decisions.len());
        if older > 0 {
            println!(
                "  {older} job(s) of older campaign versions left as they are: `sweep resume --campaign NAME@vK` continues one"
            );
        }
    }
    if let Some(code) = super::submit::resume_on_slurm(&mut project, &a, &in_scope, slurm_used)? {
        return Ok(code);
    }
    let order = campaigns_in_turn(&project, &in_scope, !named.is_empty())?;
    if order.len() > 1 {
        let mut names = Vec::new();
        for &(open, cid) in &order {
            let name = project
                .campaign_file(cid)?
                .map_or(cid.to_string(), |f| f.name);
            names.push(format!("{name} ({open} open)"));
        }
        let rule = if named.is_empty() {
            "the fewest open jobs first"
        } else {
            "in the order named"
        };
        println!(
            "campaigns in turn, {rule}, each through its jobs and its rounds: {}",
            names.join(", ")
        );
    }
    drop(project);
    // Idle workers at a campaign's tail run the later campaigns' jobs (`pool_tail.rs`).
    let lend = order.len() > 1 && !a.one_at_a_time;
    if lend && a.run.parallel > 1 {
        println!(
            "while a campaign's last jobs run, idle workers run the next campaigns' jobs, in turn, and hand them back at a checkpoint (--one-at-a-time: none)"
        );
    }
    let mut code = 0;
    for (k, &(open, cid)) in order.iter().enumerate() {
        if super::interrupt::interrupt_flag().load(Ordering::SeqCst) {
            // Stopped (a time limit, Ctrl-C) between turns: the rest wait for the next resume.
            println!(
                "interrupted: continue with: sweep resume --db {}",
                db.display()
            );
            return Ok(EXIT_PAUSED);
        }
        // Idle workers take the next campaigns' jobs, in their turn's order.
        let backfill = if lend {
            order[k + 1..]
                .iter()
                .chain(&order[..k])
                .map(|&(_, c)| JobScope::Campaign(c))
                .collect()
        } else {
            Vec::new()
        };
        let c = continue_campaign(&a, &work, cid, open, backfill)?;
        if c == EXIT_PAUSED {
            // Interrupted: the other campaigns wait for the next resume.
            return Ok(c);
        }
        code = code.max(c);
    }
    let marked_failed = decisions.iter().any(|d| d.action == "failed");
    if code == 0 && marked_failed {
        code = 1;
    }
    // Failed jobs left alone (no attempts left) are still failures of the store's campaigns.
    let failed = Project::open(db)?.failed_count()?;
    if code == 0 && failed > 0 {
        println!(
            "{failed} job(s) failed with no attempts left: `sweep status` says why; `sweep resume --max-attempts N` tries them again"
        );
        code = 1;
    }
    Ok(code)
}

/// The campaigns of `in_scope` as (open jobs, id), in turn: as given when `as_named`, else the
/// fewest open jobs first. A plain resume takes them in this order, each through its jobs and
/// then its look or its target's rounds, so a small campaign reaches its verdict without
/// waiting behind every job of a large one; a user who wants another order names them.
fn campaigns_in_turn(
    project: &Project,
    in_scope: &[i64],
    as_named: bool,
) -> anyhow::Result<Vec<(usize, i64)>> {
    let mut order = Vec::new();
    for &cid in in_scope {
        order.push((project.open_jobs(JobScope::Campaign(cid))?.len(), cid));
    }
    if !as_named {
        order.sort_unstable();
    }
    Ok(order)
}

/// The campaign versions `--campaign` names, in the order named, each once.
fn named_campaigns(project: &Project, names: &[String]) -> anyhow::Result<Vec<i64>> {
    let mut ids = Vec::new();
    for name in names {
        let id = sweep::report::find_campaign(project.conn(), Some(name), None)?.id;
        if !ids.contains(&id) {
            ids.push(id);
        }
    }
    Ok(ids)
}

/// Runs campaign `cid`'s `open` jobs (jobs it shares with another campaign included), then
/// looks at its claims or goes on with its target's rounds; returns the exit code.
fn continue_campaign(
    a: &ResumeArguments,
    work: &Path,
    cid: i64,
    open: usize,
    backfill: Vec<JobScope>,
) -> anyhow::Result<i32> {
    let db = &a.run.db.db;
    let project = Project::open(db)?;
    let file = project.campaign_file(cid)?;
    let (total, done) = campaign_totals(&project, cid)?;
    drop(project);
    // Each job's own campaign sets its checkpoint interval; this is the fallback.
    let interval = file.as_ref().map_or(
        sweep::campaign::RunSettings::default().checkpoint_interval_s,
        |f| f.run.checkpoint_interval_s,
    );
    let turn = Turn {
        cid,
        backfill,
        checkpoint_interval_s: interval,
    };
    let code = if open > 0 {
        run_jobs(
            &a.run,
            work.to_path_buf(),
            &turn,
            a.max_attempts,
            total as usize,
            done as usize,
        )?
    } else {
        0
    };
    match file {
        Some(f) if f.target.is_some() => pursue_target(&a.run, work, &turn, code),
        Some(f) if !f.claims.is_empty() => {
            if code == 0 {
                look_once(db, cid)?;
            }
            Ok(code)
        }
        _ => Ok(code),
    }
}

/// Campaign `cid`'s jobs: (all, done).
fn campaign_totals(project: &Project, cid: i64) -> anyhow::Result<(i64, i64)> {
    let states = project.state_totals(cid)?;
    let total = states.iter().map(|s| s.jobs).sum();
    let done = states
        .iter()
        .filter(|s| s.status == "done")
        .map(|s| s.jobs)
        .sum();
    Ok((total, done))
}
