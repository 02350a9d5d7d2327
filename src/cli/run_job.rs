//! `sweep run-job`: what one Slurm array task runs (see `runner::slurm::task`).

use std::path::PathBuf;

use sweep::runner::backend::BackendChoice;
use sweep::runner::slurm::{run_task, TaskEnd, TaskOptions};

#[derive(clap::Args)]
pub struct Arguments {
    /// The database's work directory (`sweep-work/<database name>` beside the database), on
    /// storage this node shares with the submitting host. The database itself is not opened.
    #[arg(long = "db-dir", alias = "work-dir", value_name = "DIR")]
    pub db_dir: PathBuf,
    /// The job's id (as `sweep status` lists it).
    #[arg(long, value_name = "ID")]
    pub job: i64,
    /// auto (a GPU when there is one, else the CPU), gpu or cpu.
    #[arg(long, default_value = "auto")]
    pub backend: BackendChoice,
    #[command(flatten)]
    pub gpu: super::run_args::GpuArgs,
    /// Engine threads (0: SLURM_CPUS_PER_TASK, else 1).
    #[arg(long, default_value_t = 0, value_parser = super::run_args::bounded(0, super::run_args::MAX_THREADS))]
    pub threads: usize,
}

/// Exit status of a task that checkpointed and stopped without asking to be requeued
/// (EX_TEMPFAIL: try again later).
const PAUSED: i32 = 75;

pub fn run(a: Arguments) -> anyhow::Result<i32> {
    let end = run_task(&TaskOptions {
        work_dir: a.db_dir,
        job_id: a.job,
        backend: a.backend,
        gpu: a.gpu.select(),
        threads: a.threads,
    })?;
    Ok(match end {
        TaskEnd::Done => 0,
        TaskEnd::AlreadyDone => {
            println!(
                "job {} is already done (its result verifies): nothing to run",
                a.job
            );
            0
        }
        TaskEnd::Paused { requeued: Some(id) } => {
            println!(
                "job {}: Slurm job {id} requeued; it continues from its checkpoint",
                a.job
            );
            0
        }
        TaskEnd::Paused { requeued: None } => PAUSED,
        TaskEnd::Failed(_) => 1,
    })
}
