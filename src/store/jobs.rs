//! Jobs: registration (idempotent by parameter hash), claiming with a lease in one transaction,
//! heartbeats, and the end states.

use anyhow::Context;
use rusqlite::{params, Connection, TransactionBehavior};

use super::now;

pub use super::lease::{owner_place, this_host, Lease, OwnerPlace};
use super::scope::in_latest_version;
pub use super::scope::JobScope;

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
    /// Claims allowed in all (`run.max_attempts` of its campaign).
    pub max_attempts: i64,
}

/// A page of claim candidates: pending jobs after id ?3 with attempts left (?2 overrides each
/// job's own limit), of campaign ?1 if not NULL, of a latest version when ?5, at most ?4.
const CLAIM_PAGE: &str =
    "SELECT j.id, j.hash, j.params_json, j.status, j.attempts, j.sim_time_s, j.target_time_s,
        COALESCE((SELECT label FROM campaign_jobs cj WHERE cj.job_id = j.id LIMIT 1), ''),
        j.max_attempts
 FROM jobs j
 WHERE j.status = 'pending' AND j.id > ?3
   AND j.attempts < COALESCE(?2, j.max_attempts)
   AND (?1 IS NULL OR EXISTS (SELECT 1 FROM campaign_jobs cj
                              WHERE cj.campaign_id = ?1 AND cj.job_id = j.id))
   AND {LATEST}
 ORDER BY j.id LIMIT ?4";

/// `CLAIM_PAGE` with its latest-version condition on ?5.
fn claim_page() -> String {
    CLAIM_PAGE.replace("{LATEST}", &in_latest_version("?5"))
}

/// Claims the next pending job (of `scope`) for `lease`, in one transaction, so two
/// launchers never run the same job. `hold` is called inside that transaction with each
/// candidate in turn and returns what keeps the job held (its OS lock) or `None` when another
/// process holds it; the first job held is marked running, its attempt counted and its stage
/// set to 'claimed'. A job without attempts left (`max_attempts`, or the job's own) is not
/// claimed.
///
/// # Errors
/// Database errors, or an error from `hold`.
pub fn claim<T>(
    conn: &mut Connection,
    scope: JobScope,
    lease: &Lease,
    max_attempts: Option<i64>,
    mut hold: impl FnMut(&JobRow) -> anyhow::Result<Option<T>>,
) -> anyhow::Result<Option<(JobRow, T)>> {
    let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
    // Candidates are read a page at a time in id order: the first is nearly always held, and a
    // store of 10⁶ pending jobs must not be read whole for each claim.
    const PAGE: i64 = 16;
    let mut after = i64::MIN;
    let (campaign, latest_only) = scope.sql();
    let query = claim_page();
    loop {
        let page: Vec<JobRow> = tx
            .prepare_cached(&query)?
            .query_map(
                params![campaign, max_attempts, after, PAGE, latest_only],
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
                        max_attempts: r.get(8)?,
                    })
                },
            )?
            .collect::<Result<_, _>>()?;
        let Some(last) = page.last() else {
            break;
        };
        after = last.id;
        for mut j in page {
            let Some(held) = hold(&j)? else {
                continue;
            };
            tx.execute(
                "UPDATE jobs SET status = 'running', lease_owner = ?2, heartbeat_at = ?3, attempts = attempts + 1,
                        stage = 'claimed'
                 WHERE id = ?1 AND status = 'pending'",
                params![j.id, lease.owner, now()],
            )?;
            tx.commit()?;
            j.attempts += 1;
            j.status = "running".into();
            return Ok(Some((j, held)));
        }
    }
    tx.commit()?;
    Ok(None)
}

/// Renews the heartbeat of a job held by `owner` (the heartbeat thread of a held job).
///
/// # Errors
/// Database errors.
pub fn beat(conn: &Connection, id: i64, owner: &str) -> anyhow::Result<()> {
    conn.execute(
        "UPDATE jobs SET heartbeat_at = ?3 WHERE id = ?1 AND lease_owner = ?2",
        params![id, owner, now()],
    )?;
    Ok(())
}

/// Records what a held job is doing ('fill', 'discharge', 'flow', 'measure'): the cause named
/// when its process dies.
///
/// # Errors
/// Database errors.
pub fn set_stage(conn: &Connection, id: i64, lease: &Lease, stage: &str) -> anyhow::Result<()> {
    conn.execute(
        "UPDATE jobs SET stage = ?3 WHERE id = ?1 AND lease_owner = ?2",
        params![id, lease.owner, stage],
    )?;
    Ok(())
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
    cpu_time: Option<f64>,
    checkpoint: Option<&str>,
) -> anyhow::Result<()> {
    conn.execute(
        "UPDATE jobs SET heartbeat_at = ?3, sim_time_s = ?4, progress = ?5, particle_steps = ?6, wall_time_s = ?7,
                cpu_time_s = ?8, checkpoint_path = COALESCE(?9, checkpoint_path)
         WHERE id = ?1 AND lease_owner = ?2",
        params![id, lease.owner, now(), sim_time, progress, particle_steps as i64, wall_time, cpu_time, checkpoint],
    )
    .context("heartbeat")?;
    Ok(())
}

/// Records the CPU time a job's threads have run (None: part of the job ran before sweep counted
/// it, and the column stays NULL).
///
/// # Errors
/// Database errors.
pub fn set_cpu_time(
    conn: &Connection,
    id: i64,
    lease: &Lease,
    cpu_time_s: Option<f64>,
) -> anyhow::Result<()> {
    conn.execute(
        "UPDATE jobs SET cpu_time_s = ?3 WHERE id = ?1 AND lease_owner = ?2",
        params![id, lease.owner, cpu_time_s],
    )
    .context("CPU time")?;
    Ok(())
}

/// Records the backend a job runs on (and its engine threads), with what was said about the choice (`backend_note`: why
/// `--backend auto` took the CPU, a software adapter allowed). (`particles` stays the job's own
/// count, set at registration, whatever the checkpoint it resumes from holds.)
///
/// # Errors
/// Database errors.
pub fn set_backend(
    conn: &Connection,
    id: i64,
    backend: &str,
    adapter: &str,
    precision: &str,
    note: Option<&str>,
    threads: usize,
) -> anyhow::Result<()> {
    conn.execute("UPDATE jobs SET backend = ?2, adapter = ?3, precision = ?4, program_version = ?5, backend_note = ?6, threads = ?7 WHERE id = ?1", params![id, backend, adapter, precision, env!("CARGO_PKG_VERSION"), note, threads as i64])?;
    Ok(())
}

/// Ends a held job as paused (interrupted at a checkpoint: the attempt is given back, it did
/// not fail), pending (a lent job handed back: likewise, unless it failed, `error`), or failed
/// (with its error kept), releasing the lease.
///
/// # Errors
/// Database errors.
pub fn release(
    conn: &Connection,
    id: i64,
    lease: &Lease,
    status: &str,
    error: Option<&str>,
) -> anyhow::Result<()> {
    // A pause (or a lent job handed back as pending) ends an attempt cleanly; a failure (a
    // lent job's too, handed back as pending with its error) spends it.
    let give_back = i64::from(error.is_none() && (status == "paused" || status == "pending"));
    conn.execute(
        "UPDATE jobs SET status = ?3, last_error = COALESCE(?4, last_error), lease_owner = NULL,
                attempts = MAX(attempts - ?5, 0)
         WHERE id = ?1 AND lease_owner = ?2",
        params![id, lease.owner, status, error, give_back],
    )?;
    Ok(())
}

/// A job a Slurm task runs, written into the task's own in-memory store as claimed by it.
#[derive(Clone, Debug)]
pub struct TaskJob<'a> {
    pub id: i64,
    pub hash: &'a str,
    pub scene: &'a str,
    pub params_json: &'a str,
    pub seed: i64,
    pub sim_time_s: f64,
    pub target_time_s: f64,
    pub lease: &'a Lease,
}

/// Inserts `job` running (one attempt, heartbeat now) under its lease.
///
/// # Errors
/// Database errors.
pub fn insert_running(conn: &Connection, job: &TaskJob) -> anyhow::Result<()> {
    conn.execute(
        "INSERT INTO jobs (id, hash, scene, params_json, seed, status, attempts, sim_time_s, target_time_s, lease_owner, heartbeat_at)
         VALUES (?1, ?2, ?3, ?4, ?5, 'running', 1, ?6, ?7, ?8, ?9)",
        params![
            job.id,
            job.hash,
            job.scene,
            job.params_json,
            job.seed,
            job.sim_time_s,
            job.target_time_s,
            job.lease.owner,
            now()
        ],
    )?;
    Ok(())
}

pub use super::lookup::*;
pub use super::register::*;
pub use super::requeue::*;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::store::scope::latest_campaign_ids;
    use crate::store::test_rows;

    /// A claim's cost must not grow with the jobs registered: SQLite's plan for a page of
    /// candidates reads the pending jobs through their index and each label through the index
    /// on `campaign_jobs(job_id)`, never a whole table (a scan per pending job made a launch of
    /// N jobs cost N²).
    #[test]
    fn a_claim_reads_no_whole_table() {
        let conn = crate::store::open_in_memory(None).unwrap();
        // The plan is the same whatever the parameters; the latest-version condition included.
        let plan: Vec<String> = conn
            .prepare(&format!("EXPLAIN QUERY PLAN {}", claim_page()))
            .unwrap()
            .query_map(params![1, 3, 0, 16, true], |r| r.get::<_, String>(3))
            .unwrap()
            .collect::<Result<_, _>>()
            .unwrap();
        let text = plan.join("\n");
        assert!(
            plan.iter().all(|step| !step.starts_with("SCAN")),
            "a step scans a whole table:\n{text}"
        );
        assert!(text.contains("jobs_status"), "{text}");
        assert!(text.contains("campaign_jobs_job"), "{text}");
    }

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
