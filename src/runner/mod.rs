//! Job lifecycle: `job` runs one job (resume or start, the chunk loop, checkpoints, results)
//! of a study that plugs in through `job::Study` (`silo_job`, `chute_job`); `job_lock` says
//! whether a job's process lives (an OS lock, a heartbeat thread). Two executors decide where:
//! `pool` claims and runs a campaign's pending jobs K at a time on this machine, `slurm` hands
//! them to Slurm as job arrays; `backend` picks and builds the simulation backend; `adaptive`
//! adds the work a campaign's target asks for, round by round.

pub mod adaptive;
mod auto_choice;
pub mod backend;
pub mod chute_job;
pub mod claim_points;
mod claim_reach;
mod claim_replicas;
pub mod claim_rounds;
pub mod evaluation;
pub mod gpu_batch;
pub mod gpu_variants;
pub mod job;
pub mod job_lock;
pub mod owner_process;
pub mod pool;
mod pool_tail;
pub mod silo_job;
pub mod slurm;

pub use job::{job_dir, JobContext, Outcome};
pub use pool::{run_pending, PoolOptions};
pub use silo_job::run_silo_job;
