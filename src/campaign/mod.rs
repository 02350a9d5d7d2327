//! Campaign files: the raw format (`file`, with where jobs run in `executor`), validation with
//! precise errors (`error`, `file_checks`), and expansion into jobs (`expand`; held by point in
//! `jobs`) with parameter hashes and seeds (`identity`).

pub mod adaptive;
pub mod claims;
mod diff;
mod duplicates;
mod error;
mod executor;
mod expand;
mod file;
mod file_checks;
mod identity;
mod job_spec;
mod jobs;
mod point;
mod resources;
mod scene_kind;
mod schema;
mod target;

pub use diff::diff_fields;
pub use error::{CampaignError, FieldProblem};
pub use executor::{ExecutorKind, SlurmSettings};
pub use expand::expand;
pub use file::{CampaignFile, JobBackend, Observers, Precision, RunSettings, SceneKind};
pub use identity::{key_with, Identity};
pub use job_spec::{job_dir, JobSpec};
pub use jobs::Jobs;
pub use point::{label_without_replica, point_key, point_params};
pub use resources::{memory_estimate, memory_limit, MemoryEstimate, MemoryLimit, MEMORY_LIMIT_ENV};
pub use schema::campaign_schema;
pub use target::{Allocation, ClaimsGoal, Target};

/// Reads, parses, validates and expands a campaign file.
///
/// # Errors
/// The file cannot be read, is not JSON of the campaign shape, has invalid values, or has a job
/// this machine cannot hold (`check_machine`); every problem names the file, the JSON path and
/// what was expected.
pub fn load(path: &std::path::Path) -> Result<(CampaignFile, Jobs), CampaignError> {
    let text = std::fs::read_to_string(path).map_err(|e| CampaignError::Read {
        file: path.display().to_string(),
        source: e,
    })?;
    let file = CampaignFile::parse_str(&text, &path.display().to_string())?;
    let jobs = expand(&file, &path.display().to_string())?;
    check_machine(jobs.points(), &path.display().to_string())?;
    Ok((file, jobs))
}

/// Refuses jobs this machine cannot hold (replicas need what their point needs): each job's memory estimate against `MemTotal` (or
/// `SWEEP_MEMORY_LIMIT_BYTES`), naming the field that sets its particle count.
///
/// # Errors
/// A job over the limit, or an unreadable `SWEEP_MEMORY_LIMIT_BYTES`.
pub fn check_machine(jobs: &[JobSpec], file: &str) -> Result<(), CampaignError> {
    let limit = memory_limit().map_err(|message| CampaignError::Invalid {
        file: file.into(),
        problems: vec![FieldProblem {
            path: format!("(environment) {MEMORY_LIMIT_ENV}"),
            message,
        }],
    })?;
    let Some(limit) = limit else {
        return Ok(());
    };
    let problems = resources::memory_problems(jobs, &limit);
    if problems.is_empty() {
        Ok(())
    } else {
        Err(CampaignError::Invalid {
            file: file.into(),
            problems,
        })
    }
}
