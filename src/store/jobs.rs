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
    /// Claims allowed in all (`run.max_attempts` of its campaign).
    pub max_attempts: i64,
}

/// The owner of a claimed job: `local:HOST:PID:T` (T tells two claims of one process apart).
#[derive(Clone, Debug)]
pub struct Lease {
    pub owner: String,
}

impl Lease {
    pub fn new() -> Self {
        Self {
            owner: format!("local:{}:{}:{}", this_host(), std::process::id(), now()),
        }
    }
}

impl Default for Lease {
    fn default() -> Self {
        Self::new()
    }
}

/// This machine's name, as local leases record it.
pub fn this_host() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|h| h.trim().to_string())
        .unwrap_or_else(|_| "localhost".into())
}

/// Where a lease's owner runs, as far as this machine can tell.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum OwnerPlace {
    /// A process of this machine (`pid`): its OS lock says whether it lives.
    ThisHost { pid: u32 },
    /// A process of another machine sharing the store: judged by its heartbeat.
    OtherHost { host: String, pid: u32 },
    /// A Slurm task: `sweep collect` decides when it ended.
    Slurm,
    /// A lease written by an older sweep (`PID:T`), or none: judged by its heartbeat.
    Unknown,
}

/// Parses a lease owner.
pub fn owner_place(owner: Option<&str>) -> OwnerPlace {
    let Some(o) = owner else {
        return OwnerPlace::Unknown;
    };
    if o.starts_with("slurm:") {
        return OwnerPlace::Slurm;
    }
    let parts: Vec<&str> = o.split(':').collect();
    match parts.as_slice() {
        ["local", host, pid, _] => match pid.parse() {
            Ok(pid) if *host == this_host() => OwnerPlace::ThisHost { pid },
            Ok(pid) => OwnerPlace::OtherHost {
                host: host.to_string(),
                pid,
            },
            Err(_) => OwnerPlace::Unknown,
        },
        _ => OwnerPlace::Unknown,
    }
}

/// How a launch was registered.
#[derive(Debug)]
pub enum Registration {
    /// The campaign's jobs are registered under `version` (a new one, or the latest when the
    /// file still expands to the same jobs); `added` of them are new to the store.
    Registered {
        campaign_id: i64,
        version: i64,
        added: usize,
    },
    /// The file differs from the latest launched version `version` in the jobs it makes:
    /// nothing was registered. `changes` lists the fields that differ ("path: old -> new").
    Changed { version: i64, changes: Vec<String> },
}

/// Registers a campaign and its jobs. Launching the same file twice adds nothing. A file whose
/// jobs differ from the latest version launched under its name is refused (`Changed`, with the
/// fields that differ) unless `new_version`, which registers it as the next version with its
/// own jobs; jobs are shared between versions only where their resolved parameters are equal.
///
/// # Errors
/// Database errors.
pub fn register(
    conn: &mut Connection,
    file: &str,
    c: &CampaignFile,
    jobs: &[JobSpec],
    new_version: bool,
) -> anyhow::Result<Registration> {
    let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
    let spec = serde_json::to_string(c)?;
    let latest: Option<(i64, i64, String)> = tx
        .query_row(
            "SELECT id, version, spec_json FROM campaigns WHERE name = ?1 ORDER BY version DESC LIMIT 1",
            [&c.name],
            |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)),
        )
        .optional()?;
    let (cid, version) = match latest {
        Some((cid, version, old_spec)) => {
            let mut stored: Vec<(String, String)> = tx
                .prepare(
                    "SELECT j.hash, cj.label FROM campaign_jobs cj JOIN jobs j ON j.id = cj.job_id
                     WHERE cj.campaign_id = ?1",
                )?
                .query_map([cid], |r| Ok((r.get(0)?, r.get(1)?)))?
                .collect::<Result<_, _>>()?;
            stored.sort();
            let mut wanted: Vec<(String, String)> =
                jobs.iter().map(|j| (j.hash(), j.label.clone())).collect();
            wanted.sort();
            if stored == wanted {
                // Same jobs: settings that change no result (checkpoint interval, executor,
                // description) follow the file.
                tx.execute(
                    "UPDATE campaigns SET file = ?2, spec_json = ?3 WHERE id = ?1",
                    params![cid, file, spec],
                )?;
                (cid, version)
            } else if new_version {
                tx.execute(
                    "INSERT INTO campaigns (name, version, file, scene, spec_json) VALUES (?1, ?2, ?3, ?4, ?5)",
                    params![c.name, version + 1, file, c.scene.name(), spec],
                )?;
                (tx.last_insert_rowid(), version + 1)
            } else {
                let old: serde_json::Value = serde_json::from_str(&old_spec)?;
                let new: serde_json::Value = serde_json::from_str(&spec)?;
                let mut changes = crate::campaign::diff_fields(&old, &new);
                if changes.is_empty() {
                    changes.push(format!(
                        "(no field differs, but the jobs do: {} stored, {} in the file; this sweep resolves parameters differently from the one that launched it)",
                        stored.len(),
                        wanted.len()
                    ));
                }
                return Ok(Registration::Changed { version, changes });
            }
        }
        None => {
            tx.execute(
                "INSERT INTO campaigns (name, version, file, scene, spec_json) VALUES (?1, 1, ?2, ?3, ?4)",
                params![c.name, file, c.scene.name(), spec],
            )?;
            (tx.last_insert_rowid(), 1)
        }
    };
    let mut added = 0;
    for j in jobs {
        let target = j.target_time_s();
        let n = tx.execute(
            "INSERT OR IGNORE INTO jobs (hash, scene, params_json, seed, target_time_s, particles, precision, program_version, max_attempts)
             VALUES (?1, ?8, ?2, ?3, ?4, ?5, ?6, ?7, ?9)",
            params![j.hash(), j.resolved_json(), j.seed() as i64, target, j.particle_count() as i64, j.precision.name(), env!("CARGO_PKG_VERSION"), j.scene.name(), c.run.max_attempts],
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
    Ok(Registration::Registered {
        campaign_id: cid,
        version,
        added,
    })
}

/// Claims the next pending job (of `campaign` if given) for `lease`, in one transaction, so two
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
    campaign: Option<i64>,
    lease: &Lease,
    max_attempts: Option<i64>,
    mut hold: impl FnMut(&JobRow) -> anyhow::Result<Option<T>>,
) -> anyhow::Result<Option<(JobRow, T)>> {
    let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
    let candidates: Vec<JobRow> = tx
        .prepare(
            "SELECT j.id, j.hash, j.params_json, j.status, j.attempts, j.sim_time_s, j.target_time_s,
                    COALESCE((SELECT label FROM campaign_jobs cj WHERE cj.job_id = j.id LIMIT 1), ''),
                    j.max_attempts
             FROM jobs j
             WHERE j.status = 'pending' AND j.attempts < COALESCE(?2, j.max_attempts)
               AND (?1 IS NULL OR j.id IN (SELECT job_id FROM campaign_jobs WHERE campaign_id = ?1))
             ORDER BY j.id",
        )?
        .query_map(params![campaign, max_attempts], |r| {
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
        })?
        .collect::<Result<_, _>>()?;
    for mut j in candidates {
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

/// Records the backend a job runs on. (`particles` stays the job's own count, set at
/// registration, whatever the checkpoint it resumes from holds.)
///
/// # Errors
/// Database errors.
pub fn set_backend(
    conn: &Connection,
    id: i64,
    backend: &str,
    adapter: &str,
    precision: &str,
) -> anyhow::Result<()> {
    conn.execute("UPDATE jobs SET backend = ?2, adapter = ?3, precision = ?4, program_version = ?5 WHERE id = ?1", params![id, backend, adapter, precision, env!("CARGO_PKG_VERSION")])?;
    Ok(())
}

/// Ends a held job as paused (interrupted at a checkpoint: the attempt is given back, it did
/// not fail) or failed (with its error kept), releasing the lease.
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
    let give_back = i64::from(status == "paused");
    conn.execute(
        "UPDATE jobs SET status = ?3, last_error = COALESCE(?4, last_error), lease_owner = NULL,
                attempts = MAX(attempts - ?5, 0)
         WHERE id = ?1 AND lease_owner = ?2",
        params![id, lease.owner, status, error, give_back],
    )?;
    Ok(())
}

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

/// Every job not done, with its lease and heartbeat age.
///
/// # Errors
/// Database errors.
pub fn open_jobs(conn: &Connection, campaign: Option<i64>) -> anyhow::Result<Vec<OpenJob>> {
    let t = now();
    let mut q = conn.prepare(
        "SELECT j.id, j.hash, COALESCE((SELECT label FROM campaign_jobs cj WHERE cj.job_id = j.id LIMIT 1), ''),
                j.status, j.attempts, j.max_attempts, j.lease_owner, ?1 - j.heartbeat_at, j.stage, j.last_error
         FROM jobs j
         WHERE j.status != 'done' AND (?2 IS NULL OR j.id IN (SELECT job_id FROM campaign_jobs WHERE campaign_id = ?2))
         ORDER BY j.id",
    )?;
    let rows = q
        .query_map(params![t, campaign], |r| {
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
/// Returns a decision for every job not done.
///
/// # Errors
/// Database errors.
pub fn requeue(
    conn: &mut Connection,
    max_attempts: Option<i64>,
    mut liveness: impl FnMut(&OpenJob) -> Liveness,
) -> anyhow::Result<Vec<Decision>> {
    let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
    let mut out = Vec::new();
    for job in open_jobs(&tx, None)? {
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

/// One job of a campaign, as `sweep status` shows it.
#[derive(Clone, Debug)]
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
    let mut q = conn.prepare(
        "SELECT j.id, j.hash, j.status, j.progress, j.sim_time_s, j.target_time_s, j.particle_steps, j.wall_time_s,
                j.attempts, j.max_attempts, j.last_error, cj.label, j.backend, j.precision, j.lease_owner,
                ?2 - j.heartbeat_at, j.stage
         FROM jobs j JOIN campaign_jobs cj ON cj.job_id = j.id WHERE cj.campaign_id = ?1 ORDER BY j.id",
    )?;
    let rows = q
        .query_map(params![campaign_id, now()], |r| {
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
            })
        })?
        .collect::<Result<_, _>>()?;
    Ok(rows)
}
