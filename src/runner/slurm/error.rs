//! What can go wrong between sweep and Slurm, in words that say what to do next.

use std::path::PathBuf;

/// Errors of the Slurm executor.
#[derive(Debug, thiserror::Error)]
pub enum SlurmError {
    /// `sbatch` (or another Slurm command) is not on PATH.
    #[error("{command} not found on PATH: run this on a Slurm login node (or load the site's slurm module), or use --executor local")]
    NotInstalled { command: &'static str },
    /// Slurm answered a command with an error (the controller is down, SLURM_CONF is wrong …).
    #[error("{command} failed ({status}): {stderr}")]
    Command {
        command: String,
        status: String,
        stderr: String,
    },
    /// `sbatch` refused a script (a bad partition, an impossible request, a limit).
    #[error("sbatch refused {}: {stderr}; its jobs stay pending (fix the settings and launch again)", script.display())]
    Rejected { script: PathBuf, stderr: String },
    /// The executor settings are not usable.
    #[error("slurm settings: {}", problems.join("; "))]
    Settings { problems: Vec<String> },
    /// A task was started for a job that was never prepared for Slurm in this work directory.
    #[error("{}: no such job file: was job {job} submitted with `sweep launch --executor slurm` using this work directory?", path.display())]
    NoJobFile { job: i64, path: PathBuf },
    /// File I/O on the shared work directory.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
}

impl SlurmError {
    pub(crate) fn io(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> Self {
        let path = path.into();
        move |source| SlurmError::Io { path, source }
    }
}
