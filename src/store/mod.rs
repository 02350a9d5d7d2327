//! The SQLite store, the only door to SQL: schema and migrations (`open`), where its work directory
//! is (`meta`), jobs and their lifecycle (`jobs`: registration, claim, heartbeat, release;
//! `requeue` for `resume`; `lookup` for status), forgetting jobs (`forget`), results
//! (`results`, read back by `silo_reads`; `chute_results` for the chute, read back by
//! `chute_reads`; `fields` for coarse-grained fields), jobs handed to Slurm (`slurm_tasks`,
//! `pending`) and their results ingested (`slurm_ingest`), job counts (`job_counts`), a finished
//! silo job's headline (`silo_done`), what the accuracy map reads (`accuracy_reads`), benchmark
//! runs (`bench_runs`), campaigns as reports find them (`campaign_reads`), claim verdicts
//! (`claims`), a campaign target's work and points
//! (`targets`). Every write that marks
//! progress is one transaction.

pub mod accuracy_reads;
pub mod bench_runs;
pub mod campaign_reads;
mod chute_flow_reads;
pub mod chute_reads;
mod chute_results;
pub mod claims;
pub mod fields;
pub mod forget;
pub mod job_counts;
pub mod jobs;
mod lease;
pub mod looks;
mod lookup;
pub mod meta;
pub mod numerics;
mod open;
pub mod pending;
mod register;
mod requeue;
mod results;
pub mod scope;
pub mod silo_done;
pub mod silo_reads;
pub mod slurm_ingest;
pub mod slurm_tasks;
pub mod targets;
#[cfg(test)]
pub(crate) mod test_rows;

pub use chute_results::ChuteJobResults;
pub use jobs::{JobRow, Lease};
pub use meta::{default_work_dir, work_dir};
pub use numerics::JobNumerics;
pub use open::{copy_to, open, open_checked, open_in_memory, SCHEMA_VERSION};
pub use results::SiloResults;

/// The database's current UTC time as `YYYYMMDDTHHMMSS` (names a submission's scripts).
///
/// # Errors
/// Database errors.
pub fn stamp(conn: &rusqlite::Connection) -> anyhow::Result<String> {
    Ok(conn.query_row("SELECT strftime('%Y%m%dT%H%M%S', 'now')", [], |r| r.get(0))?)
}

/// Unix time in seconds.
pub fn now() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}
