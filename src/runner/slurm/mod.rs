//! The Slurm executor: jobs handed to Slurm as job arrays (`submit`, scripts from `script`), one
//! array task per job running `sweep run-job` (`task`) in the job's directory on shared storage,
//! talking to the submitting host only through files (`files`); `collect` verifies and ingests
//! finished results into the database, `query` asks Slurm how its tasks are doing.

mod collect;
mod error;
pub mod files;
pub mod query;
mod script;
mod submit;
mod task;

pub use collect::{cancel, collect, CancelReport, CollectReport};
pub use error::SlurmError;
pub use submit::{resume_groups, submit, ResumeGroup, SubmitOptions, SubmitSettings, Submitted};
pub use task::{run_task, TaskEnd, TaskOptions};
