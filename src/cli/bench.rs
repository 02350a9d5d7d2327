//! `sweep bench`: throughput of the engine on a benchmark scene, stored in the database for
//! `sweep plan`'s estimates.

use std::time::Instant;

use sweep::campaign::Precision;
use sweep::runner::backend::{self, BackendChoice};

use super::DbArg;

#[derive(clap::Args)]
pub struct Arguments {
    /// silo-bed, chute-bed or chute-rods.
    #[arg(long, default_value = "silo-bed")]
    pub scene: String,
    #[arg(long, default_value_t = 30_000)]
    pub particles: usize,
    /// Timed steps (after 100 untimed warm-up steps).
    #[arg(long, default_value_t = 200)]
    pub steps: u64,
    #[arg(long, default_value = "cpu")]
    pub backend: BackendChoice,
    #[arg(long, default_value = "f32")]
    pub precision: String,
    /// Engine threads (0: all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Runs from the same start (each with its own warm-up): the median is reported and stored,
    /// with the best and every run. On a shared or virtual machine single runs scatter by tens
    /// of per cent; every run must end in the same state (checked through the checksum).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    pub repeat: u32,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Do not store the result in the database.
    #[arg(long)]
    pub no_store: bool,
    #[command(flatten)]
    pub db: DbArg,
}

pub fn run(a: Arguments) -> anyhow::Result<i32> {
    let precision = match a.precision.as_str() {
        "f32" => Precision::F32,
        "f64" => Precision::F64,
        p => anyhow::bail!("--precision: expected f32 or f64, got {p:?}"),
    };
    let sc = sweep::bench::scene(&a.scene, a.particles, 1)?;
    let dt = sc.config.dt_s;
    let mut rates = Vec::new();
    let mut last = None;
    for _ in 0..a.repeat {
        let config = sc.config.clone();
        let mut engine = backend::build(a.backend, precision, config, &sc.state, a.threads)?;
        engine
            .advance(100)
            .map_err(|e| anyhow::anyhow!("warm-up: {e}"))?;
        let t0 = Instant::now();
        let r = engine
            .advance(a.steps)
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        let secs = t0.elapsed().as_secs_f64();
        rates.push((r.particle_steps as f64 / secs, secs));
        let sum = sweep::bench::checksum(&engine.download());
        if let Some((_, _, _, first)) = &last {
            anyhow::ensure!(
                *first == sum,
                "bench: run {} ended in state {sum}, the first in {first}: the engine is not deterministic",
                rates.len()
            );
        }
        last = Some((engine, r, secs, sum));
    }
    let (mut engine, r, _, sum) = last.expect("at least one run");
    let runs: Vec<f64> = rates.iter().map(|x| x.0).collect();
    rates.sort_by(|a, b| a.0.total_cmp(&b.0));
    // The median run's rate and time (the upper one of an even count).
    let (rate, secs) = rates[rates.len() / 2];
    let best = rates[rates.len() - 1].0;
    let info = engine.describe();
    let state = engine.download();
    let mobile = state.inv_mass.iter().filter(|&&m| m > 0.0).count();
    let machine = format!(
        "{} cores, {}",
        std::thread::available_parallelism().map_or(1, |n| n.get()),
        std::env::consts::ARCH
    );
    if a.json {
        println!(
            "{}",
            serde_json::json!({
                "scene": a.scene, "particles": mobile, "steps": a.steps, "dt_s": dt, "backend": info.kind, "adapter": info.adapter,
                "precision": info.precision, "threads": info.threads, "particle_steps_per_s": rate,
                "contacts_per_particle": r.contacts_per_particle, "list_builds": r.list_builds, "seconds": secs, "state_checksum": sum, "machine": machine,
                "runs_particle_steps_per_s": runs, "best_particle_steps_per_s": best
            })
        );
    } else {
        println!(
            "{}: N = {mobile}, {} steps, dt = {dt:.3e} s, {} {} ({}): {rate:.3e} particle-steps/s, {:.2} contacts/particle, {} list builds, {secs:.2} s, checksum {sum}",
            a.scene, a.steps, info.kind, info.precision, info.adapter, r.contacts_per_particle, r.list_builds
        );
        if runs.len() > 1 {
            let all: Vec<String> = runs.iter().map(|x| format!("{x:.3e}")).collect();
            println!(
                "  median of {} runs; best {best:.3e}; runs: {}",
                runs.len(),
                all.join(", ")
            );
        }
    }
    if !a.no_store {
        let conn = sweep::store::open(&a.db.db)?;
        conn.execute(
            "INSERT INTO bench_runs (scene, backend, precision, threads, particles, steps, dt_s, particle_steps_per_s, contacts_per_particle, state_checksum, machine)
             VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11)",
            rusqlite::params![a.scene, info.kind, info.precision, info.threads as i64, mobile as i64, a.steps as i64, dt, rate, r.contacts_per_particle, sum, machine],
        )?;
    }
    Ok(0)
}
