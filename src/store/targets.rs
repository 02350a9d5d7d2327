//! What a campaign's target reads and writes: its jobs with their costs, the work it added
//! (`target_work`: jobs run on, replicas), and each point's state (`target_points`).

use anyhow::Result;
use rusqlite::{params, Connection, OptionalExtension, Transaction};

use crate::campaign::JobSpec;

/// One job of a campaign, with what it cost.
#[derive(Clone, Debug)]
pub struct TargetJob {
    pub job_id: i64,
    pub label: String,
    pub params_json: String,
    pub status: String,
    /// Simulated time run (s) and the end it runs to (its own, or an extension's).
    pub sim_time_s: f64,
    pub target_time_s: f64,
    pub particle_steps: i64,
    pub wall_time_s: f64,
    /// NULL: from the campaign file; 'target': added by the target.
    pub origin: Option<String>,
}

/// The campaign's jobs, by id.
///
/// # Errors
/// Database errors.
pub fn campaign_jobs(conn: &Connection, campaign_id: i64) -> Result<Vec<TargetJob>> {
    let mut q = conn.prepare(
        "SELECT j.id, cj.label, j.params_json, j.status, j.sim_time_s, j.target_time_s,
                j.particle_steps, j.wall_time_s, cj.origin
         FROM campaign_jobs cj JOIN jobs j ON j.id = cj.job_id
         WHERE cj.campaign_id = ?1 ORDER BY j.id",
    )?;
    let rows = q
        .query_map([campaign_id], |r| {
            Ok(TargetJob {
                job_id: r.get(0)?,
                label: r.get(1)?,
                params_json: r.get(2)?,
                status: r.get(3)?,
                sim_time_s: r.get(4)?,
                target_time_s: r.get(5)?,
                particle_steps: r.get(6)?,
                wall_time_s: r.get(7)?,
                origin: r.get(8)?,
            })
        })?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    Ok(rows)
}

/// Rounds of work the target has added to the campaign so far.
///
/// # Errors
/// Database errors.
pub fn rounds(conn: &Connection, campaign_id: i64) -> Result<u32> {
    let r: Option<i64> = conn.query_row(
        "SELECT MAX(round) FROM target_work WHERE campaign_id = ?1",
        [campaign_id],
        |r| r.get(0),
    )?;
    Ok(r.unwrap_or(0) as u32)
}

/// SQL over `j` (jobs) for what a figure draws: ended jobs, and jobs a round runs on (extended,
/// and pending, running or paused; a failed extension is not drawn as running on).
pub(crate) const RUNNING_ON_OR_DONE: &str = "(j.status = 'done' OR (j.extended_to_s IS NOT NULL \
     AND j.status IN ('pending', 'running', 'paused')))";

/// Sets done job `job_id` to run on (from its checkpoint) until its own time (the silo's
/// discharge, the chute's measurement) is `to_s`, i.e. its simulated end is `end_s` (the
/// chute's adds its longest wait for the steady state): pending again, with fresh attempts.
/// False when the job is not done (nothing changed).
///
/// # Errors
/// Database errors.
pub fn extend(tx: &Transaction, job_id: i64, to_s: f64, end_s: f64) -> Result<bool> {
    let n = tx.execute(
        "UPDATE jobs SET status = 'pending', target_time_s = ?3, extended_to_s = ?2, attempts = 0,
                progress = MIN(1.0, sim_time_s / ?3), lease_owner = NULL, last_error = NULL
         WHERE id = ?1 AND status = 'done'",
        params![job_id, to_s, end_s],
    )?;
    Ok(n == 1)
}

/// Registers `spec` as a job of the campaign added by its target, to run to `target_time_s`;
/// returns its id (an equal job already stored is linked, not duplicated).
///
/// # Errors
/// Database errors.
pub fn add_replica(
    tx: &Transaction,
    campaign_id: i64,
    spec: &JobSpec,
    target_time_s: f64,
    max_attempts: i64,
) -> Result<i64> {
    tx.execute(
        "INSERT OR IGNORE INTO jobs (hash, scene, params_json, seed, target_time_s, particles, precision, program_version, max_attempts)
         VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)",
        params![
            spec.hash(),
            spec.scene.name(),
            spec.resolved_json(),
            spec.seed() as i64,
            target_time_s,
            spec.particle_count() as i64,
            spec.precision.name(),
            env!("CARGO_PKG_VERSION"),
            max_attempts
        ],
    )?;
    let id: i64 = tx.query_row("SELECT id FROM jobs WHERE hash = ?1", [spec.hash()], |r| {
        r.get(0)
    })?;
    tx.execute(
        "INSERT OR IGNORE INTO campaign_jobs (campaign_id, job_id, label, origin) VALUES (?1, ?2, ?3, 'target')",
        params![campaign_id, id, spec.label],
    )?;
    Ok(id)
}

/// One piece of work the target added.
#[derive(Clone, Debug, PartialEq)]
pub struct WorkRow {
    pub round: u32,
    pub point: String,
    pub job_id: i64,
    /// 'extend' or 'replica'.
    pub action: String,
    pub from_s: f64,
    pub to_s: f64,
    pub ci95_rel_before: Option<f64>,
    pub ci95_rel_expected: Option<f64>,
    pub particle_steps_expected: f64,
}

/// Records `w` for the campaign.
///
/// # Errors
/// Database errors.
pub fn record_work(tx: &Transaction, campaign_id: i64, w: &WorkRow) -> Result<()> {
    tx.execute(
        "INSERT INTO target_work (campaign_id, round, point, job_id, action, from_s, to_s,
            ci95_rel_before, ci95_rel_expected, particle_steps_expected)
         VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10)",
        params![
            campaign_id,
            w.round,
            w.point,
            w.job_id,
            w.action,
            w.from_s,
            w.to_s,
            w.ci95_rel_before,
            w.ci95_rel_expected,
            w.particle_steps_expected
        ],
    )?;
    Ok(())
}

/// The work the target added to a campaign, in order.
///
/// # Errors
/// Database errors.
pub fn work(conn: &Connection, campaign_id: i64) -> Result<Vec<WorkRow>> {
    let mut q = conn.prepare(
        "SELECT round, point, job_id, action, from_s, to_s, ci95_rel_before, ci95_rel_expected,
                particle_steps_expected
         FROM target_work WHERE campaign_id = ?1 ORDER BY id",
    )?;
    let rows = q
        .query_map([campaign_id], |r| {
            Ok(WorkRow {
                round: r.get::<_, i64>(0)? as u32,
                point: r.get(1)?,
                job_id: r.get(2)?,
                action: r.get(3)?,
                from_s: r.get(4)?,
                to_s: r.get(5)?,
                ci95_rel_before: r.get(6)?,
                ci95_rel_expected: r.get(7)?,
                particle_steps_expected: r.get(8)?,
            })
        })?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    Ok(rows)
}

/// A point's state after the latest evaluation.
#[derive(Clone, Debug, PartialEq)]
pub struct PointRow {
    pub point: String,
    pub observable: String,
    pub mean: Option<f64>,
    pub ci95_rel: Option<f64>,
    pub ci_from: Option<String>,
    pub replicas: usize,
    pub runs: usize,
    pub measured_s: f64,
    pub particle_steps: i64,
    pub met: bool,
    pub status: String,
    pub rounds: u32,
}

/// Replaces the campaign's point states with `rows`.
///
/// # Errors
/// Database errors.
pub fn save_points(tx: &Transaction, campaign_id: i64, rows: &[PointRow]) -> Result<()> {
    tx.execute(
        "DELETE FROM target_points WHERE campaign_id = ?1",
        [campaign_id],
    )?;
    let mut ins = tx.prepare(
        "INSERT INTO target_points (campaign_id, point, observable, mean, ci95_rel, ci_from,
            replicas, runs, measured_s, particle_steps, met, status, rounds)
         VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13)",
    )?;
    for p in rows {
        ins.execute(params![
            campaign_id,
            p.point,
            p.observable,
            p.mean,
            p.ci95_rel,
            p.ci_from,
            p.replicas as i64,
            p.runs as i64,
            p.measured_s,
            p.particle_steps,
            p.met as i64,
            p.status,
            p.rounds
        ])?;
    }
    Ok(())
}

/// The campaign's point states (empty for a campaign without a target, or not yet evaluated).
///
/// # Errors
/// Database errors.
pub fn points(conn: &Connection, campaign_id: i64) -> Result<Vec<PointRow>> {
    let mut q = conn.prepare(
        "SELECT point, observable, mean, ci95_rel, ci_from, replicas, runs, measured_s,
                particle_steps, met, status, rounds
         FROM target_points WHERE campaign_id = ?1 ORDER BY point",
    )?;
    let rows = q
        .query_map([campaign_id], |r| {
            Ok(PointRow {
                point: r.get(0)?,
                observable: r.get(1)?,
                mean: r.get(2)?,
                ci95_rel: r.get(3)?,
                ci_from: r.get(4)?,
                replicas: r.get::<_, i64>(5)? as usize,
                runs: r.get::<_, i64>(6)? as usize,
                measured_s: r.get(7)?,
                particle_steps: r.get(8)?,
                met: r.get::<_, i64>(9)? != 0,
                status: r.get(10)?,
                rounds: r.get::<_, i64>(11)? as u32,
            })
        })?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    Ok(rows)
}

/// The campaign file a campaign was launched with (None: no such campaign).
///
/// # Errors
/// Database errors, or a stored file that is not a campaign.
pub fn campaign_file(
    conn: &Connection,
    campaign_id: i64,
) -> Result<Option<crate::campaign::CampaignFile>> {
    let spec: Option<String> = conn
        .query_row(
            "SELECT spec_json FROM campaigns WHERE id = ?1",
            [campaign_id],
            |r| r.get(0),
        )
        .optional()?;
    spec.map(|s| Ok(serde_json::from_str(&s)?)).transpose()
}

/// Every campaign whose stored file this sweep can read, with that file, by id.
fn campaign_files(conn: &Connection) -> Result<Vec<(i64, crate::campaign::CampaignFile)>> {
    let mut q = conn.prepare("SELECT id, spec_json FROM campaigns ORDER BY id")?;
    let rows = q
        .query_map([], |r| Ok((r.get::<_, i64>(0)?, r.get::<_, String>(1)?)))?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    Ok(rows
        .into_iter()
        .filter_map(|(id, s)| Some((id, serde_json::from_str(&s).ok()?)))
        .collect())
}

/// The ids of campaigns whose file has a target.
///
/// # Errors
/// Database errors.
pub fn campaigns_with_target(conn: &Connection) -> Result<Vec<i64>> {
    Ok(campaign_files(conn)?
        .into_iter()
        .filter(|(_, f)| f.target.is_some())
        .map(|(id, _)| id)
        .collect())
}

/// Every campaign whose stored file has claims but no target, by id.
///
/// # Errors
/// Database errors.
pub fn campaigns_with_claims_only(conn: &Connection) -> Result<Vec<i64>> {
    Ok(campaign_files(conn)?
        .into_iter()
        .filter(|(_, f)| f.target.is_none() && !f.claims.is_empty())
        .map(|(id, _)| id)
        .collect())
}
