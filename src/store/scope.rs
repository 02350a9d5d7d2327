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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::store::jobs::{claim, open_jobs, Lease};
    use crate::store::test_rows;

    /// Version 1 of "c" with pending jobs 1 and 2, version 2 sharing job 2 and adding job 3,
    /// and another campaign "d" with job 4.
    fn two_versions() -> rusqlite::Connection {
        let conn = test_rows::empty_db();
        let v1 = test_rows::campaign(&conn, "c", "silo", "2026-01-01T00:00:00Z");
        // (name, version) is unique: registered under another name, then made version 2.
        let v2 = test_rows::campaign(&conn, "c@2", "silo", "2026-01-02T00:00:00Z");
        conn.execute(
            "UPDATE campaigns SET name = 'c', version = 2 WHERE id = ?1",
            [v2],
        )
        .expect("version");
        let d = test_rows::campaign(&conn, "d", "silo", "2026-01-03T00:00:00Z");
        test_rows::silo_job(&conn, v1, "old", "pending", "{}");
        let shared = test_rows::silo_job(&conn, v1, "shared", "pending", "{}");
        conn.execute(
            "INSERT INTO campaign_jobs (campaign_id, job_id, label) VALUES (?1, ?2, 'shared')",
            [v2, shared],
        )
        .expect("share");
        test_rows::silo_job(&conn, v2, "new", "pending", "{}");
        test_rows::silo_job(&conn, d, "other", "pending", "{}");
        conn
    }

    fn open_ids(conn: &rusqlite::Connection, scope: JobScope) -> Vec<i64> {
        open_jobs(conn, scope)
            .expect("open")
            .iter()
            .map(|j| j.id)
            .collect()
    }

    #[test]
    fn latest_versions_leave_out_only_what_a_newer_version_replaces() {
        let mut conn = two_versions();
        assert_eq!(latest_campaign_ids(&conn).expect("latest"), vec![2, 3]);
        assert_eq!(open_ids(&conn, JobScope::All), vec![1, 2, 3, 4]);
        assert_eq!(open_ids(&conn, JobScope::LatestVersions), vec![2, 3, 4]);
        assert_eq!(open_ids(&conn, JobScope::Campaign(1)), vec![1, 2]);
        let mut claimed = Vec::new();
        while let Some((job, ())) = claim(
            &mut conn,
            JobScope::LatestVersions,
            &Lease::new(),
            None,
            |_| Ok(Some(())),
        )
        .expect("claim")
        {
            claimed.push(job.id);
        }
        assert_eq!(claimed, vec![2, 3, 4], "job 1 is only version 1's");
        let old = claim(&mut conn, JobScope::All, &Lease::new(), None, |_| {
            Ok(Some(()))
        })
        .expect("claim")
        .map(|(j, ())| j.id);
        assert_eq!(old, Some(1));
    }
}
