//! What else the project keeps: Slurm's tasks, coarse-grained fields, and benchmark rates.

use std::collections::BTreeMap;

use super::{BenchRun, FieldArray, FieldSet, JobRateQuery, Project, RateQuery, SlurmTask};
use crate::store::{bench_runs, fields, slurm_tasks};

impl Project {
    /// Whether any job was ever handed to Slurm.
    ///
    /// # Errors
    /// Database errors.
    pub fn uses_slurm(&self) -> anyhow::Result<bool> {
        slurm_tasks::any(&self.conn)
    }

    /// Jobs whose submission to Slurm was cut short, made pending again; returns how many.
    ///
    /// # Errors
    /// Database errors.
    pub fn release_stale_submissions(&self, stale_after_s: f64) -> anyhow::Result<usize> {
        slurm_tasks::release_stale_submissions(&self.conn, stale_after_s)
    }

    /// Each job's latest Slurm task, of campaign `cid` or all.
    ///
    /// # Errors
    /// Database errors.
    pub fn slurm_tasks(&self, cid: Option<i64>) -> anyhow::Result<BTreeMap<i64, SlurmTask>> {
        slurm_tasks::latest_by_job(&self.conn, cid)
    }

    /// The coarse-grained field sets job `job` stored.
    ///
    /// # Errors
    /// Database errors.
    pub fn field_sets(&self, job: i64) -> anyhow::Result<Vec<FieldSet>> {
        fields::list_field_sets(&self.conn, job)
    }

    /// The arrays of field set `set`.
    ///
    /// # Errors
    /// Database errors.
    pub fn field_arrays(&self, set: i64) -> anyhow::Result<Vec<FieldArray>> {
        fields::load_field_arrays(&self.conn, set)
    }

    /// Records a benchmark run.
    ///
    /// # Errors
    /// Database errors.
    pub fn record_bench(&self, run: &BenchRun) -> anyhow::Result<()> {
        bench_runs::record(&self.conn, run)
    }

    /// The newest benchmark rate that fits `q` (particle-steps per second).
    pub fn newest_rate(&self, q: &RateQuery) -> Option<f64> {
        bench_runs::newest_rate(&self.conn, q)
    }

    /// The median rate of this store's done jobs that fit `q`, and how many there were.
    pub fn measured_rate(&self, q: &JobRateQuery) -> Option<(f64, usize)> {
        bench_runs::measured_rate(&self.conn, q)
    }
}
