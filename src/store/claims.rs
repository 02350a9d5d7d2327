//! A campaign's claim verdicts, one row per claim and look (`claim_verdicts`), and what its
//! jobs have cost (particle-steps, wall time, core-hours) for the claims' budget.

use anyhow::Result;
use rusqlite::{params, Connection};

/// One claim at one look.
#[derive(Clone, Debug, PartialEq)]
pub struct VerdictRow {
    pub round: u32,
    pub claim_id: String,
    pub statement: String,
    pub paper: String,
    pub paper_value: String,
    pub test: String,
    pub what: String,
    pub verdict: String,
    pub value: Option<f64>,
    pub lo: Option<f64>,
    pub hi: Option<f64>,
    pub level: f64,
    pub bound: String,
    pub points: String,
    pub note: String,
    pub particle_steps: f64,
    pub wall_s: f64,
    pub forecast_particle_steps: Option<f64>,
    pub forecast_wall_s: Option<f64>,
}

fn finite(v: Option<f64>) -> Option<f64> {
    v.filter(|x| x.is_finite())
}

/// Stores the verdicts of look `round` (replacing that look's earlier rows: a look evaluated
/// again after an interruption gives the same rows).
///
/// # Errors
/// Database errors.
pub fn save_verdicts(conn: &Connection, campaign_id: i64, rows: &[VerdictRow]) -> Result<()> {
    let mut q = conn.prepare(
        "INSERT OR REPLACE INTO claim_verdicts (campaign_id, round, claim_id, statement, paper,
            paper_value, test, what, verdict, value, lo, hi, level, bound, points, note,
            particle_steps, wall_s, forecast_particle_steps, forecast_wall_s)
         VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17, ?18, ?19, ?20)",
    )?;
    for r in rows {
        q.execute(params![
            campaign_id,
            r.round,
            r.claim_id,
            r.statement,
            r.paper,
            r.paper_value,
            r.test,
            r.what,
            r.verdict,
            finite(r.value),
            finite(r.lo),
            finite(r.hi),
            r.level,
            r.bound,
            r.points,
            r.note,
            r.particle_steps,
            r.wall_s,
            finite(r.forecast_particle_steps),
            finite(r.forecast_wall_s)
        ])?;
    }
    Ok(())
}

/// The verdicts of the campaign's latest look (every claim), in the file's order of first
/// storage; empty when none was stored.
///
/// # Errors
/// Database errors.
pub fn latest_verdicts(conn: &Connection, campaign_id: i64) -> Result<Vec<VerdictRow>> {
    let mut q = conn.prepare(
        "SELECT round, claim_id, statement, paper, paper_value, test, what, verdict, value, lo, hi,
                level, bound, points, note, particle_steps, wall_s, forecast_particle_steps,
                forecast_wall_s
         FROM claim_verdicts
         WHERE campaign_id = ?1
           AND round = (SELECT MAX(round) FROM claim_verdicts WHERE campaign_id = ?1)
         ORDER BY rowid",
    )?;
    let rows = q
        .query_map([campaign_id], |r| {
            Ok(VerdictRow {
                round: r.get(0)?,
                claim_id: r.get(1)?,
                statement: r.get(2)?,
                paper: r.get(3)?,
                paper_value: r.get(4)?,
                test: r.get(5)?,
                what: r.get(6)?,
                verdict: r.get(7)?,
                value: r.get(8)?,
                lo: r.get(9)?,
                hi: r.get(10)?,
                level: r.get(11)?,
                bound: r.get(12)?,
                points: r.get(13)?,
                note: r.get(14)?,
                particle_steps: r.get(15)?,
                wall_s: r.get(16)?,
                forecast_particle_steps: r.get(17)?,
                forecast_wall_s: r.get(18)?,
            })
        })?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    Ok(rows)
}

/// Every (round, claim, verdict) of the campaign, by round: how its claims were decided.
///
/// # Errors
/// Database errors.
pub fn history(conn: &Connection, campaign_id: i64) -> Result<Vec<(u32, String, String)>> {
    let mut q = conn.prepare(
        "SELECT round, claim_id, verdict FROM claim_verdicts WHERE campaign_id = ?1 ORDER BY round, rowid",
    )?;
    let rows = q
        .query_map([campaign_id], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    Ok(rows)
}

/// What the campaign's jobs have cost: (particle-steps, wall seconds, core-hours = wall time ×
/// each job's engine threads, 1 where unrecorded).
///
/// # Errors
/// Database errors.
pub fn spent(conn: &Connection, campaign_id: i64) -> Result<(f64, f64, f64)> {
    Ok(conn.query_row(
        "SELECT COALESCE(SUM(j.particle_steps), 0), COALESCE(SUM(j.wall_time_s), 0),
                COALESCE(SUM(j.wall_time_s * COALESCE(j.threads, 1)), 0) / 3600.0
         FROM campaign_jobs cj JOIN jobs j ON j.id = cj.job_id WHERE cj.campaign_id = ?1",
        [campaign_id],
        |r| Ok((r.get::<_, f64>(0)?, r.get(1)?, r.get(2)?)),
    )?)
}
