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

/// Registers a campaign and its jobs. Launching the same file twice adds nothing (replicas its
/// target added are the campaign's own, not the file's, and do not count as a change). A file whose
/// jobs or claims differ from the latest version launched under its name is refused (`Changed`, with the
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
                     WHERE cj.campaign_id = ?1 AND cj.origin IS NULL",
                )?
                .query_map([cid], |r| Ok((r.get(0)?, r.get(1)?)))?
                .collect::<Result<_, _>>()?;
            stored.sort();
            let mut wanted: Vec<(String, String)> =
                jobs.iter().map(|j| (j.hash(), j.label.clone())).collect();
            wanted.sort();
            // Claims are part of the file's version: a claim edited after its data were seen is
            // another study, kept apart (its jobs are shared: they are not part of identity).
            let claims_of = |s: &str| {
                serde_json::from_str::<serde_json::Value>(s)
                    .ok()
                    .and_then(|v| v.get("claims").cloned())
            };
            let claims_changed = claims_of(&old_spec) != claims_of(&spec);
            if stored == wanted && !claims_changed {
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
pub use super::requeue::*;
