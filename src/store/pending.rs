//! Pending jobs as the Slurm submitter reads them: what a task file needs to know about each,
//! and which campaign each belongs to first (whose settings `sweep resume` submits it with).

use rusqlite::Connection;

/// A pending job, as a Slurm task file describes it.
#[derive(Clone, Debug)]
pub struct PendingTask {
    pub job_id: i64,
    pub hash: String,
    pub scene: String,
    pub params_json: String,
    pub seed: i64,
    pub target_time_s: f64,
    pub sim_time_s: f64,
    /// Its label in its first campaign link ("" when it has none).
    pub label: String,
}

/// The pending ones of `ids`, in the order given (the others are left out).
///
/// # Errors
/// Database errors.
pub fn pending_tasks(conn: &Connection, ids: &[i64]) -> anyhow::Result<Vec<PendingTask>> {
    let mut q = conn.prepare(
        "SELECT j.id, j.hash, j.scene, j.params_json, j.seed, j.target_time_s, j.sim_time_s,
                COALESCE((SELECT label FROM campaign_jobs cj WHERE cj.job_id = j.id LIMIT 1), '')
         FROM jobs j WHERE j.id = ?1 AND j.status = 'pending'",
    )?;
    let mut out = Vec::new();
    for &id in ids {
        let mut rows = q.query_map([id], |r| {
            Ok(PendingTask {
                job_id: r.get(0)?,
                hash: r.get(1)?,
                scene: r.get(2)?,
                params_json: r.get(3)?,
                seed: r.get(4)?,
                target_time_s: r.get(5)?,
                sim_time_s: r.get(6)?,
                label: r.get(7)?,
            })
        })?;
        if let Some(s) = rows.next() {
            out.push(s?);
        }
    }
    Ok(out)
}

/// A pending job and the first campaign it belongs to (all `None` when it belongs to none).
#[derive(Clone, Debug)]
pub struct PendingJob {
    pub id: i64,
    pub campaign_id: Option<i64>,
    pub campaign_name: Option<String>,
    /// The campaign file as stored (JSON).
    pub campaign_spec: Option<String>,
}

/// Every pending job with its first campaign, in id order.
///
/// # Errors
/// Database errors.
pub fn pending_jobs(conn: &Connection) -> anyhow::Result<Vec<PendingJob>> {
    let mut q = conn.prepare(
        "SELECT j.id, c.id, c.name, c.spec_json FROM jobs j
         LEFT JOIN campaigns c ON c.id = (SELECT MIN(campaign_id) FROM campaign_jobs WHERE job_id = j.id)
         WHERE j.status = 'pending' ORDER BY j.id",
    )?;
    let rows = q
        .query_map([], |r| {
            Ok(PendingJob {
                id: r.get(0)?,
                campaign_id: r.get(1)?,
                campaign_name: r.get(2)?,
                campaign_spec: r.get(3)?,
            })
        })?
        .collect::<Result<_, _>>()?;
    Ok(rows)
}
