//! Reading jobs and campaigns as `sweep status`, the executors and the exporters show them:
//! campaign versions, a campaign's jobs with their progress and lease, single fields of a job.

use rusqlite::{params, Connection, OptionalExtension};

use super::now;
use super::requeue::OpenJob;

/// A campaign version as `sweep status` lists it.
#[derive(Clone, Debug)]
pub struct CampaignRow {
    pub id: i64,
    pub name: String,
    pub version: i64,
    pub file: String,
}

/// Campaigns (every version), all or those named `name`, oldest first.
///
/// # Errors
/// Database errors.
pub fn campaigns(conn: &Connection, name: Option<&str>) -> anyhow::Result<Vec<CampaignRow>> {
    let mut q = conn.prepare(
        "SELECT id, name, version, file FROM campaigns WHERE ?1 IS NULL OR name = ?1 ORDER BY name, version",
    )?;
    let rows = q
        .query_map([name], |r| {
            Ok(CampaignRow {
                id: r.get(0)?,
                name: r.get(1)?,
                version: r.get(2)?,
                file: r.get(3)?,
            })
        })?
        .collect::<Result<_, _>>()?;
    Ok(rows)
}

/// The id of the campaign named `name` (its first version found), or `None`.
///
/// # Errors
/// Database errors.
pub fn campaign_id(conn: &Connection, name: &str) -> anyhow::Result<Option<i64>> {
    Ok(conn
        .query_row("SELECT id FROM campaigns WHERE name = ?1", [name], |r| {
            r.get(0)
        })
        .optional()?)
}

/// A job's parameter hash (which names its work directory), or `None` when there is no such
/// job.
///
/// # Errors
/// Database errors.
pub fn job_hash(conn: &Connection, id: i64) -> anyhow::Result<Option<String>> {
    Ok(conn
        .query_row("SELECT hash FROM jobs WHERE id = ?1", [id], |r| r.get(0))
        .optional()?)
}

/// Where a job with these parameters already stands in a store, as `sweep plan` shows it.
#[derive(Clone, Debug, PartialEq)]
pub struct StoredJob {
    pub id: i64,
    pub status: String,
    pub sim_time_s: f64,
    pub target_time_s: f64,
    pub particle_steps: i64,
}

/// The job whose parameters hash to `hash`, or `None` when the store has none: a campaign's
/// job with the same parameters as another's is the same job (shared, run once).
///
/// # Errors
/// Database errors.
pub fn job_by_hash(conn: &Connection, hash: &str) -> anyhow::Result<Option<StoredJob>> {
    Ok(conn
        .query_row(
            "SELECT id, status, sim_time_s, target_time_s, particle_steps FROM jobs WHERE hash = ?1",
            [hash],
            |r| {
                Ok(StoredJob {
                    id: r.get(0)?,
                    status: r.get(1)?,
                    sim_time_s: r.get(2)?,
                    target_time_s: r.get(3)?,
                    particle_steps: r.get(4)?,
                })
            },
        )
        .optional()?)
}

/// A job's label (from its first campaign link, else its parameter hash), or `None` when there
/// is no such job.
///
/// # Errors
/// Database errors.
pub fn job_label(conn: &Connection, id: i64) -> anyhow::Result<Option<String>> {
    Ok(conn
        .query_row(
            "SELECT COALESCE((SELECT label FROM campaign_jobs WHERE job_id = jobs.id LIMIT 1), hash) FROM jobs WHERE id = ?1",
            [id],
            |r| r.get(0),
        )
        .optional()?)
}

/// The campaign file (JSON) of the first campaign job `job_id` belongs to, or `None`.
///
/// # Errors
/// Database errors.
pub fn first_campaign_spec(conn: &Connection, job_id: i64) -> anyhow::Result<Option<String>> {
    Ok(conn
        .query_row("SELECT c.spec_json FROM campaigns c JOIN campaign_jobs cj ON cj.campaign_id = c.id WHERE cj.job_id = ?1 ORDER BY c.id LIMIT 1", [job_id], |r| r.get(0))
        .optional()?)
}

/// A job's state as the Slurm collector checks it.
#[derive(Clone, Debug)]
pub struct JobState {
    pub status: String,
    pub hash: String,
    pub lease_owner: Option<String>,
}

/// The state of job `id`.
///
/// # Errors
/// Database errors, among them no such job.
pub fn job_state(conn: &Connection, id: i64) -> anyhow::Result<JobState> {
    let mut q = conn.prepare_cached("SELECT status, hash, lease_owner FROM jobs WHERE id = ?1")?;
    Ok(q.query_row([id], |r| {
        Ok(JobState {
            status: r.get(0)?,
            hash: r.get(1)?,
            lease_owner: r.get(2)?,
        })
    })?)
}

/// One job of a campaign, as `sweep status` shows it.
#[derive(Clone, Debug, Default)]
pub struct JobStatus {
    pub id: i64,
    pub hash: String,
    pub status: String,
    pub progress: f64,
    pub sim_time_s: f64,
    pub target_time_s: f64,
    pub particle_steps: i64,
    pub wall_time_s: f64,
    pub attempts: i64,
    pub max_attempts: i64,
    pub last_error: Option<String>,
    pub label: String,
    pub backend: Option<String>,
    pub precision: Option<String>,
    pub lease_owner: Option<String>,
    pub heartbeat_age_s: Option<f64>,
    pub stage: Option<String>,
    /// What was said about its backend (why `--backend auto` took the CPU, …).
    pub backend_note: Option<String>,
}

impl JobStatus {
    /// The fields `requeue`'s liveness test reads.
    pub fn as_open(&self) -> OpenJob {
        OpenJob {
            id: self.id,
            hash: self.hash.clone(),
            label: self.label.clone(),
            status: self.status.clone(),
            attempts: self.attempts,
            max_attempts: self.max_attempts,
            lease_owner: self.lease_owner.clone(),
            heartbeat_age_s: self.heartbeat_age_s,
            stage: self.stage.clone(),
            last_error: self.last_error.clone(),
        }
    }
}

/// The jobs of campaign (version) `campaign_id`, by id.
///
/// # Errors
/// Database errors.
pub fn campaign_jobs(conn: &Connection, campaign_id: i64) -> anyhow::Result<Vec<JobStatus>> {
    campaign_jobs_in(conn, campaign_id, None, i64::MAX)
}

/// At most `limit` jobs of campaign (version) `campaign_id` by id, only those in one of
/// `statuses` when given.
///
/// # Errors
/// Database errors.
pub fn campaign_jobs_in(
    conn: &Connection,
    campaign_id: i64,
    statuses: Option<&[&str]>,
    limit: i64,
) -> anyhow::Result<Vec<JobStatus>> {
    // With statuses, the few jobs in them are found through the status index first (a
    // CROSS JOIN keeps that order): a campaign of 10⁶ pending jobs is not read to find its
    // running ones.
    let (from, wanted) = match statuses {
        Some(s) => (
            "FROM jobs j CROSS JOIN campaign_jobs cj ON cj.job_id = j.id
             WHERE cj.campaign_id = ?1 AND j.status IN (SELECT value FROM json_each(?3))",
            Some(serde_json::to_string(s)?),
        ),
        None => (
            "FROM jobs j JOIN campaign_jobs cj ON cj.job_id = j.id
             WHERE cj.campaign_id = ?1 AND ?3 IS NULL",
            None,
        ),
    };
    let mut q = conn.prepare(&format!(
        "SELECT j.id, j.hash, j.status, j.progress, j.sim_time_s, j.target_time_s, j.particle_steps, j.wall_time_s,
                j.attempts, j.max_attempts, j.last_error, cj.label, j.backend, j.precision, j.lease_owner,
                ?2 - j.heartbeat_at, j.stage, j.backend_note
         {from}
         ORDER BY j.id LIMIT ?4"
    ))?;
    let rows = q
        .query_map(params![campaign_id, now(), wanted, limit], |r| {
            Ok(JobStatus {
                id: r.get(0)?,
                hash: r.get(1)?,
                status: r.get(2)?,
                progress: r.get(3)?,
                sim_time_s: r.get(4)?,
                target_time_s: r.get(5)?,
                particle_steps: r.get(6)?,
                wall_time_s: r.get(7)?,
                attempts: r.get(8)?,
                max_attempts: r.get(9)?,
                last_error: r.get(10)?,
                label: r.get(11)?,
                backend: r.get(12)?,
                precision: r.get(13)?,
                lease_owner: r.get(14)?,
                heartbeat_age_s: r.get(15)?,
                stage: r.get(16)?,
                backend_note: r.get(17)?,
            })
        })?
        .collect::<Result<_, _>>()?;
    Ok(rows)
}

/// The jobs of a campaign in one state, summed.
#[derive(Clone, Debug, Default)]
pub struct StateTotal {
    pub status: String,
    pub jobs: i64,
    pub sim_time_s: f64,
    pub target_time_s: f64,
    pub particle_steps: f64,
    pub wall_time_s: f64,
}

/// A campaign's jobs summed by state (one pass over its links, whatever its size).
///
/// # Errors
/// Database errors.
pub fn state_totals(conn: &Connection, campaign_id: i64) -> anyhow::Result<Vec<StateTotal>> {
    let mut q = conn.prepare(
        "SELECT j.status, COUNT(*), SUM(j.sim_time_s), SUM(j.target_time_s),
                SUM(CAST(j.particle_steps AS REAL)), SUM(j.wall_time_s)
         FROM campaign_jobs cj JOIN jobs j ON j.id = cj.job_id
         WHERE cj.campaign_id = ?1 GROUP BY j.status",
    )?;
    let rows = q
        .query_map([campaign_id], |r| {
            Ok(StateTotal {
                status: r.get(0)?,
                jobs: r.get(1)?,
                sim_time_s: r.get(2)?,
                target_time_s: r.get(3)?,
                particle_steps: r.get(4)?,
                wall_time_s: r.get(5)?,
            })
        })?
        .collect::<Result<_, _>>()?;
    Ok(rows)
}
