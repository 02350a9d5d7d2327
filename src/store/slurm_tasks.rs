//! Jobs handed to Slurm (`slurm_tasks`): taking pending jobs for a submission, recording the
//! array and task that run each one, and how each ended (`slurm_ingest` copies a finished task's
//! results in). Only the submitting host writes here; tasks never open this database.
//!
//! A job handed to Slurm is `running` with the lease `slurm:<array>_<task>` (`slurm:submitting`
//! while `sbatch` runs), so local launchers never claim it and `sweep resume` leaves it to Slurm.

use std::collections::BTreeMap;
use std::path::Path;

use rusqlite::{params, Connection, OptionalExtension, TransactionBehavior};

use super::now;

/// Leases of jobs handed to Slurm start with this.
pub const LEASE_PREFIX: &str = "slurm:";

/// The lease of jobs taken for a submission whose `sbatch` has not answered yet.
const SUBMITTING: &str = "slurm:submitting";

/// A job handed to Slurm, as recorded at submission.
#[derive(Clone, Debug)]
pub struct SlurmTask {
    pub id: i64,
    pub job_id: i64,
    pub campaign_id: Option<i64>,
    pub array_job_id: String,
    pub array_task_id: u32,
    pub script_path: String,
    pub settings_json: String,
    /// active | done | failed | ended | cancelled.
    pub state: String,
    pub note: Option<String>,
}

impl SlurmTask {
    /// `array_task`, as Slurm's commands name an array task.
    pub fn slurm_id(&self) -> String {
        format!("{}_{}", self.array_job_id, self.array_task_id)
    }

    fn from_row(r: &rusqlite::Row<'_>) -> rusqlite::Result<Self> {
        Ok(Self {
            id: r.get(0)?,
            job_id: r.get(1)?,
            campaign_id: r.get(2)?,
            array_job_id: r.get(3)?,
            array_task_id: r.get(4)?,
            script_path: r.get(5)?,
            settings_json: r.get(6)?,
            state: r.get(7)?,
            note: r.get(8)?,
        })
    }
}

const COLUMNS: &str = "t.id, t.job_id, t.campaign_id, t.array_job_id, t.array_task_id, t.script_path, t.settings_json, t.state, t.note";

/// Whether any job was ever handed to Slurm (when not, nobody needs to ask Slurm anything).
///
/// # Errors
/// Database errors.
pub fn any(conn: &Connection) -> anyhow::Result<bool> {
    Ok(conn
        .query_row("SELECT 1 FROM slurm_tasks LIMIT 1", [], |_| Ok(()))
        .optional()?
        .is_some())
}

/// Takes the pending ones of `ids` for a submission (running, lease `slurm:submitting`, one
/// more attempt), in one transaction; returns those taken, in the order given.
///
/// # Errors
/// Database errors.
pub fn take_for_submission(conn: &mut Connection, ids: &[i64]) -> anyhow::Result<Vec<i64>> {
    let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
    let mut taken = Vec::new();
    for &id in ids {
        let n = tx.execute(
            "UPDATE jobs SET status = 'running', lease_owner = ?2, heartbeat_at = ?3, attempts = attempts + 1
             WHERE id = ?1 AND status = 'pending'",
            params![id, SUBMITTING, now()],
        )?;
        if n == 1 {
            taken.push(id);
        }
    }
    tx.commit()?;
    Ok(taken)
}

/// Gives jobs taken for a submission back (pending again, the attempt not counted), with the
/// reason the submission failed.
///
/// # Errors
/// Database errors.
pub fn give_back(conn: &mut Connection, ids: &[i64], error: &str) -> anyhow::Result<()> {
    let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
    for &id in ids {
        tx.execute(
            "UPDATE jobs SET status = 'pending', lease_owner = NULL, attempts = MAX(attempts - 1, 0), last_error = ?3
             WHERE id = ?1 AND lease_owner = ?2",
            params![id, SUBMITTING, error],
        )?;
    }
    tx.commit()?;
    Ok(())
}

/// Gives back jobs taken for a submission longer than `stale_after_s` ago that was never
/// recorded (the submitting process died around `sbatch`); returns how many.
///
/// # Errors
/// Database errors.
pub fn release_stale_submissions(conn: &Connection, stale_after_s: f64) -> anyhow::Result<usize> {
    Ok(conn.execute(
        "UPDATE jobs SET status = 'pending', lease_owner = NULL,
                last_error = 'its submission to Slurm was interrupted; submitted again'
         WHERE status = 'running' AND lease_owner = ?1 AND (heartbeat_at IS NULL OR heartbeat_at < ?2)",
        params![SUBMITTING, now() - stale_after_s],
    )?)
}

/// Records a submitted array: task `k` runs `jobs[k]`. Each job's lease names its task.
///
/// # Errors
/// Database errors.
pub fn record(
    conn: &mut Connection,
    campaign_id: Option<i64>,
    array_job_id: &str,
    jobs: &[i64],
    script: &Path,
    settings_json: &str,
) -> anyhow::Result<()> {
    let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
    for (k, &job) in jobs.iter().enumerate() {
        tx.execute(
            "INSERT INTO slurm_tasks (job_id, campaign_id, array_job_id, array_task_id, script_path, settings_json)
             VALUES (?1, ?2, ?3, ?4, ?5, ?6)",
            params![job, campaign_id, array_job_id, k as i64, script.display().to_string(), settings_json],
        )?;
        tx.execute(
            "UPDATE jobs SET lease_owner = ?2, heartbeat_at = ?3, last_error = NULL WHERE id = ?1",
            params![job, format!("{LEASE_PREFIX}{array_job_id}_{k}"), now()],
        )?;
    }
    tx.commit()?;
    Ok(())
}

/// The latest submission of every job that has one, keyed by job id (of `campaign`, or all).
///
/// # Errors
/// Database errors.
pub fn latest_by_job(
    conn: &Connection,
    campaign: Option<i64>,
) -> anyhow::Result<BTreeMap<i64, SlurmTask>> {
    let mut q = conn.prepare(&format!(
        "SELECT {COLUMNS} FROM slurm_tasks t
         WHERE t.id = (SELECT MAX(id) FROM slurm_tasks WHERE job_id = t.job_id)
           AND (?1 IS NULL OR t.job_id IN (SELECT job_id FROM campaign_jobs WHERE campaign_id = ?1))"
    ))?;
    let rows = q
        .query_map([campaign], SlurmTask::from_row)?
        .collect::<Result<Vec<_>, _>>()?;
    Ok(rows.into_iter().map(|t| (t.job_id, t)).collect())
}

/// Sets a submission's state and how it ended.
///
/// # Errors
/// Database errors.
pub fn set_state(
    conn: &Connection,
    id: i64,
    state: &str,
    note: Option<&str>,
) -> anyhow::Result<()> {
    conn.execute(
        "UPDATE slurm_tasks SET state = ?2, note = COALESCE(?3, note) WHERE id = ?1",
        params![id, state, note],
    )?;
    Ok(())
}

/// Ends a job handed to Slurm without a result: `paused` (its checkpoint is kept; `sweep
/// resume` resubmits it) or `failed`, with the reason; the submission's state with it.
///
/// # Errors
/// Database errors.
pub fn end_without_result(
    conn: &mut Connection,
    task: &SlurmTask,
    task_state: &str,
    job_status: &str,
    reason: &str,
) -> anyhow::Result<()> {
    let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
    tx.execute(
        "UPDATE jobs SET status = ?2, lease_owner = NULL, last_error = ?3
         WHERE id = ?1 AND status = 'running' AND lease_owner LIKE 'slurm:%'",
        params![task.job_id, job_status, reason],
    )?;
    set_state(&tx, task.id, task_state, Some(reason))?;
    tx.commit()?;
    Ok(())
}

/// Progress of a job running under Slurm, as its task last reported it.
///
/// # Errors
/// Database errors.
pub fn set_progress(
    conn: &Connection,
    job_id: i64,
    sim_time_s: f64,
    progress: f64,
    wall_time_s: f64,
) -> anyhow::Result<()> {
    conn.execute(
        "UPDATE jobs SET sim_time_s = ?2, progress = ?3, wall_time_s = ?4, heartbeat_at = ?5
         WHERE id = ?1 AND status = 'running' AND lease_owner LIKE 'slurm:%'",
        params![job_id, sim_time_s, progress, wall_time_s, now()],
    )?;
    Ok(())
}
