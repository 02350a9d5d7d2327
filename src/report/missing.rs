//! Which jobs of a campaign are not done yet, so a figure can say what it lacks. Read-only.

use anyhow::Result;
use rusqlite::{params, Connection};

/// How far a campaign has come.
#[derive(Debug, Clone, Default)]
pub struct Completion {
    /// Number of jobs in the campaign.
    pub total: usize,
    /// Labels (campaign_jobs.label) of the jobs whose status is not 'done', sorted.
    pub missing: Vec<String>,
}

/// The campaign's job count and the labels of its jobs that are not done.
///
/// # Errors
/// On a database error.
pub fn campaign_completion(conn: &Connection, campaign_id: i64) -> Result<Completion> {
    let mut stmt = conn.prepare(
        "SELECT cj.label, j.status FROM campaign_jobs cj JOIN jobs j ON j.id = cj.job_id \
         WHERE cj.campaign_id = ?1 ORDER BY cj.label",
    )?;
    let rows = stmt
        .query_map(params![campaign_id], |r| {
            Ok((r.get::<_, String>(0)?, r.get::<_, String>(1)?))
        })?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    let total = rows.len();
    let missing = rows
        .into_iter()
        .filter(|(_, status)| status != "done")
        .map(|(label, _)| label)
        .collect();
    Ok(Completion { total, missing })
}
