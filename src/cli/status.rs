//! `sweep status`: campaigns and jobs with progress, throughput and time remaining; for jobs
//! handed to Slurm, Slurm's view beside sweep's (after collecting finished results).

use std::path::Path;

use sweep::project::{
    owner_place, CpuUse, Executor, FlowVerdict, JobScope, JobStatus, Liveness, OwnerPlace, Project,
    Slurm, SlurmTask, StateTotal,
};
use sweep::runner::job_lock;
use sweep::runner::slurm::{self, query::SlurmView};

use super::DbArg;

#[derive(clap::Args)]
pub struct Arguments {
    #[command(flatten)]
    pub db: DbArg,
    /// Only this campaign (every version of it).
    #[arg(long)]
    pub campaign: Option<String>,
    /// A running job of another machine whose heartbeat is older than this (s) is shown as
    /// gone (jobs of this machine are judged by their OS lock).
    #[arg(long, default_value_t = 30.0)]
    pub stale_after: f64,
    /// A line for every job, however many (by default a campaign of more than 200 jobs is
    /// summarised: its totals, and a line only for the jobs running, paused or failed).
    #[arg(long)]
    pub all_jobs: bool,
    /// A few lines per campaign version: its jobs by state, its claims' latest look and its
    /// target's spending, without the jobs (a store's overview).
    #[arg(long, conflicts_with = "all_jobs")]
    pub brief: bool,
}

/// Up to this many jobs, a campaign's status has a line per job.
const LINE_PER_JOB_UP_TO: i64 = 200;
/// At most this many lines of jobs needing a look in a summarised campaign.
const SUMMARY_LINES: i64 = 50;

pub fn run(a: Arguments) -> anyhow::Result<i32> {
    if !Path::new(&a.db.db).exists() {
        println!(
            "no database at {}: nothing has been launched here yet; start with `sweep launch FILE`",
            a.db.db.display()
        );
        return Ok(0);
    }
    let mut project = Project::open(&a.db.db)?;
    let slurm = slurm_view(&mut project)?;
    let work = project.work_dir()?;
    // "NAME@vK" lists version K alone; the other versions still tell whether it was replaced.
    let (name, version) = match a.campaign.as_deref() {
        Some(c) => {
            let (n, v) = sweep::report::split_version(c);
            (Some(n), v)
        }
        None => (None, None),
    };
    let all_versions = project.campaigns(name)?;
    // The newest version of each name: an older one's open jobs wait unless named, apart from
    // those a newer version shares (a plain resume takes every open job of a latest version).
    let mut newest = std::collections::HashMap::new();
    for c in &all_versions {
        let v = newest.entry(c.name.clone()).or_insert(c.version);
        *v = (*v).max(c.version);
    }
    let resumed: std::collections::HashSet<i64> = project
        .open_jobs(JobScope::LatestVersions)?
        .iter()
        .map(|j| j.id)
        .collect();
    let camps: Vec<_> = all_versions
        .into_iter()
        .filter(|c| version.is_none_or(|v| c.version == v))
        .collect();
    if camps.is_empty() {
        println!(
            "{}: no campaigns{}",
            a.db.db.display(),
            a.campaign
                .as_ref()
                .map_or(String::new(), |c| format!(" named {c}"))
        );
        return Ok(0);
    }
    for c in camps {
        let totals = project.state_totals(c.id)?;
        let count = |s: &str| totals.iter().find(|t| t.status == s).map_or(0, |t| t.jobs);
        let all: i64 = totals.iter().map(|t| t.jobs).sum();
        let verdicts = project.flow_verdicts(c.id)?;
        println!(
            "campaign {}{} ({}): {} jobs — {} done, {} running, {} pending, {} paused, {} failed",
            c.name,
            if c.version > 1 {
                format!(" version {}", c.version)
            } else {
                String::new()
            },
            c.file,
            all,
            count("done"),
            count("running"),
            count("pending"),
            count("paused"),
            count("failed")
        );
        let latest = newest[&c.name];
        if c.version < latest {
            let waiting = project
                .open_jobs(JobScope::Campaign(c.id))?
                .iter()
                .filter(|j| !resumed.contains(&j.id) && j.status != "running")
                .count();
            if waiting > 0 {
                println!(
                    "         replaced by version {latest}: {waiting} open job(s) that a plain `sweep resume` leaves (it continues the latest versions' jobs); `--campaign {}@v{}` continues them",
                    c.name, c.version
                );
            }
        }
        if a.brief {
            print_brief_target(&project, c.id)?;
            continue;
        }
        let rows = if all <= LINE_PER_JOB_UP_TO || a.all_jobs {
            project.jobs_of(c.id, None, i64::MAX)?
        } else {
            print_totals(&totals);
            let needing_a_look = ["running", "paused", "failed"];
            let shown = count("running") + count("paused") + count("failed");
            println!(
                "         {all} jobs: a line for each job running, paused or failed{}; `--all-jobs` lists every one",
                if shown > SUMMARY_LINES {
                    format!(" (the first {SUMMARY_LINES} of {shown})")
                } else {
                    String::new()
                }
            );
            project.jobs_of(c.id, Some(&needing_a_look), SUMMARY_LINES)?
        };
        println!(
            "{:>5}  {:<8} {:>6} {:>14} {:>16} {:>10} {:>5}  parameters",
            "job", "status", "done%", "sim_time_s", "particle-steps/s", "eta_s", "try"
        );
        // A note every listed job shares (the usual case: one machine, one choice) is said once.
        let shared_note = shared_backend_note(&rows);
        if let Some(n) = shared_note {
            println!("         backend of every job listed that has run: {n}");
        }
        for r in &rows {
            let rate = if r.wall_time_s > 0.0 {
                r.particle_steps as f64 / r.wall_time_s
            } else {
                0.0
            };
            let eta = eta_s(r).map_or("-".into(), |e| format!("{e:.0}"));
            println!(
                "{:>5}  {:<8} {:>6.1} {:>6.2}/{:<7.2} {:>16.3e} {:>10} {:>5}  {} {}",
                r.id,
                r.status,
                100.0 * r.progress,
                r.sim_time_s,
                r.target_time_s,
                rate,
                eta,
                format!("{}/{}", r.attempts, r.max_attempts),
                r.label,
                match (&r.backend, &r.precision) {
                    (Some(b), Some(p)) => format!("[{b} {p}]"),
                    _ => String::new(),
                }
            );
            // Every job not done says why it is where it is.
            match r.status.as_str() {
                "running" if owner_place(r.lease_owner.as_deref()) != OwnerPlace::Slurm => {
                    let stage = r.stage.as_deref().unwrap_or("claimed");
                    match job_lock::liveness(&work, &r.as_open(), a.stale_after) {
                        Liveness::Alive(why) => println!("         {why}; stage '{stage}'"),
                        Liveness::Gone(why) => println!(
                            "         NOT RUNNING: {why}, during stage '{stage}'; `sweep resume` continues it"
                        ),
                    }
                }
                "failed" if r.attempts >= r.max_attempts => println!(
                    "         no attempts left ({} of {}): `sweep resume --max-attempts {}` tries again",
                    r.attempts,
                    r.max_attempts,
                    r.attempts + 1
                ),
                "paused" => println!("         paused at its checkpoint: `sweep resume` continues it"),
                _ => {}
            }
            if let Some(n) = r.backend_note.as_deref().filter(|_| shared_note.is_none()) {
                println!("         backend: {n}");
            }
            if let Some(v) = verdicts.get(&r.id).filter(|v| v.state != "steady") {
                println!("         flow: {}", describe_flow(v));
            }
            if let Some(e) = r.last_error.as_deref().filter(|_| r.status != "done") {
                println!("         last error: {e}");
            }
            if let Some((tasks, view)) = &slurm {
                if let Some(t) = tasks.get(&r.id) {
                    println!("         slurm: {}", describe(t, view.as_ref()));
                }
            }
        }
        print_target(&project, c.id)?;
        if let Some(line) = cpu_line(&project.cpu_use(c.id)?) {
            println!("{line}");
        }
    }
    Ok(0)
}

/// What the jobs' threads ran against the cores they held: on cores shared with other work
/// the core-hours (wall time × threads) grow while the CPU hours do not. None before any job
/// has counted its CPU time.
fn cpu_line(u: &CpuUse) -> Option<String> {
    (u.counted > 0).then(|| {
        let before = u.ran - u.counted;
        format!(
            "cpu: {:.3} CPU-hours used of {:.3} core-hours held ({:.0} %) by the {} job(s) that counted it{}",
            u.cpu_hours,
            u.core_hours,
            100.0 * u.cpu_hours / u.core_hours.max(1e-12),
            u.counted,
            if before > 0 {
                format!("; {before} ran before sweep counted CPU time")
            } else {
                String::new()
            }
        )
    })
}

/// The backend note of the listed jobs that have run (those with a backend), when there are
/// several and every one carries the same note; a job that ran without one (on the GPU, as
/// asked) keeps the notes per job.
fn shared_backend_note(rows: &[JobStatus]) -> Option<&str> {
    let mut ran = rows.iter().filter(|r| r.backend.is_some());
    let first = ran.next()?.backend_note.as_deref()?;
    let mut count = 1;
    for r in ran {
        if r.backend_note.as_deref() != Some(first) {
            return None;
        }
        count += 1;
    }
    (count > 1).then_some(first)
}

/// A large campaign's totals: simulated time done of its target, work and throughput.
fn print_totals(totals: &[StateTotal]) {
    let sum = |f: fn(&StateTotal) -> f64| totals.iter().map(f).sum::<f64>();
    let (sim, target) = (sum(|t| t.sim_time_s), sum(|t| t.target_time_s));
    let (steps, wall) = (sum(|t| t.particle_steps), sum(|t| t.wall_time_s));
    println!(
        "         simulated {sim:.1} of {target:.1} s ({:.1} %), {steps:.3e} particle-steps in {:.1} h of job wall time ({:.3e} particle-steps/s)",
        if target > 0.0 { 100.0 * sim / target } else { 0.0 },
        wall / 3600.0,
        if wall > 0.0 { steps / wall } else { 0.0 }
    );
}

/// `--brief`: the claims' latest look in one line, and the target's rounds and spending.
fn print_brief_target(project: &Project, campaign_id: i64) -> anyhow::Result<()> {
    let file = project.campaign_file(campaign_id).ok().flatten();
    if file.as_ref().is_some_and(|f| !f.claims.is_empty()) {
        let verdicts = project.latest_verdicts(campaign_id)?;
        match verdicts.first() {
            None => println!(
                "         claims: {} not looked at yet",
                file.as_ref().map_or(0, |f| f.claims.len())
            ),
            Some(first) => {
                let count = |v: &str| verdicts.iter().filter(|r| r.verdict == v).count();
                println!(
                    "         claims at look {}: {} supported, {} contradicted, {} undecided",
                    first.round,
                    count("supported"),
                    count("contradicted"),
                    count("undecided")
                );
            }
        }
    }
    if let Some(t) = file.and_then(|f| f.target) {
        let rounds = project
            .target_work(campaign_id)?
            .iter()
            .map(|w| w.round)
            .max()
            .unwrap_or(0);
        let (steps, _, core_hours) = project.spent(campaign_id)?;
        let (steps_cap, hours_cap) = t.budget_words();
        println!(
            "         target: {rounds} round(s) of added work; {steps:.3e}{steps_cap} particle-steps, {core_hours:.2}{hours_cap} core-hours spent"
        );
    }
    Ok(())
}

/// A campaign target's points after its latest round, and the work it added.
fn print_target(project: &Project, campaign_id: i64) -> anyhow::Result<()> {
    // A stored file this sweep cannot read (another version's) has no target to show.
    let file = project.campaign_file(campaign_id).ok().flatten();
    let verdicts = project.latest_verdicts(campaign_id)?;
    if file.as_ref().is_some_and(|f| !f.claims.is_empty()) {
        if verdicts.is_empty() {
            println!("claims: not looked at yet: they are, once the campaign's jobs have ended");
        }
        super::claims::print_verdicts(&verdicts);
    }
    let Some(t) = file.and_then(|f| f.target) else {
        return Ok(());
    };
    if t.decides_claims() {
        let work = project.target_work(campaign_id)?;
        let (steps, wall, core_hours) = project.spent(campaign_id)?;
        let (steps_cap, hours_cap) = t.budget_words();
        println!(
            "target: decide every claim — so far {} round(s) of added work ({} extension(s), {} replica(s)); spent {steps:.3e}{steps_cap} particle-steps, {:.1} min of job wall time, {core_hours:.3}{hours_cap} core-hours",
            work.iter().map(|w| w.round).max().unwrap_or(0),
            work.iter().filter(|w| w.action == "extend").count(),
            work.iter().filter(|w| w.action == "replica").count(),
            wall / 60.0,
        );
        return Ok(());
    }
    let points = project.target_points(campaign_id)?;
    let work = project.target_work(campaign_id)?;
    let met = points.iter().filter(|p| p.met).count();
    println!(
        "target: 95 % CI <= ±{:.1} % — {met} of {} point(s) met after {} round(s) of added work ({} extension(s), {} replica(s))",
        100.0 * t.ci95_rel(),
        points.len(),
        work.iter().map(|w| w.round).max().unwrap_or(0),
        work.iter().filter(|w| w.action == "extend").count(),
        work.iter().filter(|w| w.action == "replica").count(),
    );
    if points.is_empty() {
        println!("         not evaluated yet: it is, once the campaign's jobs have ended");
    }
    for p in &points {
        println!(
            "         {:<50} ±{:>5} ({}) {} replica(s), {:.1} s, {:.2e} particle-steps: {}",
            p.point,
            p.ci95_rel
                .map_or_else(|| "n/a".into(), |c| format!("{:.1} %", 100.0 * c)),
            p.ci_from.as_deref().unwrap_or("-"),
            p.replicas,
            p.measured_s,
            p.particle_steps as f64,
            p.status
        );
    }
    Ok(())
}

/// A chute job's verdict when it was not steady: which window decided, and its numbers.
fn describe_flow(v: &FlowVerdict) -> String {
    let state =
        sweep::observe::chute::FlowState::parse(&v.state).map_or(v.state.as_str(), |s| s.words());
    let numbers = v.criteria.as_ref().map_or(String::new(), |w| {
        // A change with its t statistic against the quantile: a drift is beyond both.
        let change = |x: Option<f64>, t: Option<f64>| match (x, w.t_critical) {
            (None, _) => "-".to_string(),
            (Some(x), None) => format!("{:.1} %", 100.0 * x),
            (Some(x), Some(tc)) => format!(
                "{:.1} % (t {} of {tc:.2})",
                100.0 * x,
                t.map_or("∞".into(), |t| format!("{t:.2}"))
            ),
        };
        format!(
            " over the {} window: mean V_x {:.3} m/s (flowing from {:.3}), KE change {}, V_x change {}, μ {}",
            w.phase,
            w.mean_vx_m_per_s,
            v.min_flow_velocity_m_per_s,
            change(w.ke_change, w.ke_t),
            change(w.vx_change, w.vx_t),
            w.stress_ratio.map_or("-".into(), |m| format!("{m:.3}"))
        )
    });
    let measured = if v.measured {
        "measured, left out of figures"
    } else {
        "nothing measured"
    };
    format!("{}{numbers}; {measured}", state.to_uppercase())
}

/// Every job's latest Slurm task, and Slurm's view of them (None when Slurm cannot be asked).
type SlurmRows = (
    std::collections::BTreeMap<i64, SlurmTask>,
    Option<SlurmView>,
);

/// Collects finished Slurm results, then Slurm's view of every job's latest task (None when no
/// job was ever handed to Slurm).
fn slurm_view(project: &mut Project) -> anyhow::Result<Option<SlurmRows>> {
    if !project.uses_slurm()? {
        return Ok(None);
    }
    let r = Slurm::reading().collect(project)?;
    super::shared::print_report(&r);
    let tasks = project.slurm_tasks(None)?;
    let mut arrays: Vec<String> = tasks.values().map(|t| t.array_job_id.clone()).collect();
    arrays.sort();
    arrays.dedup();
    let view = slurm::query::view(&arrays).ok();
    Ok(Some((tasks, view)))
}

/// "task 12_3 RUNNING on node7, requeued 1×" (Slurm's view), with sweep's when they differ.
fn describe(t: &SlurmTask, view: Option<&SlurmView>) -> String {
    let slurm = match view {
        None => "Slurm not reachable".to_string(),
        Some(v) => v
            .get(&t.array_job_id, t.array_task_id)
            .map_or_else(|| "unknown to Slurm now".to_string(), |tv| tv.describe()),
    };
    // How it ended for sweep; the reason is the job's last error, printed above.
    let sweep = match t.state.as_str() {
        "active" => String::new(),
        "done" => "; result collected".to_string(),
        other => format!("; {other}"),
    };
    format!("task {} {slurm}{sweep}", t.slurm_id())
}

/// The wall seconds a job not done still needs at its pace so far. Its progress is measured
/// against where it will really end, which a chute job moves from its longest allowed run to its
/// measurement's end once steady; a job without progress yet is measured against its target.
fn eta_s(r: &JobStatus) -> Option<f64> {
    if r.status == "done" || r.wall_time_s <= 0.0 {
        return None;
    }
    if r.progress > 0.0 && r.progress < 1.0 {
        return Some(r.wall_time_s * (1.0 - r.progress) / r.progress);
    }
    (r.sim_time_s > 0.0)
        .then(|| (r.target_time_s - r.sim_time_s).max(0.0) * r.wall_time_s / r.sim_time_s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_eta_follows_the_jobs_own_end() {
        // A chute job steady at 175 s measures to 295 s, long before its 720 s cap.
        let measuring = JobStatus {
            status: "running".into(),
            sim_time_s: 186.9,
            target_time_s: 720.0,
            progress: 186.9 / 295.0,
            wall_time_s: 10_000.0,
            ..JobStatus::default()
        };
        let eta = eta_s(&measuring).unwrap();
        assert!(
            (eta - 10_000.0 * (295.0 - 186.9) / 186.9).abs() < 1e-6,
            "{eta}"
        );
        // Before any progress is recorded the target stands.
        let early = JobStatus {
            progress: 0.0,
            ..measuring.clone()
        };
        let eta = eta_s(&early).unwrap();
        assert!(
            (eta - 10_000.0 * (720.0 - 186.9) / 186.9).abs() < 1e-6,
            "{eta}"
        );
        let done = JobStatus {
            status: "done".into(),
            ..measuring
        };
        assert_eq!(eta_s(&done), None);
    }

    /// A job that ran (on `backend`, with `note`), or one that has not (`backend` None).
    fn row(backend: Option<&str>, note: Option<&str>) -> JobStatus {
        JobStatus {
            backend: backend.map(str::to_owned),
            backend_note: note.map(str::to_owned),
            ..JobStatus::default()
        }
    }

    #[test]
    fn a_note_all_run_jobs_share_is_said_once() {
        let cpu = |n| row(Some("cpu"), Some(n));
        let pending = row(None, None);
        let same = [cpu("cpu: f64"), pending.clone(), cpu("cpu: f64")];
        assert_eq!(shared_backend_note(&same), Some("cpu: f64"));
        let differ = [cpu("cpu: f64"), cpu("cpu: no adapter")];
        assert_eq!(shared_backend_note(&differ), None);
        assert_eq!(shared_backend_note(&[cpu("cpu: f64")]), None);
        assert_eq!(shared_backend_note(&[pending.clone(), pending]), None);
        // A job that ran on the GPU without a note is not covered by the others' note.
        let mixed = [cpu("cpu: f64"), row(Some("gpu"), None), cpu("cpu: f64")];
        assert_eq!(shared_backend_note(&mixed), None);
    }
}
