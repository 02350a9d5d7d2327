//! Reading silo results back for the figures (`pooled::silo`, `report::silo::fields`): the
//! discharge summaries of a campaign's done jobs, a job's M(t) and its clogs.

use anyhow::Result;
use rusqlite::{params, Connection};

use super::targets::RUNNING_ON_OR_DONE;

/// One ended job's discharge summary, joined with its campaign label.
#[derive(Debug, Clone)]
pub struct DischargeRow {
    /// jobs.id
    pub job_id: i64,
    /// campaign_jobs.label
    pub label: String,
    /// Orifice diameter D, m.
    pub orifice_diameter_m: f64,
    /// Bottom rotation frequency f, Hz.
    pub rotation_frequency_hz: f64,
    /// Particle diameter d, m.
    pub particle_diameter_m: f64,
    /// Bulk density ρ_b, kg/m³.
    pub bulk_density_kg_per_m3: f64,
    /// Mean flow rate Q over flowing intervals, kg/s; None when there was none long enough.
    pub q_kg_per_s: Option<f64>,
    /// Half-width of the 95 % confidence interval of Q, kg/s.
    pub q_ci95_kg_per_s: Option<f64>,
    /// jobs.params_json, for parameters the summary does not repeat (gravity).
    pub params_json: String,
    /// Whether the job stopped on a permanent clog.
    pub permanently_clogged: bool,
    /// Blocks Q is the mean of (schema 8; older rows: parsed from q_method's `n=`).
    pub q_blocks: Option<usize>,
    /// The job's simulated discharge time and cost (`jobs`; while a round runs it on, its
    /// progress so far, not the earlier end's).
    pub sim_time_s: f64,
    pub particle_steps: i64,
    /// How Q was obtained (`discharge_summary.q_method`).
    pub q_method: String,
    /// Set while a round runs the job on (`jobs.extended_to_s`, the discharge time it runs to,
    /// s): the row is then the job's earlier end, which stays stored until it ends again.
    pub running_on_to_s: Option<f64>,
}

impl DischargeRow {
    /// The end of Q's window (s since opening, `t_end=` of q_method): earlier than the run's
    /// end when the block rates drifted there (M(t) no longer linear).
    pub fn q_window_end_s(&self) -> Option<f64> {
        let rest = self.q_method.split(",t_end=").nth(1)?;
        rest.split(',').next()?.parse().ok()
    }

    /// Q as one replica's estimate (its blocks' standard error), for pooling replicas.
    pub fn q_estimate(&self) -> Option<crate::observe::fits::ReplicaEstimate> {
        crate::observe::fits::ReplicaEstimate::from_blocks(
            self.q_kg_per_s?,
            self.q_ci95_kg_per_s?,
            self.q_blocks?,
        )
    }
}

/// `n=K` at the end of a q_method code: the block count of rows written before schema 8.
fn blocks_in_method(method: &str) -> Option<usize> {
    method
        .rsplit(",n=")
        .next()
        .filter(|_| method.contains(",n="))?
        .parse()
        .ok()
}

/// The summaries of the campaign's jobs whose status is 'done', ordered by D, f, job id.
///
/// Jobs not done are left out, so that a claim is evaluated on ended jobs only and `missing`
/// names the rest (a summary is written only when a job ends).
///
/// # Errors
/// On a database error.
pub fn done_discharge_rows(conn: &Connection, campaign_id: i64) -> Result<Vec<DischargeRow>> {
    discharge_rows(conn, campaign_id, "j.status = 'done'")
}

/// [`done_discharge_rows`] and, for each job a round is running on, its earlier end, marked by
/// [`DischargeRow::running_on_to_s`]: what a figure draws, so that extending a job does not
/// take its point off the figure until it ends again.
///
/// # Errors
/// On a database error.
pub fn drawable_discharge_rows(conn: &Connection, campaign_id: i64) -> Result<Vec<DischargeRow>> {
    discharge_rows(conn, campaign_id, RUNNING_ON_OR_DONE)
}

/// The discharge summaries of the campaign's jobs that satisfy `filter` (SQL over `j`, a
/// constant string), ordered by D, f, job id.
fn discharge_rows(conn: &Connection, campaign_id: i64, filter: &str) -> Result<Vec<DischargeRow>> {
    let mut stmt = conn.prepare(&format!(
        "SELECT j.id, cj.label, s.orifice_diameter_m, s.rotation_frequency_hz, \
                s.particle_diameter_m, s.bulk_density_kg_per_m3, s.q_kg_per_s, \
                s.q_ci95_kg_per_s, j.params_json, s.permanently_clogged, s.q_blocks, s.q_method, \
                j.sim_time_s, j.particle_steps, \
                CASE WHEN j.status = 'done' THEN NULL ELSE j.extended_to_s END \
         FROM campaign_jobs cj \
         JOIN jobs j ON j.id = cj.job_id \
         JOIN discharge_summary s ON s.job_id = j.id \
         WHERE cj.campaign_id = ?1 AND {filter} \
         ORDER BY s.orifice_diameter_m, s.rotation_frequency_hz, j.id"
    ))?;
    let rows = stmt
        .query_map(params![campaign_id], |r| {
            Ok(DischargeRow {
                job_id: r.get(0)?,
                label: r.get(1)?,
                orifice_diameter_m: r.get(2)?,
                rotation_frequency_hz: r.get(3)?,
                particle_diameter_m: r.get(4)?,
                bulk_density_kg_per_m3: r.get(5)?,
                q_kg_per_s: r.get(6)?,
                q_ci95_kg_per_s: r.get(7)?,
                params_json: r.get(8)?,
                permanently_clogged: r.get::<_, i64>(9)? != 0,
                q_blocks: r
                    .get::<_, Option<i64>>(10)?
                    .map(|n| n as usize)
                    .or_else(|| blocks_in_method(&r.get::<_, String>(11).unwrap_or_default())),
                sim_time_s: r.get(12)?,
                particle_steps: r.get(13)?,
                q_method: r.get(11)?,
                running_on_to_s: r.get(14)?,
            })
        })?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    Ok(rows)
}

/// M(t) of one job as (t_s, mass_kg), in time order.
///
/// # Errors
/// On a database error.
pub fn mass_series(conn: &Connection, job_id: i64) -> Result<Vec<(f64, f64)>> {
    let mut stmt =
        conn.prepare("SELECT t_s, mass_kg FROM discharge_series WHERE job_id = ?1 ORDER BY t_s")?;
    let rows = stmt
        .query_map(params![job_id], |r| Ok((r.get(0)?, r.get(1)?)))?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    Ok(rows)
}

/// One clog of a job (`clogs`): when it began and how long it lasted, s.
#[derive(Debug, Clone, Copy)]
pub struct ClogInterval {
    pub start_s: f64,
    pub duration_s: f64,
}

/// The clogs of one job, in the table's order.
///
/// # Errors
/// On a database error.
pub fn clog_intervals(conn: &Connection, job_id: i64) -> Result<Vec<ClogInterval>> {
    let mut q = conn.prepare("SELECT start_s, duration_s FROM clogs WHERE job_id = ?1")?;
    let clogs = q
        .query_map([job_id], |r| {
            Ok(ClogInterval {
                start_s: r.get(0)?,
                duration_s: r.get(1)?,
            })
        })?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    Ok(clogs)
}

/// A job's flow rate Q and the half-width of its 95 % confidence interval, kg/s
/// (`discharge_summary`; None when there was no flowing interval long enough).
#[derive(Debug, Clone, Copy)]
pub struct FlowRate {
    pub q_kg_per_s: Option<f64>,
    pub q_ci95_kg_per_s: Option<f64>,
}

/// The flow rate of one job.
///
/// # Errors
/// On a database error, among them no summary for the job.
pub fn flow_rate(conn: &Connection, job_id: i64) -> Result<FlowRate> {
    Ok(conn.query_row(
        "SELECT q_kg_per_s, q_ci95_kg_per_s FROM discharge_summary WHERE job_id = ?1",
        [job_id],
        |r| {
            Ok(FlowRate {
                q_kg_per_s: r.get(0)?,
                q_ci95_kg_per_s: r.get(1)?,
            })
        },
    )?)
}
