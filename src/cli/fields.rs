//! `sweep fields --job ID`: lists a job's coarse-grained field sets and their fields.

use sweep::project::Project;

use super::DbArg;

#[derive(clap::Args)]
pub struct Arguments {
    #[command(flatten)]
    pub db: DbArg,
    /// Job id (see `sweep status`).
    #[arg(long)]
    pub job: i64,
}

pub fn run(a: Arguments) -> anyhow::Result<i32> {
    if !a.db.db.exists() {
        eprintln!("sweep: no database at {}", a.db.db.display());
        return Ok(2);
    }
    let project = Project::open(&a.db.db)?;
    let Some(label) = project.job_label(a.job)? else {
        eprintln!(
            "sweep: no job {} in {}; see `sweep status --db {}`",
            a.job,
            a.db.db.display(),
            a.db.db.display()
        );
        return Ok(2);
    };
    let sets = project.field_sets(a.job)?;
    println!("job {} ({label}): {} field set(s)", a.job, sets.len());
    if sets.is_empty() {
        println!("  none: its campaign has no observers.fields, or the job is not done");
    }
    for s in &sets {
        let axes = match s.grid_kind.as_str() {
            "rz" => ["r", "z", "-"],
            "z" => ["-", "-", "z"],
            _ => ["x", "y", "z"],
        };
        let dims: Vec<String> = (0..3)
            .filter(|&k| s.shape[k] > 1 || axes[k] != "-")
            .map(|k| {
                format!(
                    "{} {} from {:.4} m step {:.4} m",
                    axes[k], s.shape[k], s.origin_m[k], s.spacing_m[k]
                )
            })
            .collect();
        println!(
            "{}  [{}]  {}  w = {:.4} m, cutoff {} w  t = {:.3}..{:.3} s, {} sample(s)",
            s.name,
            s.grid_kind,
            dims.join(", "),
            s.kernel_width_m,
            s.cutoff_widths,
            s.t_start_s,
            s.t_end_s,
            s.samples
        );
        for f in project.field_arrays(s.id)? {
            let kind = match f.components {
                1 => "scalar",
                3 => "vector",
                9 => "tensor",
                _ => "array",
            };
            println!(
                "    {:<18} {:<10} {} ({} components)",
                f.field, f.units, kind, f.components
            );
        }
    }
    Ok(0)
}
