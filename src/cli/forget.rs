//! `sweep forget`: removes jobs (or a campaign's jobs), their rows and their work directories,
//! after confirmation.

use std::io::{BufRead, IsTerminal, Write};

use sweep::project::{ForgetPlan, Liveness, Project};
use sweep::runner::job::job_dir;
use sweep::runner::job_lock;

use super::DbArg;

#[derive(clap::Args)]
#[command(group(clap::ArgGroup::new("what").required(true).args(["job", "campaign"])))]
pub struct Arguments {
    #[command(flatten)]
    pub db: DbArg,
    /// The job to forget (its id, as `sweep status` lists it).
    #[arg(long)]
    pub job: Option<i64>,
    /// The campaign to forget: every version, or `NAME@vK` for version K. Jobs another campaign
    /// shares are kept (only unlinked).
    #[arg(long)]
    pub campaign: Option<String>,
    /// Do not ask for confirmation.
    #[arg(long)]
    pub yes: bool,
}

pub fn run(a: Arguments) -> anyhow::Result<i32> {
    if !a.db.db.exists() {
        eprintln!("sweep: error: no database at {}", a.db.db.display());
        return Ok(2);
    }
    let mut project = Project::open(&a.db.db)?;
    let work = project.work_dir()?;
    let plan = match (&a.job, &a.campaign) {
        (Some(id), _) => project.plan_forget_job(*id),
        (None, Some(name)) => {
            let (name, version) = sweep::report::split_version(name);
            project.plan_forget_campaign(name, version)
        }
        (None, None) => unreachable!("clap requires --job or --campaign"),
    };
    let plan = match plan {
        Ok(p) => p,
        Err(e) => {
            eprintln!("sweep: error: {}: {e}", a.db.db.display());
            return Ok(2);
        }
    };
    // A job whose process lives is not pulled from under it.
    for j in project.open_jobs(sweep::project::JobScope::All)? {
        if j.status == "running" && plan.jobs.iter().any(|(id, ..)| *id == j.id) {
            if let Liveness::Alive(why) = job_lock::liveness(&work, &j, 30.0) {
                eprintln!("sweep: error: job {} is {why}: stop it first", j.id);
                return Ok(2);
            }
        }
    }
    describe(&plan);
    if !a.yes && !confirmed()? {
        println!("nothing forgotten");
        return Ok(1);
    }
    project.forget(&plan)?;
    let mut dirs = 0;
    for (_, hash, ..) in &plan.jobs {
        let dir = job_dir(&work, hash);
        if dir.exists() {
            std::fs::remove_dir_all(&dir)
                .map_err(|e| anyhow::anyhow!("{}: cannot remove: {e}", dir.display()))?;
            dirs += 1;
        }
    }
    println!(
        "forgot {} job(s) and {} campaign version(s); removed {dirs} work director{}",
        plan.jobs.len(),
        plan.campaigns.len(),
        if dirs == 1 { "y" } else { "ies" }
    );
    Ok(0)
}

fn describe(plan: &ForgetPlan) {
    println!(
        "this removes {} job(s) with all their results and checkpoints{}{}:",
        plan.jobs.len(),
        if plan.campaigns.is_empty() {
            String::new()
        } else {
            format!(", and {} campaign version(s)", plan.campaigns.len())
        },
        if plan.kept_shared > 0 {
            format!(
                " ({} job(s) other campaigns share are kept)",
                plan.kept_shared
            )
        } else {
            String::new()
        }
    );
    for (id, _, label, status) in &plan.jobs {
        println!("  job {id} [{status}] {label}");
    }
}

/// Asks on the terminal (or reads a line from the standard input when it is not one).
fn confirmed() -> anyhow::Result<bool> {
    if std::io::stdin().is_terminal() {
        print!("forget them? [y/N] ");
        std::io::stdout().flush()?;
    }
    let mut line = String::new();
    std::io::stdin().lock().read_line(&mut line)?;
    Ok(matches!(line.trim(), "y" | "Y" | "yes"))
}
