//! Collecting what Slurm tasks left in their job directories into the main database (run by
//! `sweep collect`, `sweep status` and `sweep resume`, on the submitting host only):
//!
//! - a result that verifies (marker, checksum, row counts, the job done in its store) is
//!   ingested: the job's rows copied from every result table and the job marked done, in one
//!   transaction. A job is done because its result verifies, never because Slurm said COMPLETED;
//! - a result that does not verify is reported and left out;
//! - a `failed.json` marks the job failed with its error (`sweep resume` retries it);
//! - a task that Slurm says has ended (TIMEOUT, NODE_FAIL, CANCELLED, COMPLETED, …) or no longer
//!   knows, without a result, leaves its job paused at its last checkpoint: `sweep resume`
//!   resubmits it;
//! - a task still queued or running has its progress copied from its `progress.json`.
//!
//! Also `cancel`: `scancel` of a campaign's arrays, their jobs paused at their checkpoints.

use std::path::Path;

use rusqlite::Connection;

use super::files::{self, FailedMarker, ProgressFile};
use super::query::{self, SlurmView};
use crate::store::jobs;
use crate::store::slurm_ingest::{self, Ingested};
use crate::store::slurm_tasks::{self, SlurmTask};

/// What a collection found.
#[derive(Debug, Default)]
pub struct CollectReport {
    /// Jobs whose verified results were ingested now.
    pub ingested: Vec<i64>,
    /// Jobs that failed under Slurm, with their error.
    pub failed: Vec<(i64, String)>,
    /// Jobs whose task ended without a result, with Slurm's word on it (now paused).
    pub ended: Vec<(i64, String)>,
    /// Jobs whose result files do not verify (or could not be ingested), and why.
    pub refused: Vec<(i64, String)>,
    /// Jobs still queued or running under Slurm.
    pub with_slurm: Vec<i64>,
    /// Slurm's view of the tasks asked about (None when Slurm could not be asked).
    pub view: Option<SlurmView>,
    /// Why Slurm could not be asked.
    pub slurm_error: Option<String>,
}

/// Collects every job handed to Slurm that is not done yet.
///
/// # Errors
/// Database errors.
pub fn collect(conn: &mut Connection, work_dir: &Path) -> anyhow::Result<CollectReport> {
    let mut report = CollectReport::default();
    let open = open_jobs(conn)?;
    if open.is_empty() {
        return Ok(report);
    }
    // NOTE: Slurm is asked before the files are read: a task that Slurm says has ended wrote
    // its files before it ended, so a missing result then really is missing.
    let mut arrays: Vec<String> = open
        .iter()
        .filter(|o| o.task.state == "active")
        .map(|o| o.task.array_job_id.clone())
        .collect();
    arrays.sort();
    arrays.dedup();
    match query::view(&arrays) {
        Ok(v) => report.view = Some(v),
        Err(e) => report.slurm_error = Some(e.to_string()),
    }
    for job in open {
        let handed = job.handed();
        let OpenJob { task, hash, .. } = job;
        let dir = files::job_dir(work_dir, &hash);
        match files::verify_result(&dir, task.job_id, &hash) {
            Ok(Some(m)) => {
                match slurm_ingest::ingest(conn, task.job_id, &hash, &dir.join(&m.db_file), &m.rows)
                {
                    Ok(Ingested::Done) => report.ingested.push(task.job_id),
                    Ok(Ingested::AlreadyDone) => {}
                    Err(e) => report.refused.push((task.job_id, format!("{e:#}"))),
                }
                continue;
            }
            Ok(None) => {}
            Err(why) => report.refused.push((task.job_id, why)),
        }
        if task.state != "active" || !handed {
            continue;
        }
        if let Ok(Some(f)) = files::read_json::<FailedMarker>(&dir.join("failed.json")) {
            if f.job_id == task.job_id && f.hash == hash {
                let why = format!("under Slurm (task {}): {}", task.slurm_id(), f.error);
                slurm_tasks::end_without_result(conn, &task, "failed", "failed", &why)?;
                report.failed.push((task.job_id, why));
                continue;
            }
        }
        let Some(view) = &report.view else {
            continue;
        };
        match view.get(&task.array_job_id, task.array_task_id) {
            Some(tv) if tv.alive() => {
                if let Ok(Some(p)) = files::read_json::<ProgressFile>(&dir.join("progress.json")) {
                    let frac = if p.target_time_s > 0.0 {
                        (p.sim_time_s / p.target_time_s).min(1.0)
                    } else {
                        0.0
                    };
                    slurm_tasks::set_progress(
                        conn,
                        task.job_id,
                        p.sim_time_s,
                        frac,
                        p.wall_time_s,
                    )?;
                }
                report.with_slurm.push(task.job_id);
            }
            found => {
                let what = match found {
                    Some(tv) => format!("ended {}", tv.describe()),
                    None => "is no longer known to Slurm (ended longer ago than MinJobAge, no accounting)".into(),
                };
                let why = format!(
                    "Slurm task {} {what} without a result; `sweep resume` resubmits it from its checkpoint",
                    task.slurm_id()
                );
                slurm_tasks::end_without_result(conn, &task, "ended", "paused", &why)?;
                report.ended.push((task.job_id, why));
            }
        }
    }
    Ok(report)
}

/// A job not done whose latest submission went to Slurm.
struct OpenJob {
    task: SlurmTask,
    status: String,
    hash: String,
    lease: Option<String>,
}

impl OpenJob {
    /// Running with a Slurm lease: handed to Slurm and not heard of since.
    fn handed(&self) -> bool {
        self.status == "running"
            && self
                .lease
                .as_deref()
                .is_some_and(|l| l.starts_with(slurm_tasks::LEASE_PREFIX))
    }
}

/// Every job not done whose latest submission went to Slurm.
fn open_jobs(conn: &Connection) -> anyhow::Result<Vec<OpenJob>> {
    let latest = slurm_tasks::latest_by_job(conn, None)?;
    let mut out = Vec::new();
    for (id, task) in latest {
        let jobs::JobState {
            status,
            hash,
            lease_owner: lease,
        } = jobs::job_state(conn, id)?;
        if status != "done" {
            out.push(OpenJob {
                task,
                status,
                hash,
                lease,
            });
        }
    }
    Ok(out)
}

/// What `cancel` did.
#[derive(Debug, Default)]
pub struct CancelReport {
    /// Arrays cancelled.
    pub arrays: Vec<String>,
    /// Jobs paused (their tasks were queued or running).
    pub paused: Vec<i64>,
}

/// Cancels the arrays of `campaign` (or of every campaign) that still have a job queued or
/// running, and pauses those jobs at their last checkpoint. Run `collect` first: a job whose
/// result is already there is done, not cancelled.
///
/// # Errors
/// `scancel` missing or failing (nothing is marked then), database errors.
pub fn cancel(conn: &mut Connection, campaign: Option<i64>) -> anyhow::Result<CancelReport> {
    let open: Vec<SlurmTask> = open_jobs(conn)?
        .into_iter()
        .filter(|o| {
            o.task.state == "active"
                && o.handed()
                && (campaign.is_none() || o.task.campaign_id == campaign)
        })
        .map(|o| o.task)
        .collect();
    let mut arrays: Vec<String> = open.iter().map(|t| t.array_job_id.clone()).collect();
    arrays.sort();
    arrays.dedup();
    query::cancel(&arrays)?;
    let mut report = CancelReport {
        arrays,
        paused: Vec::new(),
    };
    for t in open {
        slurm_tasks::end_without_result(
            conn,
            &t,
            "cancelled",
            "paused",
            &format!(
                "Slurm task {} cancelled by `sweep cancel`; `sweep resume` resubmits it from its checkpoint",
                t.slurm_id()
            ),
        )?;
        report.paused.push(t.job_id);
    }
    Ok(report)
}
