//! A sweep project as the command line sees it: one store (its campaigns, jobs, results and
//! Slurm tasks) and the work directory beside it, behind one door, `Project::open(db)`. The
//! binary asks the project (register, pending, status, forget, …) and never picks a store
//! module or writes SQL itself; the layers below that read a store (report, runner, export)
//! take the project's connection.

mod campaigns;
pub mod executor;
mod jobs;
mod records;

use std::path::{Path, PathBuf};

use anyhow::Context;
use rusqlite::Connection;

pub use crate::store::bench_runs::{BenchRun, JobRateQuery, RateQuery};
pub use crate::store::campaign_reads::CampaignRef;
pub use crate::store::chute_reads::FlowVerdict;
pub use crate::store::claims::{CpuUse, VerdictRow};
pub use crate::store::fields::{FieldArray, FieldSet};
pub use crate::store::forget::ForgetPlan;
pub use crate::store::job_counts::JobTotals;
pub use crate::store::jobs::{
    owner_place, CampaignRow, Decision, JobScope, JobStatus, Liveness, OpenJob, OwnerPlace,
    Registration, StateTotal, StoredJob,
};
pub use crate::store::slurm_tasks::SlurmTask;
pub use crate::store::targets::{PointRow, WorkRow};
pub use executor::{Executor, Local, Outcome, Slurm, Submission};

/// An open store and where it lives.
pub struct Project {
    db: PathBuf,
    conn: Connection,
}

impl Project {
    /// Opens (creating or upgrading) the store at `db`.
    ///
    /// # Errors
    /// A store that cannot be opened or set up.
    pub fn open(db: &Path) -> anyhow::Result<Project> {
        Ok(Project {
            db: db.to_path_buf(),
            conn: crate::store::open(db)?,
        })
    }

    /// [`Project::open`], refusing a store whose pages are damaged before anything is written.
    ///
    /// # Errors
    /// As `open`, and a store that fails SQLite's check.
    pub fn open_checked(db: &Path) -> anyhow::Result<Project> {
        Ok(Project {
            db: db.to_path_buf(),
            conn: crate::store::open_checked(db)?,
        })
    }

    /// A copy of the store at `db` in memory (an empty one if there is none): a dry run
    /// registers into it and leaves the file as it was.
    ///
    /// # Errors
    /// A store that cannot be read.
    pub fn scratch_copy(db: &Path) -> anyhow::Result<Project> {
        Ok(Project {
            db: db.to_path_buf(),
            conn: crate::store::open_in_memory(db.exists().then_some(db))?,
        })
    }

    /// The store's file.
    pub fn db(&self) -> &Path {
        &self.db
    }

    /// The store, for the layers that read it (report, runner, export).
    pub fn conn(&self) -> &Connection {
        &self.conn
    }

    /// The store, for the layers that write it (runner: Slurm collection and submission).
    pub fn conn_mut(&mut self) -> &mut Connection {
        &mut self.conn
    }

    /// The work directory (checkpoints, shared stages), as the store records it.
    ///
    /// # Errors
    /// A store or file-system error.
    pub fn work_dir(&self) -> anyhow::Result<PathBuf> {
        crate::store::work_dir(&self.conn, &self.db)
            .with_context(|| format!("{}: finding its work directory", self.db.display()))
    }
}
