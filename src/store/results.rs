//! Results of a silo job, written in the same transaction that marks the job done.

use rusqlite::{params, Connection, TransactionBehavior};

use crate::observe::discharge::{Discharge, DischargeSummary};

/// What a finished silo job stores.
#[derive(Clone, Debug)]
pub struct SiloResults {
    pub orifice_diameter_m: f64,
    pub rotation_frequency_hz: f64,
    pub particle_diameter_m: f64,
    pub bulk_density_kg_per_m3: f64,
    pub discharge: Discharge,
    pub summary: DischargeSummary,
    pub wall_time_s: f64,
    pub particle_steps: u64,
    pub sim_time_s: f64,
    /// Time step and the running numerical record of the discharge.
    pub dt_s: f64,
    pub numerics: super::JobNumerics,
    /// Coarse-grained fields (when the campaign asked for them).
    pub fields: Option<crate::observe::silo_fields::SiloFieldObserver>,
}

impl SiloResults {
    /// Writes every result row and marks the job done, in one transaction; a job already done
    /// (another process finished it) is left alone and nothing is written twice.
    ///
    /// # Errors
    /// Database errors.
    pub fn commit(&self, conn: &mut Connection, job_id: i64) -> anyhow::Result<bool> {
        let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
        let status: String =
            tx.query_row("SELECT status FROM jobs WHERE id = ?1", [job_id], |r| {
                r.get(0)
            })?;
        if status == "done" {
            return Ok(false);
        }
        tx.execute("DELETE FROM discharge_series WHERE job_id = ?1", [job_id])?;
        tx.execute("DELETE FROM clogs WHERE job_id = ?1", [job_id])?;
        {
            let mut ins = tx.prepare("INSERT INTO discharge_series (job_id, t_s, mass_kg, count) VALUES (?1, ?2, ?3, ?4)")?;
            for &(t, m, c) in &self.discharge.samples {
                ins.execute(params![job_id, t, m, c as i64])?;
            }
            let mut ins = tx.prepare("INSERT OR REPLACE INTO clogs (job_id, start_s, duration_s, permanent) VALUES (?1, ?2, ?3, ?4)")?;
            for c in &self.summary.clogs {
                ins.execute(params![job_id, c.start_s, c.duration_s, c.permanent as i64])?;
            }
        }
        let s = &self.summary;
        tx.execute(
            "INSERT OR REPLACE INTO discharge_summary (job_id, orifice_diameter_m, rotation_frequency_hz, particle_diameter_m, bulk_density_kg_per_m3,
                q_kg_per_s, q_ci95_kg_per_s, q_method, flowing_time_s, discharged_mass_kg, discharged_count, clogs, clogged_time_s, permanently_clogged, q_blocks)
             VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15)",
            params![
                job_id,
                self.orifice_diameter_m,
                self.rotation_frequency_hz,
                self.particle_diameter_m,
                self.bulk_density_kg_per_m3,
                s.q_kg_per_s,
                s.q_ci95_kg_per_s,
                s.q_method,
                s.flowing_time_s,
                self.discharge.mass_kg,
                self.discharge.count as i64,
                s.clogs.len() as i64,
                s.clogs.iter().map(|c| c.duration_s).sum::<f64>(),
                s.permanently_clogged as i64,
                s.q_blocks as i64
            ],
        )?;
        self.numerics.write(&tx, job_id, self.dt_s)?;
        super::fields::delete_job_fields(&tx, job_id)?;
        if let Some(f) = &self.fields {
            let flowing = |t: f64| self.discharge.flowing_at_end(t, self.sim_time_s);
            super::fields::save_silo_fields(&tx, job_id, f, &flowing)?;
        }
        tx.execute(
            "UPDATE jobs SET status = 'done', lease_owner = NULL, progress = 1.0, sim_time_s = ?2, wall_time_s = ?3, particle_steps = ?4,
                finished_at = strftime('%Y-%m-%dT%H:%M:%fZ', 'now') WHERE id = ?1",
            params![job_id, self.sim_time_s, self.wall_time_s, self.particle_steps as i64],
        )?;
        tx.commit()?;
        Ok(true)
    }
}
