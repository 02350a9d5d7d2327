//! Command-line definitions (clap derive) and dispatch; one file per subcommand in `cli/`.

mod bench;
mod bench_args;
mod bench_batch;
mod bench_dispatches;
mod cancel;
mod claims;
mod collect;
mod export;
mod fields;
mod forget;
mod info;
mod interrupt;
mod launch;
mod plan;
mod plan_claims;
mod report;
mod run_args;
mod run_job;
mod schema;
mod shared;
mod status;
mod submit;

use std::path::PathBuf;

use clap::{Parser, Subcommand};

/// Parameter studies of granular flow: campaigns of DEM jobs, checkpointed, stored in SQLite.
#[derive(Parser)]
#[command(name = "sweep", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// Global database option shared by subcommands.
#[derive(clap::Args, Clone)]
pub struct DbArg {
    /// SQLite database (created by `launch`).
    #[arg(long, default_value = "sweep.db", env = "SWEEP_DB")]
    pub db: PathBuf,
}

#[derive(Subcommand)]
enum Command {
    /// Register a campaign file's jobs and run the pending ones.
    ///
    /// With `--executor slurm` the pending jobs are handed to Slurm as job arrays instead (one
    /// task per job, `sweep run-job`); the scripts are kept under the work directory, and
    /// `sweep status`, `sweep collect` or `sweep resume` collect finished results.
    ///
    /// EXAMPLES:
    ///   sweep launch campaigns/silo_QvsF_quick.json
    ///   sweep launch campaigns/silo_QvsF.json --parallel 2 --db paper.db
    ///   sweep launch campaigns/silo_QvsF.json --executor slurm --partition gpu --gpus-per-job 1 --time 04:00:00 --array-max 8
    ///   sweep launch campaigns/silo_QvsF.json --executor slurm --dry-run
    ///
    /// ERRORS: a bad campaign file exits with status 2 and names the file, the JSON path and
    /// what was expected; nothing is registered. A failed job does not stop the others; the exit
    /// status is then 1. With Slurm: no `sbatch` on PATH, bad settings, or `sbatch` refusing a
    /// script (a bad partition, say) exit with status 2 and Slurm's message; the jobs stay pending.
    Launch(run_args::Arguments),
    /// Continue paused jobs, jobs whose process died (stale heartbeat) and failed jobs with
    /// attempts left, from their last valid checkpoint.
    ///
    /// Jobs that ran under Slurm are collected first, and those whose task ended without a result
    /// (a time limit, a node failure, `sweep cancel`) are resubmitted to Slurm.
    ///
    /// EXAMPLES:
    ///   sweep resume
    ///   sweep resume --db paper.db --parallel 2
    ///   sweep resume --executor local   # run what was left on Slurm on this machine
    Resume(run_args::ResumeArguments),
    /// Campaigns and jobs: status, progress, throughput, time remaining.
    ///
    /// For jobs handed to Slurm, Slurm's view beside sweep's (finished results are collected
    /// first, as by `sweep collect`).
    Status(status::Arguments),
    /// Ingest the verified results of finished Slurm tasks into the database.
    ///
    /// Each task leaves its result in its job's directory; a result that verifies (checksum, row
    /// counts) is copied into the database and marks the job done. Jobs whose task ended without
    /// a result are paused for `sweep resume`.
    ///
    /// EXAMPLES:
    ///   sweep collect --db paper.db
    ///
    /// ERRORS: a result file that does not verify is reported and not ingested (exit status 1);
    /// when Slurm cannot be asked, jobs still handed to it are left as they are.
    Collect(collect::Arguments),
    /// Cancel the Slurm arrays of a campaign (or of all).
    ///
    /// Their jobs are paused at their last checkpoint; `sweep resume` resubmits them.
    ///
    /// EXAMPLES:
    ///   sweep cancel --campaign silo_QvsF --db paper.db
    Cancel(cancel::Arguments),
    /// Run one job as a Slurm array task (what the sbatch scripts call).
    ///
    /// Works in the job's directory under the work directory, without opening the database; the
    /// result is collected later by `sweep collect`.
    ///
    /// EXAMPLES:
    ///   sweep run-job --db-dir /scratch/me/sweep-work/paper --job 7 --backend gpu
    ///
    /// EXIT STATUS: 0 done (or requeued after SIGUSR1), 1 the job failed, 75 checkpointed on a
    /// signal and stopped, 2 an error (no job file, I/O).
    RunJob(run_job::Arguments),
    /// Each job's effects and estimated cost, without running anything.
    ///
    /// EXAMPLES:
    ///   sweep plan campaigns/silo_QvsF.json
    Plan(plan::Arguments),
    /// Redraw a paper's figure from the database (SVG, PNG, CSV and a table).
    ///
    /// EXAMPLES:
    ///   sweep report --figure fig4
    ///   sweep report --figure fig3 --campaign silo_QvsF_quick --out figures
    Report(report::Arguments),
    /// Measure engine throughput (particle-steps per second) on a benchmark scene.
    ///
    /// EXAMPLES:
    ///   sweep bench --scene silo-bed --particles 30000 --steps 200 --precision f32 --threads 2
    Bench(bench::Arguments),
    /// Write a job's particle snapshots and coarse-grained fields as VTK files for ParaView.
    ///
    /// Particles: the frames recorded with `observers.snapshots.interval_s`, as `.vtu` files
    /// and `particles.pvd` (open it in ParaView: a time series at the job's clock); a job
    /// without frames gives its latest checkpoint as one frame, and says so. Fields: each
    /// coarse-grained field set as a `.vti` image and `fields.pvd`. Array names carry units,
    /// e.g. `velocity [m/s]`.
    ///
    /// EXAMPLES:
    ///   sweep export --job 3 --vtk vtk/job3
    ///   sweep export --job 3 --vtk vtk/job3 --every 10 --db paper.db
    ///
    /// ERRORS: an unknown job id, a job with no frames, no checkpoint and no field sets, or an
    /// output directory that cannot be written exit with status 2 and name the job or the
    /// directory. A corrupt frame is skipped and named; the exit status is then 1.
    Export(export::Arguments),
    /// List a job's coarse-grained field sets: grid, kernel, time window, samples, fields.
    ///
    /// EXAMPLES:
    ///   sweep fields --job 3
    ///   sweep fields --job 3 --db quick.db
    ///
    /// ERRORS: no database or an unknown job id exit with status 2; a job without field sets
    /// (its campaign had no `observers.fields`) is said so and exits with status 0.
    Fields(fields::Arguments),
    /// Remove jobs, their results, checkpoints and work directories (after confirmation).
    ///
    /// EXAMPLES:
    ///   sweep forget --job 7
    ///   sweep forget --campaign silo_QvsF@v1
    ///   sweep forget --campaign silo_QvsF --yes   # every version, no question
    ///
    /// ERRORS: an unknown job or campaign, or a job whose process still runs it, exit with
    /// status 2; declining the question exits with 1 and removes nothing.
    Forget(forget::Arguments),
    /// Print the JSON Schema of campaign files (for editors).
    Schema,
    /// GPU adapters found, their limits, and the backend `auto` and `gpu` would choose.
    Info(info::Arguments),
}

/// Parses the command line and runs it; returns the exit code.
pub fn run() -> anyhow::Result<i32> {
    let cli = Cli::parse();
    match cli.command {
        Command::Launch(a) => launch::launch(a),
        Command::Resume(a) => launch::resume(a),
        Command::Status(a) => status::run(a),
        Command::Collect(a) => collect::run(a),
        Command::Cancel(a) => cancel::run(a),
        Command::RunJob(a) => run_job::run(a),
        Command::Plan(a) => plan::run(a),
        Command::Report(a) => report::run(a),
        Command::Export(a) => export::run(a),
        Command::Fields(a) => fields::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Forget(a) => forget::run(a),
        Command::Schema => schema::run(),
        Command::Info(a) => info::run(a),
    }
}
