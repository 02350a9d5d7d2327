//! How many jobs are where: the counts and id lists the launchers print and submit from.

use rusqlite::Connection;

/// Done jobs of a campaign.
///
/// # Errors
/// Database errors.
pub fn campaign_done_count(conn: &Connection, campaign_id: i64) -> anyhow::Result<i64> {
    Ok(conn.query_row(
        "SELECT COUNT(*) FROM jobs j JOIN campaign_jobs cj ON cj.job_id = j.id WHERE cj.campaign_id = ?1 AND j.status = 'done'",
        [campaign_id],
        |r| r.get(0),
    )?)
}

/// Ids of a campaign's pending jobs, in id order.
///
/// # Errors
/// Database errors.
pub fn pending_job_ids(conn: &Connection, campaign_id: i64) -> anyhow::Result<Vec<i64>> {
    let mut q = conn.prepare(
        "SELECT j.id FROM jobs j JOIN campaign_jobs cj ON cj.job_id = j.id
         WHERE cj.campaign_id = ?1 AND j.status = 'pending' ORDER BY j.id",
    )?;
    let ids = q
        .query_map([campaign_id], |r| r.get(0))?
        .collect::<Result<Vec<i64>, _>>()?;
    Ok(ids)
}

/// Pending jobs in the whole store.
///
/// # Errors
/// Database errors.
pub fn pending_count(conn: &Connection) -> anyhow::Result<i64> {
    Ok(conn.query_row(
        "SELECT COUNT(*) FROM jobs WHERE status = 'pending'",
        [],
        |r| r.get(0),
    )?)
}

/// Failed jobs in the whole store (each with no attempts left once `resume` has looked).
///
/// # Errors
/// Database errors.
pub fn failed_count(conn: &Connection) -> anyhow::Result<i64> {
    Ok(conn.query_row(
        "SELECT COUNT(*) FROM jobs WHERE status = 'failed'",
        [],
        |r| r.get(0),
    )?)
}

/// Jobs in the whole store, and how many of them are done.
#[derive(Clone, Copy, Debug)]
pub struct JobTotals {
    pub total: i64,
    pub done: i64,
}

/// Jobs in the whole store, and how many are done.
///
/// # Errors
/// Database errors.
pub fn job_totals(conn: &Connection) -> anyhow::Result<JobTotals> {
    Ok(conn.query_row(
        "SELECT COUNT(*), COALESCE(SUM(status = 'done'), 0) FROM jobs",
        [],
        |r| {
            Ok(JobTotals {
                total: r.get(0)?,
                done: r.get(1)?,
            })
        },
    )?)
}
