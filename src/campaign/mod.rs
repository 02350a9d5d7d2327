//! Campaign files: the raw format (`file`, with where jobs run in `executor`), validation with
//! precise errors (`error`), and expansion into jobs with parameter hashes and seeds (`expand`).

mod diff;
mod error;
mod executor;
mod expand;
mod file;
mod point;

pub use diff::diff_fields;
pub use error::{CampaignError, FieldProblem};
pub use executor::{ExecutorKind, SlurmSettings};
pub use expand::{expand, JobSpec};
pub use file::{CampaignFile, JobBackend, Observers, Precision, RunSettings, SceneKind};
pub use point::point_key;

/// Reads, parses, validates and expands a campaign file.
///
/// # Errors
/// The file cannot be read, is not JSON of the campaign shape, or has invalid values; every
/// problem names the file, the JSON path and what was expected.
pub fn load(path: &std::path::Path) -> Result<(CampaignFile, Vec<JobSpec>), CampaignError> {
    let text = std::fs::read_to_string(path).map_err(|e| CampaignError::Read {
        file: path.display().to_string(),
        source: e,
    })?;
    let file = CampaignFile::parse_str(&text, &path.display().to_string())?;
    let jobs = expand(&file, &path.display().to_string())?;
    Ok((file, jobs))
}
