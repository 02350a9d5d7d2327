//! Jobs: registration (idempotent by parameter hash), claiming with a lease in one transaction,
//! heartbeats, and the end states.

use anyhow::Context;
use rusqlite::{params, Connection, OptionalExtension, TransactionBehavior};

use super::now;
use crate::campaign::{CampaignFile, JobSpec};

/// A job as stored.
#[derive(Clone, Debug)]
pub struct JobRow {
    pub id: i64,
    pub hash: String,
    pub params_json: String,
    pub status: String,
    pub attempts: i64,
    pub sim_time_s: f64,
    pub target_time_s: f64,
    pub label: String,
}

/// The owner of a claimed job (process id and a random tag).
#[derive(Clone, Debug)]
pub struct Lease {
    pub owner: String,
}

impl Lease {
    pub fn new() -> Self {
        Self {
            owner: format!("{}:{}", std::process::id(), now()),
        }
    }
}

impl Default for Lease {
    fn default() -> Self {
        Self::new()
    }
}

/// Registers a campaign and its jobs. Returns (campaign id, jobs added). Launching the same
/// file twice adds nothing; a changed parameter adds a new job.
///
/// # Errors
/// Database errors.
pub fn register(
    conn: &mut Connection,
    file: &str,
    c: &CampaignFile,
    jobs: &[JobSpec],
) -> anyhow::Result<(i64, usize)> {
    let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
    let spec = serde_json::to_string(c)?;
    tx.execute(
        "INSERT INTO campaigns (name, file, scene, spec_json) VALUES (?1, ?2, ?4, ?3)
         ON CONFLICT(name) DO UPDATE SET file = excluded.file, spec_json = excluded.spec_json",
        params![c.name, file, spec, c.scene.name()],
    )?;
    let cid: i64 = tx.query_row("SELECT id FROM campaigns WHERE name = ?1", [&c.name], |r| {
        r.get(0)
    })?;
    let mut added = 0;
    for j in jobs {
        let target = j.target_time_s();
        let n = tx.execute(
            "INSERT OR IGNORE INTO jobs (hash, scene, params_json, seed, target_time_s, particles, precision, program_version)
             VALUES (?1, ?8, ?2, ?3, ?4, ?5, ?6, ?7)",
            params![j.hash(), j.resolved_json(), j.seed() as i64, target, j.particle_count() as i64, j.precision.name(), env!("CARGO_PKG_VERSION"), j.scene.name()],
        )?;
        added += n;
        let jid: i64 = tx.query_row("SELECT id FROM jobs WHERE hash = ?1", [j.hash()], |r| {
            r.get(0)
        })?;
        tx.execute(
            "INSERT OR IGNORE INTO campaign_jobs (campaign_id, job_id, label) VALUES (?1, ?2, ?3)",
            params![cid, jid, j.label],
        )?;
    }
    tx.commit()?;
    Ok((cid, added))
}

/// Claims the next pending job (of `campaign` if given) for `lease`, in one transaction, so two
/// launchers never run the same job.
///
/// # Errors
/// Database errors.
pub fn claim(
    conn: &mut Connection,
    campaign: Option<i64>,
    lease: &Lease,
) -> anyhow::Result<Option<JobRow>> {
    let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
    let row = tx
        .query_row(
            "SELECT j.id, j.hash, j.params_json, j.status, j.attempts, j.sim_time_s, j.target_time_s,
                    COALESCE((SELECT label FROM campaign_jobs cj WHERE cj.job_id = j.id LIMIT 1), '')
             FROM jobs j
             WHERE j.status = 'pending' AND (?1 IS NULL OR j.id IN (SELECT job_id FROM campaign_jobs WHERE campaign_id = ?1))
             ORDER BY j.id LIMIT 1",
            [campaign],
            |r| {
                Ok(JobRow {
                    id: r.get(0)?,
                    hash: r.get(1)?,
                    params_json: r.get(2)?,
                    status: r.get(3)?,
                    attempts: r.get(4)?,
                    sim_time_s: r.get(5)?,
                    target_time_s: r.get(6)?,
                    label: r.get(7)?,
                })
            },
        )
        .optional()?;
    if let Some(j) = &row {
        tx.execute(
            "UPDATE jobs SET status = 'running', lease_owner = ?2, heartbeat_at = ?3, attempts = attempts + 1 WHERE id = ?1 AND status = 'pending'",
            params![j.id, lease.owner, now()],
        )?;
    }
    tx.commit()?;
    Ok(row)
}

/// Progress of a running job; also renews the lease.
///
/// # Errors
/// Database errors.
#[allow(clippy::too_many_arguments)]
pub fn heartbeat(
    conn: &Connection,
    id: i64,
    lease: &Lease,
    sim_time: f64,
    progress: f64,
    particle_steps: u64,
    wall_time: f64,
    checkpoint: Option<&str>,
) -> anyhow::Result<()> {
    conn.execute(
        "UPDATE jobs SET heartbeat_at = ?3, sim_time_s = ?4, progress = ?5, particle_steps = ?6, wall_time_s = ?7,
                checkpoint_path = COALESCE(?8, checkpoint_path)
         WHERE id = ?1 AND lease_owner = ?2",
        params![id, lease.owner, now(), sim_time, progress, particle_steps as i64, wall_time, checkpoint],
    )
    .context("heartbeat")?;
    Ok(())
}

/// Records the backend a job runs on.
///
/// # Errors
/// Database errors.
pub fn set_backend(
    conn: &Connection,
    id: i64,
    backend: &str,
    adapter: &str,
    precision: &str,
    particles: usize,
) -> anyhow::Result<()> {
    conn.execute("UPDATE jobs SET backend = ?2, adapter = ?3, precision = ?4, particles = ?5, program_version = ?6 WHERE id = ?1", params![id, backend, adapter, precision, particles as i64, env!("CARGO_PKG_VERSION")])?;
    Ok(())
}

/// Ends a job as paused (interrupted) or failed (with its error kept), releasing the lease.
///
/// # Errors
/// Database errors.
pub fn release(
    conn: &Connection,
    id: i64,
    status: &str,
    error: Option<&str>,
) -> anyhow::Result<()> {
    conn.execute("UPDATE jobs SET status = ?2, last_error = COALESCE(?3, last_error), lease_owner = NULL WHERE id = ?1", params![id, status, error])?;
    Ok(())
}

/// Makes resumable jobs pending again: paused ones, running ones whose heartbeat is older than
/// `stale_after_s` (their process died; not those handed to Slurm), failed ones with attempts
/// left. Returns how many.
///
/// # Errors
/// Database errors.
pub fn requeue(
    conn: &mut Connection,
    stale_after_s: f64,
    max_attempts: i64,
) -> anyhow::Result<usize> {
    let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
    let mut n = tx.execute(
        "UPDATE jobs SET status = 'pending', lease_owner = NULL WHERE status = 'paused'",
        [],
    )?;
    // A job handed to Slurm has no heartbeat here: `sweep collect` decides when its task ended.
    n += tx.execute("UPDATE jobs SET status = 'pending', lease_owner = NULL WHERE status = 'running' AND (heartbeat_at IS NULL OR heartbeat_at < ?1) AND COALESCE(lease_owner, '') NOT LIKE 'slurm:%'", [now() - stale_after_s])?;
    n += tx.execute("UPDATE jobs SET status = 'pending', lease_owner = NULL WHERE status = 'failed' AND attempts < ?1", [max_attempts])?;
    tx.commit()?;
    Ok(n)
}
