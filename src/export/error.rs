//! Why an export failed: each error names the job or the file and what was expected.

use std::path::PathBuf;

/// Why `export_job` could not export.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error("no job {job_id} in the database: expected the id of a registered job ('sweep status' lists them)")]
    UnknownJob { job_id: i64 },
    #[error("job {job_id}: nothing to export: no snapshot frames in {}, no valid checkpoint in {} and no field sets in the database; set observers.snapshots.interval_s in the campaign and run the job ('sweep launch' or 'sweep resume')", snapshots.display(), job_dir.display())]
    Nothing {
        job_id: i64,
        snapshots: PathBuf,
        job_dir: PathBuf,
    },
    #[error("{}: cannot write: {source} (expected a writable directory)", path.display())]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("job {job_id}: cannot read from the database: {message}")]
    Store { job_id: i64, message: String },
    #[error("job {job_id}: {message}")]
    Fields { job_id: i64, message: String },
}
