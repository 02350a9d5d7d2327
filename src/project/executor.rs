//! Where a project's jobs run, behind one trait (glotzerlab/row's `Scheduler`): this machine's
//! pool of engines, or a Slurm cluster. `sweep launch`, `resume`, `status`, `collect` and
//! `cancel` ask an executor to run jobs, to bring in what ended elsewhere, and to stop what it
//! runs; only the executor knows whether that is a thread pool or `sbatch`.

use std::path::PathBuf;

use super::{JobScope, Project};
use crate::runner::pool::{run_pending, PoolOptions, PoolSummary};
use crate::runner::slurm::{self, CancelReport, CollectReport, SubmitSettings, Submitted};

/// Which jobs to run: the pending ones of a campaign (or of the whole store), by id where the
/// executor needs them listed.
pub struct Submission<'a> {
    pub campaign: Option<i64>,
    pub campaign_name: &'a str,
    /// The pending jobs (Slurm runs these; the pool claims pending jobs itself).
    pub jobs: &'a [i64],
    /// Jobs of the campaign in all and those already done (the pool's progress counts).
    pub total: usize,
    pub done: usize,
}

/// What an executor did with a submission.
pub enum Outcome {
    /// The jobs ran here until none was left or an interrupt came.
    Ran(PoolSummary),
    /// The jobs were handed over (or, in a dry run, their scripts only written out).
    Handed(Vec<Submitted>),
}

/// Where jobs run.
pub trait Executor {
    /// Its name in messages ("local", "slurm").
    fn name(&self) -> &'static str;

    /// Runs the submission's jobs, or hands them over.
    ///
    /// # Errors
    /// The store, the file system or the cluster failing.
    fn submit(&mut self, project: &mut Project, s: &Submission) -> anyhow::Result<Outcome>;

    /// Brings in the results of jobs that ended elsewhere (nothing on this machine).
    ///
    /// # Errors
    /// The store failing.
    fn collect(&mut self, project: &mut Project) -> anyhow::Result<CollectReport>;

    /// Stops what runs under it (of `campaign`, or all): its jobs pause at their last
    /// checkpoint. Collect first: a job whose result is already there is done, not stopped.
    ///
    /// # Errors
    /// The store or the cluster failing.
    fn cancel(
        &mut self,
        project: &mut Project,
        campaign: Option<i64>,
    ) -> anyhow::Result<CancelReport>;
}

/// This machine: a pool of engines claims the pending jobs and runs them to their end.
pub struct Local {
    /// The pool's settings; its campaign and store are the submission's and the project's,
    /// its work directory the project's unless set.
    pub pool: PoolOptions,
}

impl Executor for Local {
    fn name(&self) -> &'static str {
        "local"
    }

    fn submit(&mut self, project: &mut Project, s: &Submission) -> anyhow::Result<Outcome> {
        self.pool.db = project.db().to_path_buf();
        if self.pool.work_dir.as_os_str().is_empty() {
            self.pool.work_dir = project.work_dir()?;
        }
        // A submission of one campaign runs its jobs; one of the whole store keeps the pool's
        // own scope (a plain `resume`: the latest versions).
        if let Some(c) = s.campaign {
            self.pool.scope = JobScope::Campaign(c);
        }
        Ok(Outcome::Ran(run_pending(&self.pool, s.total, s.done)?))
    }

    fn collect(&mut self, _project: &mut Project) -> anyhow::Result<CollectReport> {
        // Jobs of this machine store their results as they end.
        Ok(CollectReport::default())
    }

    fn cancel(
        &mut self,
        _project: &mut Project,
        _campaign: Option<i64>,
    ) -> anyhow::Result<CancelReport> {
        // A pool stops with its process (Ctrl-C, SIGTERM): its jobs checkpoint and pause.
        Ok(CancelReport::default())
    }
}

/// A Slurm cluster: pending jobs go out as job arrays running `sweep run-job`, their results
/// are verified and collected from the shared work directory.
pub struct Slurm {
    pub settings: SubmitSettings,
    /// The sweep binary as the compute nodes reach it.
    pub sweep_bin: PathBuf,
    /// Write and submit nothing; return the scripts.
    pub dry_run: bool,
}

impl Slurm {
    /// A Slurm executor that only collects and cancels (it submits nothing).
    pub fn reading() -> Slurm {
        Slurm {
            settings: SubmitSettings {
                slurm: crate::campaign::SlurmSettings::default(),
                backend: crate::runner::backend::BackendChoice::Auto,
                gpu: crate::runner::backend::GpuSelect::default(),
                threads: 0,
                checkpoint_interval_s: crate::campaign::RunSettings::default()
                    .checkpoint_interval_s,
            },
            sweep_bin: PathBuf::new(),
            dry_run: true,
        }
    }
}

impl Executor for Slurm {
    fn name(&self) -> &'static str {
        "slurm"
    }

    fn submit(&mut self, project: &mut Project, s: &Submission) -> anyhow::Result<Outcome> {
        let work = project.work_dir()?;
        let opts = slurm::SubmitOptions {
            work_dir: &work,
            campaign_id: s.campaign,
            campaign_name: s.campaign_name,
            settings: &self.settings,
            sweep_bin: &self.sweep_bin,
            dry_run: self.dry_run,
        };
        Ok(Outcome::Handed(slurm::submit(
            project.conn_mut(),
            s.jobs,
            &opts,
        )?))
    }

    fn collect(&mut self, project: &mut Project) -> anyhow::Result<CollectReport> {
        if !project.uses_slurm()? {
            return Ok(CollectReport::default());
        }
        let work = project.work_dir()?;
        slurm::collect(project.conn_mut(), &work)
    }

    fn cancel(
        &mut self,
        project: &mut Project,
        campaign: Option<i64>,
    ) -> anyhow::Result<CancelReport> {
        slurm::cancel(project.conn_mut(), campaign)
    }
}
