//! The Slurm side of `sweep launch` and `sweep resume`: the executor flags, registering and
//! submitting a campaign's pending jobs (or printing the scripts, in a dry run), and resubmitting
//! resumed jobs with the settings of their last submission.

use anyhow::Context;
use sweep::campaign::{CampaignFile, ExecutorKind, Jobs, SlurmSettings};
use sweep::project::{Executor, Outcome, Project, Slurm, Submission};
use sweep::runner::slurm::{self, SlurmError, SubmitSettings, Submitted};

use super::run_args::{Arguments, ResumeArguments};

/// `sweep launch --executor slurm`: registers the jobs, then hands the pending ones to Slurm.
pub fn launch_slurm(a: &Arguments, file: &CampaignFile, jobs: &Jobs) -> anyhow::Result<i32> {
    let settings = a.exec.slurm_settings(&file.run.slurm);
    let problems = settings.problems();
    if !problems.is_empty() {
        eprintln!("sweep: error: {}", SlurmError::Settings { problems });
        return Ok(2);
    }
    if !a.exec.dry_run && slurm::query::which("sbatch").is_none() {
        eprintln!(
            "sweep: error: {}; nothing registered",
            SlurmError::NotInstalled { command: "sbatch" }
        );
        return Ok(2);
    }
    // The campaign is stored as launched (executor and Slurm settings from the command line
    // included, which changes no job), so `sweep resume` sends its jobs to Slurm too.
    let mut launched = file.clone();
    launched.run.executor = ExecutorKind::Slurm;
    launched.run.slurm = settings.clone();
    let db = &a.run.db.db;
    let mut project = if a.exec.dry_run {
        Project::scratch_copy(db)?
    } else {
        Project::open(db)?
    };
    let (cid, _version, added) = match super::shared::register(&mut project, a, &launched, jobs)? {
        Ok(x) => x,
        Err(code) => return Ok(code),
    };
    let (done, pending) = (project.done_count(cid)?, project.pending_ids(cid)?);
    println!(
        "campaign {}: {} job(s), {} new, {} already done (database {}{})",
        file.name,
        jobs.len(),
        added,
        done,
        db.display(),
        if a.exec.dry_run {
            ", left as it was: dry run"
        } else {
            ""
        }
    );
    if pending.is_empty() {
        println!("nothing to submit: every job of the campaign is done, running or paused (see `sweep status --db {}`)", db.display());
        return Ok(0);
    }
    let sub = SubmitSettings {
        slurm: settings,
        backend: a.run.backend,
        gpu: a.run.gpu.select(),
        threads: a.run.threads,
        checkpoint_interval_s: file.run.checkpoint_interval_s,
    };
    let code = submit_and_report(
        &mut project,
        Some(cid),
        &file.name,
        &sub,
        &pending,
        a.exec.dry_run,
    )?;
    if code == 0 && !a.exec.dry_run {
        println!(
            "follow with: sweep status --db {db} (it collects finished results, as do `sweep collect` and `sweep resume`); stop with: sweep cancel --campaign {} --db {db}",
            file.name,
            db = db.display()
        );
    }
    Ok(code)
}

/// Submits `jobs` and prints the arrays (or, in a dry run, the scripts); returns the exit code.
fn submit_and_report(
    project: &mut Project,
    campaign_id: Option<i64>,
    campaign_name: &str,
    settings: &SubmitSettings,
    jobs: &[i64],
    dry_run: bool,
) -> anyhow::Result<i32> {
    let bin = std::env::current_exe()
        .and_then(|p| p.canonicalize())
        .context("locating the sweep binary for the job scripts")?;
    let mut slurm = Slurm {
        settings: settings.clone(),
        sweep_bin: bin,
        dry_run,
    };
    let s = Submission {
        campaign: campaign_id,
        campaign_name,
        jobs,
        total: jobs.len(),
        done: 0,
    };
    match slurm.submit(project, &s) {
        Ok(outcome) => {
            if let Outcome::Handed(list) = outcome {
                print_submitted(&list, settings);
            }
            Ok(0)
        }
        Err(e) => {
            eprintln!("sweep: error: {e:#}");
            Ok(2)
        }
    }
}

fn print_submitted(list: &[Submitted], settings: &SubmitSettings) {
    for s in list {
        match &s.array_job_id {
            None => {
                println!(
                    "# {} ({} job(s); dry run: not written, not submitted)",
                    s.script.display(),
                    s.jobs.len()
                );
                print!("{}", s.text);
            }
            Some(id) => println!(
                "submitted {} job(s) to Slurm as array {id}{}: script {}",
                s.jobs.len(),
                settings
                    .slurm
                    .array_max
                    .map_or(String::new(), |k| format!(" (at most {k} at a time)")),
                s.script.display()
            ),
        }
    }
}

/// The Slurm part of `sweep resume`: resubmits the pending jobs that go to Slurm (those last
/// submitted there, or all with `--executor slurm`) of `campaigns`. Returns the exit code when
/// nothing is left to run here.
///
/// # Errors
/// Database errors.
pub fn resume_on_slurm(
    project: &mut Project,
    a: &ResumeArguments,
    campaigns: &[i64],
    slurm_used: bool,
) -> anyhow::Result<Option<i32>> {
    if a.executor == Some(ExecutorKind::Local) {
        return Ok(None);
    }
    let fallback = SubmitSettings {
        slurm: SlurmSettings::default(),
        backend: a.run.backend,
        gpu: a.run.gpu.select(),
        threads: a.run.threads,
        checkpoint_interval_s: sweep::campaign::RunSettings::default().checkpoint_interval_s,
    };
    let all = a.executor == Some(ExecutorKind::Slurm);
    let mut groups = slurm::resume_groups(project.conn(), all, &fallback)?;
    groups.retain(|g| g.campaign_id.is_none_or(|c| campaigns.contains(&c)));
    if groups.is_empty() && !slurm_used && !all {
        return Ok(None);
    }
    if a.run.time_limit.is_some() && !groups.is_empty() {
        let n: usize = groups.iter().map(|g| g.jobs.len()).sum();
        eprintln!(
            "sweep: error: {n} job(s) would go to Slurm, where --time-limit does not reach (a Slurm job's limit is its --time): add `--executor local` to run them here under the limit; nothing was submitted"
        );
        return Ok(Some(2));
    }
    for g in &groups {
        let code = submit_and_report(
            project,
            g.campaign_id,
            &g.campaign_name,
            &g.settings,
            &g.jobs,
            false,
        )?;
        if code != 0 {
            // Those jobs are pending again: not a reason to run them here instead.
            return Ok(Some(code));
        }
    }
    let pending = project.pending_count()?;
    if pending > 0 {
        // Jobs that never went to Slurm run here.
        return Ok(None);
    }
    if !groups.is_empty() {
        println!(
            "follow with: sweep status --db {} (it collects finished results)",
            project.db().display()
        );
    }
    Ok(Some(0))
}
