//! `sweep cancel`: cancels a campaign's Slurm arrays; their jobs stay resumable.

use sweep::project::{Executor, Project, Slurm};

use super::shared::print_report;
use super::DbArg;

#[derive(clap::Args)]
pub struct Arguments {
    #[command(flatten)]
    pub db: DbArg,
    /// Only this campaign's arrays (default: every campaign's).
    #[arg(long)]
    pub campaign: Option<String>,
}

pub fn run(a: Arguments) -> anyhow::Result<i32> {
    if !a.db.db.exists() {
        eprintln!(
            "sweep: no database at {}: nothing to cancel",
            a.db.db.display()
        );
        return Ok(2);
    }
    let mut project = Project::open(&a.db.db)?;
    let cid = match &a.campaign {
        Some(name) => match project.campaign_id(name)? {
            Some(id) => Some(id),
            None => {
                eprintln!(
                    "sweep: no campaign named {name} in {}; see `sweep status --db {}`",
                    a.db.db.display(),
                    a.db.db.display()
                );
                return Ok(2);
            }
        },
        None => None,
    };
    if !project.uses_slurm()? {
        println!("nothing to cancel: no job was handed to Slurm");
        return Ok(0);
    }
    // Results already there make their jobs done, not cancelled.
    let mut slurm = Slurm::reading();
    let r = slurm.collect(&mut project)?;
    print_report(&r);
    let c = slurm.cancel(&mut project, cid)?;
    if c.arrays.is_empty() {
        println!("nothing to cancel: no job is queued or running under Slurm");
        return Ok(0);
    }
    println!(
        "cancelled Slurm array(s) {}: {} job(s) paused at their last checkpoint",
        c.arrays.join(", "),
        c.paused.len()
    );
    println!(
        "continue with: sweep resume --db {} (resubmits them to Slurm)",
        a.db.db.display()
    );
    Ok(0)
}
