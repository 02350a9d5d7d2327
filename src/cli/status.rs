//! `sweep status`: campaigns and jobs with progress, throughput and time remaining; for jobs
//! handed to Slurm, Slurm's view beside sweep's (after collecting finished results).

use std::path::Path;

use sweep::runner::slurm::{self, query::SlurmView};
use sweep::store::slurm_tasks::{self, SlurmTask};

use super::DbArg;

#[derive(clap::Args)]
pub struct Arguments {
    #[command(flatten)]
    pub db: DbArg,
    /// Only this campaign.
    #[arg(long)]
    pub campaign: Option<String>,
}

pub fn run(a: Arguments) -> anyhow::Result<i32> {
    if !Path::new(&a.db.db).exists() {
        println!(
            "no database at {}: nothing has been launched here yet; start with `sweep launch FILE`",
            a.db.db.display()
        );
        return Ok(0);
    }
    let mut conn = sweep::store::open(&a.db.db)?;
    let slurm = slurm_view(&mut conn, &a.db.db)?;
    let mut camps = conn.prepare(
        "SELECT id, name, file FROM campaigns WHERE ?1 IS NULL OR name = ?1 ORDER BY id",
    )?;
    let camps: Vec<(i64, String, String)> = camps
        .query_map([&a.campaign], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))?
        .collect::<Result<_, _>>()?;
    if camps.is_empty() {
        println!(
            "{}: no campaigns{}",
            a.db.db.display(),
            a.campaign
                .as_ref()
                .map_or(String::new(), |c| format!(" named {c}"))
        );
        return Ok(0);
    }
    for (cid, name, file) in camps {
        let mut q = conn.prepare(
            "SELECT j.id, j.status, j.progress, j.sim_time_s, j.target_time_s, j.particle_steps, j.wall_time_s, j.attempts,
                    COALESCE(j.last_error, ''), cj.label, COALESCE(j.backend, ''), COALESCE(j.precision, '')
             FROM jobs j JOIN campaign_jobs cj ON cj.job_id = j.id WHERE cj.campaign_id = ?1 ORDER BY j.id",
        )?;
        #[allow(clippy::type_complexity)]
        let rows: Vec<(
            i64,
            String,
            f64,
            f64,
            f64,
            i64,
            f64,
            i64,
            String,
            String,
            String,
            String,
        )> = q
            .query_map([cid], |r| {
                Ok((
                    r.get(0)?,
                    r.get(1)?,
                    r.get(2)?,
                    r.get(3)?,
                    r.get(4)?,
                    r.get(5)?,
                    r.get(6)?,
                    r.get(7)?,
                    r.get(8)?,
                    r.get(9)?,
                    r.get(10)?,
                    r.get(11)?,
                ))
            })?
            .collect::<Result<_, _>>()?;
        let count = |s: &str| rows.iter().filter(|r| r.1 == s).count();
        println!(
            "campaign {name} ({file}): {} jobs — {} done, {} running, {} pending, {} paused, {} failed",
            rows.len(),
            count("done"),
            count("running"),
            count("pending"),
            count("paused"),
            count("failed")
        );
        println!(
            "{:>5}  {:<8} {:>6} {:>14} {:>16} {:>10} {:>4}  parameters",
            "job", "status", "done%", "sim_time_s", "particle-steps/s", "eta_s", "try"
        );
        for r in &rows {
            let rate = if r.6 > 0.0 { r.5 as f64 / r.6 } else { 0.0 };
            let eta = if r.1 != "done" && r.3 > 0.0 && r.6 > 0.0 {
                format!("{:.0}", (r.4 - r.3).max(0.0) * r.6 / r.3)
            } else {
                "-".into()
            };
            println!(
                "{:>5}  {:<8} {:>6.1} {:>6.2}/{:<7.2} {:>16.3e} {:>10} {:>4}  {} {}",
                r.0,
                r.1,
                100.0 * r.2,
                r.3,
                r.4,
                rate,
                eta,
                r.7,
                r.9,
                if r.10.is_empty() {
                    String::new()
                } else {
                    format!("[{} {}]", r.10, r.11)
                }
            );
            if !r.8.is_empty() && r.1 != "done" {
                println!("         last error: {}", r.8);
            }
            if let Some((tasks, view)) = &slurm {
                if let Some(t) = tasks.get(&r.0) {
                    println!("         slurm: {}", describe(t, view.as_ref()));
                }
            }
        }
    }
    Ok(0)
}

/// Every job's latest Slurm task, and Slurm's view of them (None when Slurm cannot be asked).
type SlurmRows = (
    std::collections::BTreeMap<i64, SlurmTask>,
    Option<SlurmView>,
);

/// Collects finished Slurm results, then Slurm's view of every job's latest task (None when no
/// job was ever handed to Slurm).
fn slurm_view(conn: &mut rusqlite::Connection, db: &Path) -> anyhow::Result<Option<SlurmRows>> {
    if !slurm_tasks::any(conn)? {
        return Ok(None);
    }
    let r = slurm::collect(conn, &super::launch::work_dir(db))?;
    super::collect::print_report(&r);
    let tasks = slurm_tasks::latest_by_job(conn, None)?;
    let mut arrays: Vec<String> = tasks.values().map(|t| t.array_job_id.clone()).collect();
    arrays.sort();
    arrays.dedup();
    let view = slurm::query::view(&arrays).ok();
    Ok(Some((tasks, view)))
}

/// "task 12_3 RUNNING on node7, requeued 1×" (Slurm's view), with sweep's when they differ.
fn describe(t: &SlurmTask, view: Option<&SlurmView>) -> String {
    let slurm = match view {
        None => "Slurm not reachable".to_string(),
        Some(v) => v
            .get(&t.array_job_id, t.array_task_id)
            .map_or_else(|| "unknown to Slurm now".to_string(), |tv| tv.describe()),
    };
    // How it ended for sweep; the reason is the job's last error, printed above.
    let sweep = match t.state.as_str() {
        "active" => String::new(),
        "done" => "; result collected".to_string(),
        other => format!("; {other}"),
    };
    format!("task {} {slurm}{sweep}", t.slurm_id())
}
