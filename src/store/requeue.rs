//! `sweep resume`'s look at every job not done: which to run again, which to mark failed (its
//! attempts spent), which to leave alone and why. The caller says whether a running job's owner
//! lives (its OS lock, or its heartbeat).

use rusqlite::{params, Connection, TransactionBehavior};

use super::lease::{owner_place, OwnerPlace};
use super::now;
use super::scope::{in_latest_version, JobScope};

/// A job that is not done and that `resume` looked at.
#[derive(Clone, Debug)]
pub struct OpenJob {
    pub id: i64,
    pub hash: String,
    pub label: String,
    pub status: String,
    pub attempts: i64,
    pub max_attempts: i64,
    pub lease_owner: Option<String>,
    pub heartbeat_age_s: Option<f64>,
    pub stage: Option<String>,
    pub last_error: Option<String>,
}

/// What a running job's owner is, as the caller found out (its OS lock, or its heartbeat).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Liveness {
    /// Its process lives: leave it alone (the reason is said).
    Alive(String),
    /// Its process is gone (the reason is said).
    Gone(String),
}

/// What `requeue` did with one job.
#[derive(Clone, Debug)]
pub struct Decision {
    pub job: OpenJob,
    /// 'pending' (to be run), 'failed' (no attempts left) or 'left' (left alone).
    pub action: &'static str,
    pub why: String,
}

/// Every job of `scope` not done, with its lease and heartbeat age.
///
/// # Errors
/// Database errors.
pub fn open_jobs(conn: &Connection, scope: JobScope) -> anyhow::Result<Vec<OpenJob>> {
    let t = now();
    let (campaign, latest_only) = scope.sql();
    let mut q = conn.prepare(&format!(
        "SELECT j.id, j.hash, COALESCE((SELECT label FROM campaign_jobs cj WHERE cj.job_id = j.id LIMIT 1), ''),
                j.status, j.attempts, j.max_attempts, j.lease_owner, ?1 - j.heartbeat_at, j.stage, j.last_error
         FROM jobs j
         WHERE j.status != 'done' AND (?2 IS NULL OR j.id IN (SELECT job_id FROM campaign_jobs WHERE campaign_id = ?2))
           AND {}
         ORDER BY j.id",
        in_latest_version("?3")
    ))?;
    let rows = q
        .query_map(params![t, campaign, latest_only], |r| {
            Ok(OpenJob {
                id: r.get(0)?,
                hash: r.get(1)?,
                label: r.get(2)?,
                status: r.get(3)?,
                attempts: r.get(4)?,
                max_attempts: r.get(5)?,
                lease_owner: r.get(6)?,
                heartbeat_age_s: r.get(7)?,
                stage: r.get(8)?,
                last_error: r.get(9)?,
            })
        })?
        .collect::<Result<_, _>>()?;
    Ok(rows)
}

/// Makes resumable jobs pending again, in one transaction (claims wait for it): paused ones,
/// running ones whose owner `liveness` finds gone (not those handed to Slurm: `sweep collect`
/// decides those), failed ones with attempts left. A running job whose owner is gone after its
/// last attempt is marked failed with the cause. `max_attempts` overrides each job's own.
/// Only the jobs of `scope`. Returns a decision for every such job not done.
///
/// # Errors
/// Database errors.
pub fn requeue(
    conn: &mut Connection,
    scope: JobScope,
    max_attempts: Option<i64>,
    mut liveness: impl FnMut(&OpenJob) -> Liveness,
) -> anyhow::Result<Vec<Decision>> {
    let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
    let mut out = Vec::new();
    for job in open_jobs(&tx, scope)? {
        let limit = max_attempts.unwrap_or(job.max_attempts);
        let (action, why) = match job.status.as_str() {
            "paused" => ("pending", "paused at its checkpoint".to_string()),
            "pending" if job.attempts >= limit => (
                "failed",
                format!("no attempts left ({} of {limit})", job.attempts),
            ),
            "pending" => ("pending", "not started yet".to_string()),
            "failed" if job.attempts < limit => (
                "pending",
                format!("failed, retried (attempt {} of {limit})", job.attempts + 1),
            ),
            "failed" => (
                "left",
                format!(
                    "failed after {} of {limit} attempts (`--max-attempts` allows more): {}",
                    job.attempts,
                    job.last_error.as_deref().unwrap_or("no error recorded")
                ),
            ),
            "running" if owner_place(job.lease_owner.as_deref()) == OwnerPlace::Slurm => {
                ("left", "handed to Slurm: `sweep collect` follows it".into())
            }
            "running" => match liveness(&job) {
                Liveness::Alive(why) => ("left", why),
                Liveness::Gone(why) => {
                    let stage = job.stage.as_deref().unwrap_or("claimed");
                    let cause = format!("{why}, during stage '{stage}'");
                    if job.attempts >= limit {
                        (
                            "failed",
                            format!("{cause}; no attempts left ({} of {limit})", job.attempts),
                        )
                    } else {
                        (
                            "pending",
                            format!("{cause} (attempt {} of {limit})", job.attempts),
                        )
                    }
                }
            },
            _ => ("left", format!("status '{}'", job.status)),
        };
        match action {
            "pending" => {
                tx.execute(
                    "UPDATE jobs SET status = 'pending', lease_owner = NULL WHERE id = ?1",
                    [job.id],
                )?;
                if job.status == "running" {
                    tx.execute(
                        "UPDATE jobs SET last_error = ?2 WHERE id = ?1",
                        params![job.id, why],
                    )?;
                }
            }
            "failed" => {
                tx.execute(
                    "UPDATE jobs SET status = 'failed', lease_owner = NULL, last_error = ?2 WHERE id = ?1",
                    params![job.id, why],
                )?;
            }
            _ => {}
        }
        out.push(Decision { job, action, why });
    }
    tx.commit()?;
    Ok(out)
}
