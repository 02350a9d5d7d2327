//! Running the `sweep` binary in tests: commands and child processes in a temporary directory,
//! the tiny silo campaign (a few hundred particles, 0.4 s of discharge), reading the database,
//! and waiting for a child to reach some point.

use std::path::{Path, PathBuf};
use std::process::{Child, Output, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use rusqlite::types::Value as Sql;
use rusqlite::{Connection, OpenFlags};
use serde_json::{json, Value};
use sweep::checkpoint;
use tempfile::TempDir;

pub const BIN: &str = env!("CARGO_BIN_EXE_sweep");

/// The binary `sweep_cmd` and `spawn` run: this build's, or the one `SWEEP_TEST_BIN` names (to
/// show that a new test fails on an older build).
pub fn bin() -> String {
    std::env::var("SWEEP_TEST_BIN").unwrap_or_else(|_| BIN.into())
}

/// Longest a test waits for a child process to reach some point.
pub const PATIENCE: Duration = Duration::from_secs(120);

/// A synchronous run of the binary (assert_cmd), without a `SWEEP_DB` from the environment.
pub fn sweep_cmd(dir: &Path) -> assert_cmd::Command {
    let mut c = assert_cmd::Command::new(bin());
    c.current_dir(dir)
        .env_remove("SWEEP_DB")
        .env_remove("SWEEP_ALLOW_SOFTWARE_GPU");
    c
}

/// A child process of the binary, its output sent to `log` (stdout) and `log.err` (stderr).
pub fn spawn(dir: &Path, args: &[&str], log: &str) -> Child {
    let out = std::fs::File::create(dir.join(log)).unwrap();
    let err = std::fs::File::create(dir.join(format!("{log}.err"))).unwrap();
    std::process::Command::new(bin())
        .args(args)
        .current_dir(dir)
        .env_remove("SWEEP_DB")
        .stdin(Stdio::null())
        .stdout(out)
        .stderr(err)
        .spawn()
        .unwrap()
}

/// `sweep launch FILE --db DB --backend cpu --threads 1`, run to completion; fails the test if it fails.
pub fn launch_ok(dir: &Path, file: &Path, db: &Path) -> Output {
    launch_on(dir, file, db, "cpu", 1)
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The tiny silo's `base`: 300 spheres of 5.8 mm in R_c = 3 cm, h = 20 cm, softened (Y = 3 MPa,
/// n_c = 20), 0.4 s of discharge after a fill of at most 0.2 s. Tests change what they need.
pub fn tiny_silo_base() -> Value {
    json!({
        "cylinder_radius_m": 0.03,
        "cylinder_height_m": 0.2,
        "particle_count": 300,
        "youngs_modulus_pa": 3.0e6,
        "shear_modulus_pa": 1.0e5,
        "dt_s": null,
        "contact_steps": 20,
        "discharge_time_s": 0.4,
        "settle_max_time_s": 0.2
    })
}

/// The tiny silo campaign: one job per (orifice, frequency) pair.
pub fn campaign(
    name: &str,
    orifices: &[f64],
    frequencies: &[f64],
    checkpoint_interval_s: f64,
) -> Value {
    json!({
        "name": name,
        "scene": "silo",
        "base": tiny_silo_base(),
        "sweep": { "orifice_diameter_m": orifices, "rotation_frequency_hz": frequencies },
        "observers": { "discharge": { "skip_initial_s": 0.1, "block_s": 0.05 } },
        "run": { "precision": "f64", "checkpoint_interval_s": checkpoint_interval_s }
    })
}

/// The tiny chute (ξ = 1.5, 4 L × 4 L × 4 L, n_c = 10, 1 s to the steady-state test and 1 s of
/// measurement, too short to be steady: measured anyway with `measure_unsteady`): one job, in
/// `precision` ("f64" or "f32").
pub fn tiny_chute(name: &str, precision: &str, checkpoint_interval_s: f64) -> Value {
    json!({
        "name": name,
        "scene": "chute",
        "base": {
            "aspect_ratio": 1.5, "inclination_deg": 28.0,
            "box_x_lengths": 4.0, "box_y_lengths": 4.0, "bed_height_lengths": 4.0,
            "contact_steps": 10.0,
            "steady_min_time_s": 0.5, "steady_max_time_s": 1.0, "steady_window_s": 0.5,
            "measure_time_s": 1.0, "measure_unsteady": true
        },
        "observers": {"chute": {"max_lag_s": 0.3, "fit_min_lag_s": 0.1, "correlation_every": 2}},
        "run": {"precision": precision, "checkpoint_interval_s": checkpoint_interval_s}
    })
}

/// `sweep launch FILE --db DB --backend BACKEND --threads T` (and `--allow-software-gpu` with
/// gpu), run to completion; fails the test if it fails.
pub fn launch_on(dir: &Path, file: &Path, db: &Path, backend: &str, threads: usize) -> Output {
    let o = sweep_cmd(dir)
        .args([
            "launch",
            file.to_str().unwrap(),
            "--db",
            db.to_str().unwrap(),
        ])
        .args(["--backend", backend, "--threads", &threads.to_string()])
        // CI's only adapter is lavapipe, which --backend gpu refuses unless allowed.
        .args(if backend == "gpu" {
            &["--allow-software-gpu"][..]
        } else {
            &[]
        })
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "launch failed:\n{}\n{}",
        stdout(&o),
        stderr(&o)
    );
    o
}

/// The single-job campaign of the kill/resume tests. The checkpoint interval is not part of a
/// job's identity, so every interval gives the same job (and must give the same results).
pub fn one_job(checkpoint_interval_s: f64) -> Value {
    campaign("tiny", &[0.02], &[1.0], checkpoint_interval_s)
}

pub fn write_campaign(dir: &Path, file: &str, c: &Value) -> PathBuf {
    let p = dir.join(file);
    std::fs::write(&p, serde_json::to_string_pretty(c).unwrap()).unwrap();
    p
}

pub fn read_db(db: &Path) -> Connection {
    Connection::open_with_flags(db, OpenFlags::SQLITE_OPEN_READ_ONLY).unwrap()
}

/// A `sweep bench` result of `scene` on `backend` (f32, 1000 particles) at `rate`
/// particle-steps/s, stored in `db` for `sweep plan`'s wall-time estimates.
pub fn bench_row(db: &Path, scene: &str, backend: &str, threads: i64, rate: f64) {
    sweep::store::open(db)
        .unwrap()
        .execute(
            "INSERT INTO bench_runs (scene, backend, precision, threads, particles, steps, dt_s,
                 particle_steps_per_s, contacts_per_particle, state_checksum, machine)
             VALUES (?1, ?2, 'f32', ?3, 1000, 10, 1e-6, ?4, 5.0, 'x', 'test')",
            rusqlite::params![scene, backend, threads, rate],
        )
        .unwrap();
}

pub fn count(db: &Path, sql: &str) -> i64 {
    read_db(db).query_row(sql, [], |r| r.get(0)).unwrap()
}

/// Every row of a query, each cell rendered with its exact bits (reals as their IEEE-754 bit
/// pattern), so that equal renderings mean bitwise-equal results.
pub fn rows(db: &Path, sql: &str) -> Vec<Vec<String>> {
    let conn = read_db(db);
    let mut q = conn.prepare(sql).unwrap();
    let n = q.column_count();
    let out = q
        .query_map([], |r| {
            (0..n)
                .map(|k| {
                    Ok(match r.get::<_, Sql>(k)? {
                        Sql::Real(x) => format!("{x:e} [{:016x}]", x.to_bits()),
                        Sql::Integer(i) => format!("int {i}"),
                        Sql::Text(t) => format!("text {t}"),
                        Sql::Null => "null".into(),
                        Sql::Blob(b) => format!("blob {b:?}"),
                    })
                })
                .collect::<rusqlite::Result<Vec<String>>>()
        })
        .unwrap()
        .collect::<rusqlite::Result<Vec<_>>>()
        .unwrap();
    out
}

/// The results tables of a database, keyed by job hash (not by row id, which may differ).
#[derive(Debug, PartialEq)]
pub struct Results {
    pub jobs: Vec<Vec<String>>,
    pub series: Vec<Vec<String>>,
    pub summary: Vec<Vec<String>>,
    pub clogs: Vec<Vec<String>>,
}

pub fn results(db: &Path) -> Results {
    Results {
        jobs: rows(db, "SELECT hash, status, sim_time_s, target_time_s FROM jobs ORDER BY hash"),
        series: rows(
            db,
            "SELECT j.hash, s.t_s, s.mass_kg, s.count FROM discharge_series s JOIN jobs j ON j.id = s.job_id ORDER BY j.hash, s.t_s",
        ),
        summary: rows(
            db,
            "SELECT j.hash, s.orifice_diameter_m, s.rotation_frequency_hz, s.particle_diameter_m, s.bulk_density_kg_per_m3,
                    s.q_kg_per_s, s.q_ci95_kg_per_s, s.q_method, s.flowing_time_s, s.discharged_mass_kg, s.discharged_count,
                    s.clogs, s.clogged_time_s, s.permanently_clogged
             FROM discharge_summary s JOIN jobs j ON j.id = s.job_id ORDER BY j.hash",
        ),
        clogs: rows(
            db,
            "SELECT j.hash, c.start_s, c.duration_s, c.permanent FROM clogs c JOIN jobs j ON j.id = c.job_id ORDER BY j.hash, c.start_s",
        ),
    }
}

/// Compares two runs' results table by table, so a failure shows which table differs.
pub fn assert_same_results(reference: &Results, got: &Results) {
    assert_eq!(
        reference.jobs, got.jobs,
        "jobs (hash, status, sim_time_s, target_time_s) differ"
    );
    assert_eq!(
        reference.series.len(),
        got.series.len(),
        "discharge_series row counts differ"
    );
    for (a, b) in reference.series.iter().zip(&got.series) {
        assert_eq!(
            a, b,
            "discharge_series rows differ (hash, t_s, mass_kg, count)"
        );
    }
    assert_eq!(reference.summary, got.summary, "discharge_summary differs");
    assert_eq!(reference.clogs, got.clogs, "clogs differ");
}

/// Results of the single-job campaign run without interruption (computed once, shared).
pub fn reference() -> &'static Results {
    static REF: OnceLock<Results> = OnceLock::new();
    REF.get_or_init(|| {
        let dir = TempDir::new().unwrap();
        let file = write_campaign(dir.path(), "tiny.json", &one_job(0.05));
        let db = dir.path().join("sweep.db");
        launch_ok(dir.path(), &file, &db);
        let r = results(&db);
        assert_eq!(
            r.summary.len(),
            1,
            "the reference run has one job with a summary"
        );
        assert!(r.series.len() > 10, "the reference run has an M(t) series");
        r
    })
}

/// `ckpt-<step>.bin` files of every job under a database's work directory, newest last.
pub fn job_checkpoints(dir: &Path) -> Vec<PathBuf> {
    let jobs = dir.join("sweep-work").join("sweep").join("jobs");
    let mut all: Vec<PathBuf> = std::fs::read_dir(&jobs)
        .into_iter()
        .flatten()
        .flatten()
        .flat_map(|e| checkpoint::list(&e.path()))
        .collect();
    all.sort_by_key(|p| p.file_name().map(|n| n.to_owned()));
    all
}

/// Polls until `ready` holds (returns true) or the child exits first (returns false).
pub fn wait_for(child: &mut Child, what: &str, mut ready: impl FnMut() -> bool) -> bool {
    let t0 = Instant::now();
    loop {
        if ready() {
            return true;
        }
        if child.try_wait().unwrap().is_some() {
            return false;
        }
        assert!(t0.elapsed() < PATIENCE, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(5));
    }
}

pub fn kill(child: &mut Child) {
    child.kill().unwrap(); // SIGKILL on Unix
    child.wait().unwrap();
}

/// Starts `sweep launch FILE --db DB` on the CPU with 1 thread (its output in launch.log).
pub fn spawn_launch(dir: &Path, file: &Path, db: &Path) -> Child {
    spawn(
        dir,
        &[
            "launch",
            file.to_str().unwrap(),
            "--db",
            db.to_str().unwrap(),
            "--backend",
            "cpu",
            "--threads",
            "1",
        ],
        "launch.log",
    )
}

/// Starts the single-job campaign in `dir` and SIGKILLs it once a checkpoint of the discharge
/// (not just the shared fill stage) exists. Returns the database path.
pub fn launch_and_kill(dir: &Path, checkpoint_interval_s: f64) -> PathBuf {
    let file = write_campaign(dir, "tiny.json", &one_job(checkpoint_interval_s));
    let db = dir.join("sweep.db");
    let mut child = spawn_launch(dir, &file, &db);
    let seen = wait_for(&mut child, "a discharge checkpoint", || {
        !job_checkpoints(dir).is_empty()
    });
    assert!(
        seen,
        "the job finished before a discharge checkpoint was seen: the kill tests need a longer job"
    );
    kill(&mut child);
    assert_eq!(
        count(&db, "SELECT COUNT(*) FROM jobs WHERE status = 'done'"),
        0,
        "the job was killed, not finished"
    );
    assert_eq!(
        count(&db, "SELECT COUNT(*) FROM discharge_summary"),
        0,
        "no results before the job finishes"
    );
    db
}

pub fn resume(dir: &Path, db: &Path) -> Output {
    sweep_cmd(dir)
        .args([
            "resume",
            "--db",
            db.to_str().unwrap(),
            "--stale-after",
            "0",
            "--backend",
            "cpu",
            "--threads",
            "1",
        ])
        .output()
        .unwrap()
}

/// Launches campaign `file` into `db` (CPU, 1 thread) and returns it once `sql` (a count)
/// is positive. Panics, naming `what`, if the campaign ends before.
pub fn launch_until(dir: &Path, file: &Path, db: &Path, what: &str, sql: &str) -> Child {
    let mut child = spawn_launch(dir, file, db);
    let seen = wait_for(&mut child, what, || {
        db.exists()
            && read_db(db)
                .query_row(sql, [], |r| r.get::<_, i64>(0))
                .unwrap_or(0)
                > 0
    });
    assert!(seen, "the campaign ended before {what}");
    child
}

/// Launches campaign `file` into `db` (CPU, 1 thread) and returns it once work a round added
/// is running past where it started (`target_work`). Panics if the campaign ends before.
pub fn launch_until_a_round_runs(dir: &Path, file: &Path, db: &Path) -> Child {
    launch_until(
        dir,
        file,
        db,
        "a round's work running",
        "SELECT COUNT(*) FROM target_work w JOIN jobs j ON j.id = w.job_id
         WHERE j.status = 'running' AND j.sim_time_s > w.from_s",
    )
}

/// As [`launch_until_a_round_runs`], then SIGKILLed: for resume tests of targets and claims.
pub fn launch_killed_in_a_round(dir: &Path, file: &Path, db: &Path) {
    let mut child = launch_until_a_round_runs(dir, file, db);
    kill(&mut child);
}

/// A job's column as text (NULL as "null"), read while other processes write (and before the
/// store exists).
pub fn job_field(db: &Path, id: i64, column: &str) -> String {
    let Ok(conn) = Connection::open_with_flags(db, OpenFlags::SQLITE_OPEN_READ_ONLY) else {
        return "null".into();
    };
    conn.query_row(
        &format!("SELECT COALESCE(CAST({column} AS TEXT), 'null') FROM jobs WHERE id = ?1"),
        [id],
        |r| r.get(0),
    )
    .unwrap_or_else(|_| "null".into())
}

/// Sends `sig` ("-TERM", "-USR1", …) to a child.
pub fn signal(child: &Child, sig: &str) {
    let ok = std::process::Command::new("kill")
        .args([sig, &child.id().to_string()])
        .status()
        .unwrap()
        .success();
    assert!(ok, "kill {sig} failed");
}

/// A command's stdout and stderr, for messages and searches.
pub fn text(o: &Output) -> String {
    format!("{}\n{}", stdout(o), stderr(o))
}
