//! What the accuracy–cost map (`report::accuracy`) reads of a campaign's done jobs: cost,
//! numerical record and kinetic energy, whatever the scene.

use anyhow::Result;
use rusqlite::{params, Connection};

/// One done job of an accuracy campaign.
#[derive(Debug, Clone)]
pub struct AccuracyRow {
    /// jobs.id
    pub job_id: i64,
    /// campaign_jobs.label
    pub label: String,
    /// jobs.params_json
    pub params_json: String,
    pub wall_time_s: f64,
    /// CPU seconds of its threads (None where a part of it ran without counting them).
    pub cpu_time_s: Option<f64>,
    pub particle_steps: i64,
    /// Time step (s) and largest overlap / radius, from job_numerics (None without a row).
    pub dt_s: Option<f64>,
    pub max_overlap_ratio: Option<f64>,
    /// The engine that ran it ("cpu" or "gpu"; "" when not recorded).
    pub backend: String,
    /// Mean kinetic energy over the measurement window (J) and its relative trend (1/s), from
    /// job_energy.
    pub mean_kinetic_j: Option<f64>,
    pub drift_per_s: Option<f64>,
}

/// The campaign's done jobs, by job id.
///
/// # Errors
/// On a database error.
pub fn accuracy_rows(conn: &Connection, campaign_id: i64) -> Result<Vec<AccuracyRow>> {
    let mut st = conn.prepare(
        "SELECT j.id, cj.label, j.params_json, j.wall_time_s, j.particle_steps, n.dt_s, n.max_overlap_ratio,
                COALESCE(j.backend, ''), e.mean_kinetic_j, e.drift_per_s, j.cpu_time_s
         FROM campaign_jobs cj JOIN jobs j ON j.id = cj.job_id LEFT JOIN job_numerics n ON n.job_id = j.id
         LEFT JOIN job_energy e ON e.job_id = j.id
         WHERE cj.campaign_id = ?1 AND j.status = 'done' ORDER BY j.id",
    )?;
    let rows = st
        .query_map(params![campaign_id], |r| {
            Ok(AccuracyRow {
                job_id: r.get(0)?,
                label: r.get(1)?,
                params_json: r.get(2)?,
                wall_time_s: r.get(3)?,
                particle_steps: r.get(4)?,
                dt_s: r.get(5)?,
                max_overlap_ratio: r.get(6)?,
                backend: r.get(7)?,
                mean_kinetic_j: r.get(8)?,
                drift_per_s: r.get(9)?,
                cpu_time_s: r.get(10)?,
            })
        })?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    Ok(rows)
}
