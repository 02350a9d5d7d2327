//! The one-line account of a finished silo job that the local pool prints.

use rusqlite::Connection;

/// A finished silo job's headline numbers.
#[derive(Clone, Copy, Debug)]
pub struct SiloDone {
    /// Mean discharge rate and its 95 % half-width (kg/s); `None` without a flowing interval
    /// long enough.
    pub q_kg_per_s: Option<f64>,
    pub q_ci95_kg_per_s: Option<f64>,
    pub clogs: i64,
    pub permanently_clogged: bool,
    pub wall_time_s: f64,
    pub particle_steps: i64,
}

/// The headline numbers of finished silo job `job_id`.
///
/// # Errors
/// Database errors, among them no discharge summary for the job.
pub fn silo_done(conn: &Connection, job_id: i64) -> anyhow::Result<SiloDone> {
    Ok(conn.query_row(
        "SELECT s.q_kg_per_s, s.q_ci95_kg_per_s, s.clogs, s.permanently_clogged, j.wall_time_s, j.particle_steps
         FROM discharge_summary s JOIN jobs j ON j.id = s.job_id WHERE s.job_id = ?1",
        [job_id],
        |r| {
            Ok(SiloDone {
                q_kg_per_s: r.get(0)?,
                q_ci95_kg_per_s: r.get(1)?,
                clogs: r.get(2)?,
                permanently_clogged: r.get::<_, i64>(3)? != 0,
                wall_time_s: r.get(4)?,
                particle_steps: r.get(5)?,
            })
        },
    )?)
}
