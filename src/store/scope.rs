//! Which jobs a run, a requeue or a listing takes: all, one campaign version's, or those of
//! every campaign's latest version.

/// Which jobs a run or a requeue takes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum JobScope {
    /// Every job of the store.
    #[default]
    All,
    /// The jobs of one campaign version (`campaigns.id`).
    Campaign(i64),
    /// The jobs of each campaign's latest version: what a plain `resume` continues, so that an
    /// older version that a new one replaces is left as it is.
    LatestVersions,
}

impl JobScope {
    /// (campaign id or NULL, whether only latest versions' jobs) as SQL parameters.
    pub(crate) fn sql(self) -> (Option<i64>, bool) {
        match self {
            JobScope::All => (None, false),
            JobScope::Campaign(c) => (Some(c), false),
            JobScope::LatestVersions => (None, true),
        }
    }
}

/// An SQL condition on job `j.id`: true when the flag parameter `flag` (e.g. "?5") is 0, or
/// the job belongs to a campaign that no later version of the same name replaces. Correlated on
/// the job (index `campaign_jobs_job`), so a claim in a store of 10⁶ jobs stays cheap.
pub(crate) fn in_latest_version(flag: &str) -> String {
    format!(
        "({flag} = 0 OR EXISTS (SELECT 1 FROM campaign_jobs lj JOIN campaigns lc ON lc.id = lj.campaign_id
            WHERE lj.job_id = j.id AND NOT EXISTS (SELECT 1 FROM campaigns ln
                WHERE ln.name = lc.name AND ln.version > lc.version)))"
    )
}

/// The ids of the campaigns no later version of the same name replaces, ascending.
///
/// # Errors
/// Database errors.
pub fn latest_campaign_ids(conn: &rusqlite::Connection) -> anyhow::Result<Vec<i64>> {
    let mut q = conn.prepare(
        "SELECT c.id FROM campaigns c
         WHERE NOT EXISTS (SELECT 1 FROM campaigns n WHERE n.name = c.name AND n.version > c.version)
         ORDER BY c.id",
    )?;
    let ids = q
        .query_map([], |r| r.get(0))?
        .collect::<rusqlite::Result<_>>()?;
    Ok(ids)
}
