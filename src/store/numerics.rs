//! A job's numerical record (time step, largest overlap, contacts, list rebuilds), accumulated
//! chunk by chunk by the runners and written with the job's results: what the accuracy–cost map
//! reads besides the observables.

use rusqlite::{params, Connection};
use serde::{Deserialize, Serialize};

use crate::engine::ChunkReport;
use crate::observe::energy::EnergyTrend;

/// Running totals over a job's chunks (kept in its checkpoints).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct JobNumerics {
    pub steps: u64,
    pub max_overlap_ratio: f64,
    pub contacts_sum: f64,
    pub chunks: u64,
    pub list_builds: u64,
    /// Kinetic energy over the measurement window (absent from checkpoints of older versions).
    #[serde(default)]
    pub energy: EnergyTrend,
}

impl JobNumerics {
    /// Adds one chunk's report.
    pub fn add(&mut self, r: &ChunkReport) {
        self.steps += r.steps;
        self.max_overlap_ratio = self.max_overlap_ratio.max(r.max_overlap_ratio);
        self.contacts_sum += r.contacts_per_particle;
        self.chunks += 1;
        self.list_builds += r.list_builds;
    }

    /// Writes (or replaces) the job's row.
    ///
    /// # Errors
    /// Database errors.
    pub fn write(&self, conn: &Connection, job_id: i64, dt_s: f64) -> rusqlite::Result<()> {
        conn.execute(
            "INSERT OR REPLACE INTO job_numerics (job_id, dt_s, steps, max_overlap_ratio, mean_contacts, list_builds)
             VALUES (?1, ?2, ?3, ?4, ?5, ?6)",
            params![
                job_id,
                dt_s,
                self.steps as i64,
                self.max_overlap_ratio,
                self.contacts_sum / self.chunks.max(1) as f64,
                self.list_builds as i64
            ],
        )?;
        if self.energy.samples > 0 {
            conn.execute(
                "INSERT OR REPLACE INTO job_energy (job_id, t_start_s, t_end_s, samples, mean_kinetic_j, drift_per_s)
                 VALUES (?1, ?2, ?3, ?4, ?5, ?6)",
                params![
                    job_id,
                    self.energy.t_first_s,
                    self.energy.t_last_s,
                    self.energy.samples as i64,
                    self.energy.mean_j(),
                    self.energy.relative_drift_per_s()
                ],
            )?;
        }
        Ok(())
    }
}
