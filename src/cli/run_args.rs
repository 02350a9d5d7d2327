//! The arguments of `sweep launch` and `sweep resume`: how pending jobs run, where (this machine
//! or Slurm), and how Slurm is asked for them.

use std::path::PathBuf;

use sweep::campaign::{ExecutorKind, SlurmSettings};
use sweep::runner::backend::{BackendChoice, GpuSelect};

use super::DbArg;

/// The most threads (or jobs at once) a command accepts: far above any machine's cores, far
/// below what makes the OS refuse a thread pool.
pub const MAX_THREADS: usize = 1024;

/// How pending jobs run (shared by launch and resume).
#[derive(clap::Args)]
pub struct RunArgs {
    #[command(flatten)]
    pub db: DbArg,
    /// auto (a GPU when there is one, else the CPU), gpu or cpu.
    #[arg(long, default_value = "auto")]
    pub backend: BackendChoice,
    #[command(flatten)]
    pub gpu: GpuArgs,
    /// Jobs run at the same time (at least 1).
    #[arg(long, default_value_t = 1, value_parser = bounded(1, MAX_THREADS))]
    pub parallel: usize,
    /// Engine threads per job (0: cores / parallel; at most 1024).
    #[arg(long, default_value_t = 0, value_parser = bounded(0, MAX_THREADS))]
    pub threads: usize,
    /// GPU jobs running at the same time (--parallel) share one engine, up to J per batch
    /// (1 to 32; auto: all of them, as the device's buffer limits allow). Each job's results are
    /// those it has alone.
    #[arg(long, default_value = "auto", value_name = "auto|J", value_parser = parse_batch)]
    pub batch: usize,
    /// Stop after this much wall time (e.g. 2h45m, 90m, 30s): the running jobs write their
    /// checkpoints and pause, as on Ctrl-C, and `sweep resume` continues them. For a session or
    /// a machine held until a fixed time. This machine's runs only: Slurm jobs take `--time`.
    #[arg(long, value_name = "DURATION", value_parser = parse_time_limit)]
    pub time_limit: Option<std::time::Duration>,
}

/// `--time-limit`: a humantime duration above zero (a zero limit would stop the run before
/// it registered or claimed anything).
fn parse_time_limit(s: &str) -> Result<std::time::Duration, String> {
    match humantime::parse_duration(s) {
        Ok(d) if !d.is_zero() => Ok(d),
        Ok(_) => Err("expected a duration above zero, e.g. 2h45m".into()),
        Err(e) => Err(format!(
            "expected a duration such as 2h45m, 90m or 30s: {e}"
        )),
    }
}

/// `--batch`: auto (every job running at once, at most 32) or J in 1..=32.
fn parse_batch(s: &str) -> Result<usize, String> {
    if s == "auto" {
        return Ok(sweep::engine::gpu::MAX_JOBS);
    }
    match s.parse::<usize>() {
        Ok(j) if (1..=sweep::engine::gpu::MAX_JOBS).contains(&j) => Ok(j),
        _ => Err(format!(
            "expected auto or a number of jobs from 1 to {}, got {s:?}",
            sweep::engine::gpu::MAX_JOBS
        )),
    }
}

/// Which GPU adapter `--backend gpu|auto` takes (launch, resume, run-job, bench).
#[derive(clap::Args, Clone, Copy, Debug, Default)]
pub struct GpuArgs {
    /// The GPU adapter numbered N by `sweep info` (default: the best one).
    #[arg(long = "gpu", value_name = "N")]
    pub index: Option<usize>,
    /// Let --backend gpu run on a software adapter (lavapipe, llvmpipe), which it refuses
    /// otherwise; also SWEEP_ALLOW_SOFTWARE_GPU=1.
    #[arg(long)]
    pub allow_software_gpu: bool,
}

impl GpuArgs {
    pub fn select(&self) -> GpuSelect {
        GpuSelect {
            index: self.index,
            allow_software: self.allow_software_gpu,
        }
    }
}

#[derive(clap::Args)]
pub struct Arguments {
    /// Campaign file (JSON).
    pub file: PathBuf,
    #[command(flatten)]
    pub run: RunArgs,
    #[command(flatten)]
    pub exec: ExecutorArgs,
    /// Launch a changed file as a new version of its campaign (the old version's jobs and
    /// results stay as they are, apart from it).
    #[arg(long)]
    pub new_version: bool,
    /// Register the campaign's jobs and stop: a later `sweep resume --db` runs it in turn with
    /// the store's other campaigns (a queue on a machine that is busy with them).
    #[arg(long, conflicts_with = "executor")]
    pub register_only: bool,
}

#[derive(clap::Args)]
pub struct ResumeArguments {
    #[command(flatten)]
    pub run: RunArgs,
    /// A running job of another machine (or of an older sweep) whose heartbeat is older than
    /// this (s) is taken as dead. Jobs of this machine are judged at once by their OS lock.
    #[arg(long, default_value_t = 30.0)]
    pub stale_after: f64,
    /// Jobs are run until they have had this many attempts (default: each campaign's
    /// `run.max_attempts`); a job whose attempts are spent is marked failed.
    #[arg(long, value_parser = clap::value_parser!(i64).range(1..))]
    pub max_attempts: Option<i64>,
    /// Where resumed jobs run: local or slurm (default: where each job last ran; Slurm jobs
    /// are resubmitted with the settings of their last submission).
    #[arg(long)]
    pub executor: Option<ExecutorKind>,
    /// Only these campaigns' jobs, in the order named: NAME (its latest version) or NAME@vK
    /// (version K); repeat the flag for several. Others stay as they are,
    /// e.g. an older version's paused jobs that a new version replaces. Idle workers at one
    /// campaign's tail run the jobs of the others named.
    #[arg(long, value_name = "NAME[@vK]")]
    pub campaign: Vec<String>,
    /// Campaigns strictly one after another. By default, while a campaign's last jobs run,
    /// idle workers run the next campaigns' jobs and hand them back at a checkpoint when the
    /// campaign's own jobs have ended.
    #[arg(long)]
    pub one_at_a_time: bool,
}

/// Where jobs run, and how Slurm is asked for them.
#[derive(clap::Args)]
pub struct ExecutorArgs {
    /// local (this machine) or slurm (job arrays); default: the campaign's run.executor, else
    /// local.
    #[arg(long)]
    pub executor: Option<ExecutorKind>,
    /// Slurm partition (default: the campaign's run.slurm, else the cluster's default).
    #[arg(long, value_name = "P")]
    pub partition: Option<String>,
    /// GPUs per job (--gres=gpu:N).
    #[arg(long, value_name = "N")]
    pub gpus_per_job: Option<u32>,
    /// CPU cores per job (--cpus-per-task), also the engine threads unless --threads is given.
    #[arg(long, value_name = "N")]
    pub cpus_per_job: Option<u32>,
    /// Time limit per task ([D-]HH:MM:SS); a job that needs longer is checkpointed and requeued.
    #[arg(long, value_name = "HH:MM:SS")]
    pub time: Option<String>,
    /// At most K tasks of the array run at once (--array=…%K).
    #[arg(long, value_name = "K")]
    pub array_max: Option<u32>,
    /// One more sbatch option, repeatable: --sbatch-arg=--account=proj42.
    #[arg(long = "sbatch-arg", value_name = "ARG", allow_hyphen_values = true)]
    pub sbatch_args: Vec<String>,
    /// Print the sbatch scripts and submit nothing (the database is left as it was).
    #[arg(long)]
    pub dry_run: bool,
}

impl ExecutorArgs {
    /// The campaign's Slurm settings with the command line's on top (sbatch args added).
    pub fn slurm_settings(&self, file: &SlurmSettings) -> SlurmSettings {
        let mut s = file.clone();
        if let Some(p) = &self.partition {
            s.partition = Some(p.clone());
        }
        if let Some(n) = self.gpus_per_job {
            s.gpus_per_job = n;
        }
        if let Some(n) = self.cpus_per_job {
            s.cpus_per_job = n;
        }
        if let Some(t) = &self.time {
            s.time = Some(t.clone());
        }
        if let Some(k) = self.array_max {
            s.array_max = Some(k);
        }
        s.sbatch_args.extend(self.sbatch_args.iter().cloned());
        s
    }

    /// The Slurm-only flags given on the command line.
    pub fn slurm_flags(&self) -> Vec<&'static str> {
        let mut v = Vec::new();
        for (set, name) in [
            (self.partition.is_some(), "--partition"),
            (self.gpus_per_job.is_some(), "--gpus-per-job"),
            (self.cpus_per_job.is_some(), "--cpus-per-job"),
            (self.time.is_some(), "--time"),
            (self.array_max.is_some(), "--array-max"),
            (!self.sbatch_args.is_empty(), "--sbatch-arg"),
            (self.dry_run, "--dry-run"),
        ] {
            if set {
                v.push(name);
            }
        }
        v
    }
}

/// A clap parser of a whole number in [lo, hi] (thread and job counts).
pub fn bounded(lo: u64, hi: usize) -> clap::builder::RangedU64ValueParser<usize> {
    clap::builder::RangedU64ValueParser::<usize>::new().range(lo..=hi as u64)
}
