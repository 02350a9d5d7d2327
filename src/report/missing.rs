//! Which jobs of a campaign are not done yet, so a figure can say what it lacks. Read-only.

use anyhow::Result;
use rusqlite::Connection;

use crate::store::campaign_reads::{campaign_job_statuses, LabelledStatus};

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
    let rows = campaign_job_statuses(conn, campaign_id)?;
    let total = rows.len();
    let missing = rows
        .into_iter()
        .filter(|r| r.status != "done")
        .map(|LabelledStatus { label, .. }| label)
        .collect();
    Ok(Completion { total, missing })
}
