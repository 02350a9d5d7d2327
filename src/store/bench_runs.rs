//! Benchmark runs (`bench_runs`): what `sweep bench` measured, and the throughput `sweep plan`
//! estimates a campaign's cost from.

use rusqlite::{params, Connection};

/// One benchmark run as stored.
#[derive(Clone, Debug)]
pub struct BenchRun<'a> {
    pub scene: &'a str,
    /// "cpu" or "gpu".
    pub backend: &'a str,
    /// "f64" or "f32".
    pub precision: &'a str,
    pub threads: i64,
    /// Mobile particles.
    pub particles: i64,
    pub steps: i64,
    pub dt_s: f64,
    pub particle_steps_per_s: f64,
    pub contacts_per_particle: f64,
    pub state_checksum: &'a str,
    pub machine: &'a str,
}

/// Records a benchmark run.
///
/// # Errors
/// Database errors.
pub fn record(conn: &Connection, run: &BenchRun) -> anyhow::Result<()> {
    conn.execute(
        "INSERT INTO bench_runs (scene, backend, precision, threads, particles, steps, dt_s, particle_steps_per_s, contacts_per_particle, state_checksum, machine)
         VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11)",
        params![
            run.scene,
            run.backend,
            run.precision,
            run.threads,
            run.particles,
            run.steps,
            run.dt_s,
            run.particle_steps_per_s,
            run.contacts_per_particle,
            run.state_checksum,
            run.machine
        ],
    )?;
    Ok(())
}

/// Which benchmark a throughput estimate comes from.
#[derive(Clone, Debug)]
pub struct RateQuery<'a> {
    /// The scene benched from its lattice.
    pub scene: &'a str,
    /// The scene benched from a settled bed, preferred when there is one (else `scene` again).
    pub settled_scene: &'a str,
    pub backend: &'a str,
    pub precision: &'a str,
    /// CPU threads (a GPU's rate does not depend on them).
    pub threads: i64,
}

/// The particle-steps per second of the newest matching benchmark, the settled scene's first;
/// `None` when there is none (or the query fails: an estimate is then just missing).
pub fn newest_rate(conn: &Connection, q: &RateQuery) -> Option<f64> {
    conn.query_row(
        "SELECT particle_steps_per_s FROM bench_runs WHERE scene IN (?1, ?5) AND backend = ?2
         AND precision = ?3 AND (backend = 'gpu' OR threads = ?4)
         ORDER BY scene = ?5 DESC, id DESC LIMIT 1",
        params![q.scene, q.backend, q.precision, q.threads, q.settled_scene],
        |r| r.get(0),
    )
    .ok()
}
