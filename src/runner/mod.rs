//! Job lifecycle: claim, run in chunks, heartbeat, checkpoint, resume, finish. `silo_job` runs one
//! silo job, `chute_job` one chute job; two executors decide where: `pool` runs a campaign's
//! pending jobs K at a time on this machine, `slurm` hands them to Slurm as job arrays; `backend`
//! picks and builds the simulation backend.

pub mod backend;
pub mod chute_job;
pub mod job;
pub mod job_lock;
pub mod pool;
pub mod silo_job;
pub mod slurm;

pub use job::{job_dir, JobContext, Outcome};
pub use pool::{run_pending, PoolOptions};
pub use silo_job::run_silo_job;
