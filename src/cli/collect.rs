//! `sweep collect`: finished Slurm results into the database (also run by `status` and `resume`).

use sweep::project::{Executor, Project, Slurm};

use super::shared::print_report;
use super::DbArg;

#[derive(clap::Args)]
pub struct Arguments {
    #[command(flatten)]
    pub db: DbArg,
}

pub fn run(a: Arguments) -> anyhow::Result<i32> {
    if !a.db.db.exists() {
        eprintln!(
            "sweep: no database at {}: nothing to collect; start with `sweep launch FILE --executor slurm`",
            a.db.db.display()
        );
        return Ok(2);
    }
    let mut project = Project::open(&a.db.db)?;
    if !project.uses_slurm()? {
        println!(
            "no job of {} was handed to Slurm: nothing to collect",
            a.db.db.display()
        );
        return Ok(0);
    }
    let r = Slurm::reading().collect(&mut project)?;
    print_report(&r);
    println!(
        "{} job(s) collected, {} still queued or running under Slurm, {} ended without a result, {} failed, {} not verified",
        r.ingested.len(),
        r.with_slurm.len(),
        r.ended.len(),
        r.failed.len(),
        r.refused.len()
    );
    Ok(if r.failed.is_empty() && r.refused.is_empty() {
        0
    } else {
        1
    })
}
