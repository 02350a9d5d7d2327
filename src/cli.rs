//! Command-line definitions (clap derive) and dispatch; one file per subcommand in `cli/`.

mod bench;
mod info;
mod launch;
mod plan;
mod report;
mod schema;
mod status;

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
    /// EXAMPLES:
    ///   sweep launch campaigns/silo_QvsF_quick.json
    ///   sweep launch campaigns/silo_QvsF.json --parallel 2 --db paper.db
    ///
    /// ERRORS: a bad campaign file exits with status 2 and names the file, the JSON path and
    /// what was expected; nothing is registered. A failed job does not stop the others; the exit
    /// status is then 1.
    Launch(launch::Arguments),
    /// Continue paused jobs, jobs whose process died (stale heartbeat) and failed jobs with
    /// attempts left, from their last valid checkpoint.
    ///
    /// EXAMPLES:
    ///   sweep resume
    ///   sweep resume --db paper.db --parallel 2
    Resume(launch::ResumeArguments),
    /// Campaigns and jobs: status, progress, throughput, time remaining.
    Status(status::Arguments),
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
        Command::Plan(a) => plan::run(a),
        Command::Report(a) => report::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Schema => schema::run(),
        Command::Info(a) => info::run(a),
    }
}
