//! `sweep export --job ID --vtk DIR [--every K]`.

use std::path::PathBuf;

use sweep::export::{export_job, Encoding, ExportOptions};
use sweep::project::Project;

use super::DbArg;

#[derive(clap::Args)]
pub struct Arguments {
    /// The job's id (`sweep status` lists them).
    #[arg(long)]
    pub job: i64,
    /// Output directory for the VTK files (created if missing).
    #[arg(long)]
    pub vtk: PathBuf,
    /// Export every K-th snapshot frame (1 = all).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..))]
    pub every: u64,
    /// Write arrays as text instead of base64 (larger; readable by eye).
    #[arg(long)]
    pub ascii: bool,
    #[command(flatten)]
    pub db: DbArg,
}

pub fn run(a: Arguments) -> anyhow::Result<i32> {
    if !a.db.db.exists() {
        anyhow::bail!(
            "no database at {}: expected the database of a launched campaign (--db)",
            a.db.db.display()
        );
    }
    let project = Project::open(&a.db.db)?;
    let opts = ExportOptions {
        every: a.every as usize,
        encoding: if a.ascii {
            Encoding::Ascii
        } else {
            Encoding::Base64
        },
    };
    let work = project.work_dir()?;
    let r = export_job(project.conn(), &work, a.job, &a.vtk, &opts)?;
    for n in &r.notes {
        eprintln!("sweep: {n}");
    }
    for e in &r.refused {
        eprintln!("sweep: {e}");
    }
    if let Some(p) = &r.particles_pvd {
        println!(
            "wrote {} ({} particle frame(s); open it in ParaView)",
            p.display(),
            r.frames.len()
        );
    }
    if let Some(p) = &r.fields_pvd {
        println!("wrote {} ({} field set(s))", p.display(), r.fields.len());
    }
    // Refused frames do not stop the export, but the result is incomplete.
    Ok(if r.refused.is_empty() { 0 } else { 1 })
}
