//! The SQLite store: schema and migrations (`open`), jobs and their lifecycle (`jobs`), results
//! (`results`; `chute_results` for the chute). Every write that marks progress is one transaction.

mod chute_results;
pub mod jobs;
mod open;
mod results;

pub use jobs::{JobRow, Lease};
pub use open::{open, SCHEMA_VERSION};
pub use results::SiloResults;

/// Unix time in seconds.
pub fn now() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}
