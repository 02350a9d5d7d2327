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
    /// The job's particles: a rate depends on N (a GPU's strongly, launch-bound when small).
    pub particles: i64,
}

/// The particle-steps per second of the matching benchmark nearest the job's N (by ratio), the
/// settled scene's first, the newest of equals; `None` when there is none (or the query fails:
/// an estimate is then just missing).
pub fn newest_rate(conn: &Connection, q: &RateQuery) -> Option<f64> {
    conn.query_row(
        "SELECT particle_steps_per_s FROM bench_runs WHERE scene IN (?1, ?5) AND backend = ?2
         AND precision = ?3 AND (backend = 'gpu' OR threads = ?4)
         ORDER BY scene = ?5 DESC,
                  MAX(MAX(particles, 1) * 1.0 / ?6, ?6 * 1.0 / MAX(particles, 1)), id DESC
         LIMIT 1",
        params![
            q.scene,
            q.backend,
            q.precision,
            q.threads,
            q.settled_scene,
            q.particles.max(1)
        ],
        |r| r.get(0),
    )
    .ok()
}

/// Which finished jobs a throughput estimate may come from when no benchmark fits.
#[derive(Clone, Debug)]
pub struct JobRateQuery<'a> {
    /// `jobs.scene`: "silo" or "chute".
    pub scene: &'a str,
    /// Chute only: spheres (ξ = 1, the sphere engine) or spherocylinders.
    pub spheres: Option<bool>,
    pub backend: &'a str,
    pub precision: &'a str,
    /// CPU threads (a GPU's rate does not depend on them).
    pub threads: i64,
}

/// The median particle-steps per second of this store's done jobs that fit `q` (each over at
/// least a minute of wall time), with how many there were; None without any. A one-thread CPU
/// job that counted its CPU time gives its rate per second of that (at most its wall time), so
/// that jobs which shared their core with other work do not slow the forecast.
pub fn measured_rate(conn: &Connection, q: &JobRateQuery) -> Option<(f64, usize)> {
    let mut stmt = conn
        .prepare(
            "SELECT CAST(particle_steps AS REAL)
                    / CASE WHEN backend = 'cpu' AND threads = 1 AND cpu_time_s > 0
                           THEN MIN(cpu_time_s, wall_time_s) ELSE wall_time_s END
             FROM jobs
             WHERE status = 'done' AND scene = ?1 AND backend = ?2 AND precision = ?3
               AND (backend = 'gpu' OR threads = ?4) AND wall_time_s >= 60 AND particle_steps > 0
               AND (?5 IS NULL OR scene <> 'chute'
                    OR (json_extract(params_json, '$.chute.aspect_ratio') = 1.0) = ?5)",
        )
        .ok()?;
    let mut rates: Vec<f64> = stmt
        .query_map(
            params![q.scene, q.backend, q.precision, q.threads, q.spheres],
            |r| r.get(0),
        )
        .ok()?
        .filter_map(Result::ok)
        .collect();
    if rates.is_empty() {
        return None;
    }
    rates.sort_by(f64::total_cmp);
    Some((rates[rates.len() / 2], rates.len()))
}

#[cfg(test)]
mod tests {
    use super::{measured_rate, newest_rate, record, BenchRun, JobRateQuery, RateQuery};
    use crate::store::test_rows;

    /// A GPU's rate depends on N (launch-bound when small): a plan takes the bench nearest the
    /// job's N by ratio, the newest of equals, and any threads for a GPU.
    #[test]
    fn a_plan_takes_the_bench_nearest_the_jobs_n() {
        let conn = test_rows::empty_db();
        // (particles, rate, threads), oldest first.
        let runs = [
            (30_000, 5.0e8, 1),
            (1_000_000, 2.0e9, 1),
            (30_000, 6.0e8, 16),
            (3_000, 1.0e8, 1),
        ];
        for (n, rate, threads) in runs {
            let run = BenchRun {
                scene: "silo-bed",
                backend: "gpu",
                precision: "f32",
                threads,
                particles: n,
                steps: 500,
                dt_s: 1e-5,
                particle_steps_per_s: rate,
                contacts_per_particle: 5.0,
                state_checksum: "x",
                machine: "test",
            };
            record(&conn, &run).unwrap();
        }
        let at = |particles| {
            newest_rate(
                &conn,
                &RateQuery {
                    scene: "silo-bed",
                    settled_scene: "silo-bed/settled",
                    backend: "gpu",
                    precision: "f32",
                    threads: 2,
                    particles,
                },
            )
        };
        assert_eq!(at(30_144), Some(6.0e8));
        assert_eq!(at(2_000), Some(1.0e8));
        assert_eq!(at(600_000), Some(2.0e9));
        assert_eq!(at(0), Some(1.0e8));
    }

    /// The median over the store's done jobs of the scene, engine, precision and threads; a
    /// short job (setup-bound), a failed one, another precision or the spheres' engine does
    /// not count.
    #[test]
    fn the_store_s_own_jobs_give_the_median_rate() {
        let conn = test_rows::empty_db();
        let c = test_rows::campaign(&conn, "c", "chute", "2026-01-01T00:00:00Z");
        let rods = r#"{"scene":"chute","chute":{"aspect_ratio":2.5}}"#;
        let spheres = r#"{"scene":"chute","chute":{"aspect_ratio":1.0}}"#;
        // (params, status, precision, particle-steps, wall s)
        let rows = [
            (rods, "done", "f32", 1.0e9, 1000.0),
            (rods, "done", "f32", 3.0e9, 1000.0),
            (rods, "done", "f32", 2.0e9, 1000.0),
            (rods, "done", "f32", 1.0e7, 10.0),
            (rods, "failed", "f32", 9.0e9, 1000.0),
            (rods, "done", "f64", 9.0e9, 1000.0),
            (spheres, "done", "f32", 9.0e9, 1000.0),
        ];
        for (k, (p, status, precision, steps, wall)) in rows.iter().enumerate() {
            let id = test_rows::silo_job(&conn, c, &format!("j{k}"), status, p);
            conn.execute(
                "UPDATE jobs SET scene = 'chute', backend = 'cpu', precision = ?2, threads = 1,
                        particle_steps = ?3, wall_time_s = ?4 WHERE id = ?1",
                rusqlite::params![id, precision, *steps as i64, wall],
            )
            .unwrap();
        }
        let q = JobRateQuery {
            scene: "chute",
            spheres: Some(false),
            backend: "cpu",
            precision: "f32",
            threads: 1,
        };
        assert_eq!(measured_rate(&conn, &q), Some((2.0e6, 3)));
        let spheres = JobRateQuery {
            spheres: Some(true),
            ..q.clone()
        };
        assert_eq!(measured_rate(&conn, &spheres), Some((9.0e6, 1)));
        let two = JobRateQuery {
            threads: 2,
            ..q.clone()
        };
        assert_eq!(measured_rate(&conn, &two), None);
        // A job that shared its core counted half its wall time as CPU: per CPU second it
        // ran at 4e6 (2e9 in 500 s). One whose CPU count passes its wall time (the pool's
        // spin beside the caller) is taken at its wall time: 3e9 in 1000 s, the median (not
        // 3e9 in 1100 s).
        conn.execute_batch(
            "UPDATE jobs SET cpu_time_s = 500.0 WHERE particle_steps = 2000000000;
             UPDATE jobs SET cpu_time_s = 1100.0 WHERE particle_steps = 3000000000;",
        )
        .unwrap();
        assert_eq!(measured_rate(&conn, &q), Some((3.0e6, 3)));
    }
}
