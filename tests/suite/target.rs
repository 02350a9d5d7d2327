//! Campaign targets end to end (`"target"` in a campaign file): a tiny refilled silo whose two
//! points are run on and replicated until Q's 95 % interval holds. The rounds stop at each
//! point as soon as its interval is within the target and never add work to a point that
//! already is; the work order and the results are the same run twice and after a kill and
//! `sweep resume`; a job run on from its checkpoint gives the bits of the same job run longer
//! from the start.

use std::path::Path;

use crate::common::cli::*;
use rusqlite::params;
use serde_json::{json, Value};
use sweep::observe::fits::{pool, ReplicaEstimate};
use tempfile::TempDir;

const GOAL: f64 = 0.06;

/// Two points (D = 4.1 d, f = 0 and 1 Hz), 600 particles, 1 s each to start with.
fn tiny_target() -> Value {
    let mut c = campaign("tiny_target", &[0.024], &[0.0, 1.0], 0.2);
    let base = c["base"].as_object_mut().unwrap();
    base.insert("particle_count".into(), json!(600));
    base.insert("discharge_time_s".into(), json!(1.0));
    base.insert("reinsert".into(), json!(true));
    c["target"] = json!({"q_ci95_rel": GOAL, "max_replicas": 3, "max_time_s": 3.0});
    c
}

/// The work a target added, keyed by job hash (ids may differ between databases).
fn work(db: &Path) -> Vec<Vec<String>> {
    rows(
        db,
        "SELECT w.round, w.point, j.hash, w.action, w.from_s, w.to_s, w.ci95_rel_before,
                w.ci95_rel_expected
         FROM target_work w JOIN jobs j ON j.id = w.job_id ORDER BY w.id",
    )
}

fn launch_target(dir: &Path) -> (std::path::PathBuf, String) {
    let file = write_campaign(dir, "t.json", &tiny_target());
    let db = dir.join("sweep.db");
    let o = launch_ok(dir, &file, &db);
    (db, stdout(&o))
}

#[test]
fn each_point_gets_work_until_its_interval_holds_and_no_longer() {
    let dir = TempDir::new().unwrap();
    let (db, out) = launch_target(dir.path());
    let conn = read_db(&db);
    // No work was ever added to a point whose interval already held.
    let mut q = conn
        .prepare("SELECT point, round, ci95_rel_before FROM target_work ORDER BY id")
        .unwrap();
    let added: Vec<(String, i64, Option<f64>)> = q
        .query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))
        .unwrap()
        .collect::<Result<_, _>>()
        .unwrap();
    assert!(!added.is_empty(), "1 s runs cannot reach ±6 %:\n{out}");
    for (point, round, before) in &added {
        assert!(
            before.is_none_or(|b| b > GOAL),
            "round {round} added work to {point} at ±{before:?}, already within the target"
        );
    }
    // Every point ended met, and its interval is the pooled interval of its replicas' Q.
    let mut q = conn
        .prepare("SELECT point, ci95_rel, met, status, replicas FROM target_points")
        .unwrap();
    let points: Vec<(String, Option<f64>, bool, String, i64)> = q
        .query_map([], |r| {
            Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?, r.get(4)?))
        })
        .unwrap()
        .collect::<Result<_, _>>()
        .unwrap();
    assert_eq!(points.len(), 2, "{points:?}");
    for (point, ci, met, status, replicas) in &points {
        assert!(*met && status == "met", "{point}: {status}\n{out}");
        let f = if point.ends_with("=0.0") { 0.0 } else { 1.0 };
        let mut q = conn
            .prepare(
                "SELECT s.q_kg_per_s, s.q_ci95_kg_per_s, s.q_blocks FROM discharge_summary s
                 WHERE s.rotation_frequency_hz = ?1 AND s.q_kg_per_s IS NOT NULL",
            )
            .unwrap();
        let est: Vec<ReplicaEstimate> = q
            .query_map(params![f], |r| {
                Ok(
                    ReplicaEstimate::from_blocks(
                        r.get(0)?,
                        r.get(1)?,
                        r.get::<_, i64>(2)? as usize,
                    )
                    .unwrap(),
                )
            })
            .unwrap()
            .collect::<Result<_, _>>()
            .unwrap();
        assert_eq!(est.len() as i64, *replicas, "{point}");
        let p = pool(&est).unwrap();
        let ci = ci.unwrap();
        assert!(
            (p.ci95_rel() - ci).abs() < 1e-12,
            "{point}: {} vs {ci}",
            p.ci95_rel()
        );
        assert!(ci <= GOAL, "{point}: ±{ci} is not within ±{GOAL}");
    }
    // `sweep plan` forecasts nothing more for points already met.
    let plan = sweep_cmd(dir.path())
        .args(["plan", "t.json", "--db", db.to_str().unwrap()])
        .output()
        .unwrap();
    let plan = stdout(&plan);
    assert_eq!(plan.matches("  met").count(), 2, "{plan}");
    assert!(
        plan.contains("still to run: 0.000e0 particle-steps"),
        "{plan}"
    );
    // The replicas the target added are the campaign's own: the same file launches again.
    let again = launch_ok(dir.path(), &dir.path().join("t.json"), &db);
    assert!(stdout(&again).contains("0 new"), "{}", stdout(&again));
    assert_eq!(
        work(&db).len(),
        added.len(),
        "no work added by a second launch"
    );
}

#[test]
fn the_rounds_take_the_same_work_in_the_same_order_twice_and_after_a_kill() {
    let a = TempDir::new().unwrap();
    let (db_a, _) = launch_target(a.path());
    // Killed once the first round's work is running, then resumed.
    let b = TempDir::new().unwrap();
    let file = write_campaign(b.path(), "t.json", &tiny_target());
    let db_b = b.path().join("sweep.db");
    launch_killed_in_a_round(b.path(), &file, &db_b);
    let o = resume(b.path(), &db_b);
    assert!(o.status.success(), "{}\n{}", stdout(&o), stderr(&o));
    assert_eq!(work(&db_a), work(&db_b), "the target chose other work");
    assert_same_results(&results(&db_a), &results(&db_b));
}

/// The single job of campaign `c` run twice: in A launched to its own end, then run on until
/// its own time is `to_s` (its end `end_s`); in B told to end at `end_s` before it ever ran.
/// Returns both directories (kept alive) and databases.
fn run_on_and_run_longer(c: &Value, to_s: f64, end_s: f64) -> [(TempDir, std::path::PathBuf); 2] {
    let a = TempDir::new().unwrap();
    let file = write_campaign(a.path(), "c.json", c);
    let db_a = a.path().join("sweep.db");
    launch_ok(a.path(), &file, &db_a);
    {
        let mut conn = sweep::store::open(&db_a).unwrap();
        let tx = conn.transaction().unwrap();
        assert!(sweep::store::targets::extend(&tx, 1, to_s, end_s).unwrap());
        tx.commit().unwrap();
    }
    let o = resume(a.path(), &db_a);
    assert!(o.status.success(), "{}\n{}", stdout(&o), stderr(&o));
    let b = TempDir::new().unwrap();
    let file = write_campaign(b.path(), "c.json", c);
    let db_b = b.path().join("sweep.db");
    {
        let (f, jobs) = sweep::campaign::load(&file).unwrap();
        let mut conn = sweep::store::open(&db_b).unwrap();
        sweep::store::jobs::register(&mut conn, "c.json", &f, &jobs, false).unwrap();
        conn.execute("UPDATE jobs SET target_time_s = ?1", [end_s])
            .unwrap();
    }
    let o = resume(b.path(), &db_b);
    assert!(o.status.success(), "{}\n{}", stdout(&o), stderr(&o));
    [(a, db_a), (b, db_b)]
}

#[test]
fn a_job_run_on_gives_the_bits_of_the_job_run_longer_from_the_start() {
    let mut c = one_job(0.1);
    c["base"]["reinsert"] = json!(true);
    // Run to 0.4 s, then on to 0.7 s from its checkpoint; against 0.7 s from the start.
    let [(_a, db_a), (_b, db_b)] = run_on_and_run_longer(&c, 0.7, 0.7);
    let (ra, rb) = (results(&db_a), results(&db_b));
    assert!(
        count(&db_a, "SELECT COUNT(*) FROM jobs WHERE sim_time_s > 0.69") > 0,
        "the run on reached 0.7 s"
    );
    assert_same_results(&ra, &rb);
}

#[test]
fn a_target_that_does_not_fit_the_campaign_is_refused_by_field() {
    let dir = TempDir::new().unwrap();
    let mut c = tiny_target();
    c["target"] = json!({"d_ci95_rel": 0.1, "max_replicas": 0, "max_time_s": 0.5});
    let file = write_campaign(dir.path(), "bad.json", &c);
    let o = sweep_cmd(dir.path())
        .args(["launch", file.to_str().unwrap(), "--db", "x.db"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    for field in [
        "target.q_ci95_rel",
        "target.d_ci95_rel",
        "target.max_replicas",
        "target.max_time_s",
    ] {
        assert!(
            e.contains(&format!("bad.json: {field}")),
            "{field} not named:\n{e}"
        );
    }
    assert!(!dir.path().join("x.db").exists(), "nothing registered");
}

#[test]
fn a_chute_target_adds_replicas_and_stops_at_its_cap() {
    let dir = TempDir::new().unwrap();
    // Too short to be steady: no replica has a D to pool, so the target can only replicate
    // until max_replicas, and says why it stopped.
    let mut c = tiny_chute("tiny_chute_target", "f32", 0.5);
    c["target"] = json!({"d_ci95_rel": 0.5, "max_replicas": 2});
    let file = write_campaign(dir.path(), "c.json", &c);
    let db = dir.path().join("sweep.db");
    let out = stdout(&launch_ok(dir.path(), &file, &db));
    assert_eq!(
        count(&db, "SELECT COUNT(*) FROM jobs WHERE status = 'done'"),
        2,
        "{out}"
    );
    let conn = read_db(&db);
    let (runs, met, status): (i64, bool, String) = conn
        .query_row("SELECT runs, met, status FROM target_points", [], |r| {
            Ok((r.get(0)?, r.get(1)?, r.get(2)?))
        })
        .unwrap();
    assert_eq!((runs, met), (2, false), "{status}");
    assert!(
        status.contains("no estimate after 2 replica(s)"),
        "{status}"
    );
    assert_eq!(
        count(
            &db,
            "SELECT COUNT(*) FROM target_work WHERE action = 'replica'"
        ),
        1
    );
}

/// A chute job's results, keyed by job hash, each cell with its exact bits.
fn chute_results(db: &Path) -> Vec<Vec<Vec<String>>> {
    ["chute_summary", "chute_blocks", "chute_msd", "chute_series", "chute_flow_state"]
        .iter()
        .map(|t| {
            rows(
                db,
                &format!(
                    "SELECT j.hash, j.sim_time_s, t.* FROM {t} t JOIN jobs j ON j.id = t.job_id ORDER BY 1, 3, 4, 5"
                ),
            )
            .into_iter()
            .map(|mut r| {
                r.remove(2); // the row's own job id
                r
            })
            .collect()
        })
        .collect()
}

#[test]
fn a_chute_measurement_run_on_gives_the_bits_of_a_longer_one() {
    // The tiny chute measures 1 s after at most 1 s of waiting; run on to 1.5 s of measurement.
    let c = tiny_chute("tiny_chute_on", "f32", 0.5);
    let [(_a, db_a), (_b, db_b)] = run_on_and_run_longer(&c, 1.5, 2.5);
    let measured: f64 = read_db(&db_a)
        .query_row(
            "SELECT measure_end_s - measure_start_s FROM chute_summary",
            [],
            |r| r.get(0),
        )
        .unwrap();
    assert!(
        (measured - 1.5).abs() < 0.06,
        "measured {measured} s, not 1.5 s"
    );
    assert_eq!(chute_results(&db_a), chute_results(&db_b));
}

#[test]
fn a_replica_added_after_run_ons_runs_as_long_as_its_point() {
    // One point whose single run is run on to max_time_s: the next round can only replicate,
    // and that replica must run to 1.5 s like its sibling, not the file's 1 s (a short
    // replica pooled with a long one widens the interval it was added to narrow).
    let dir = TempDir::new().unwrap();
    let mut c = tiny_target();
    c["sweep"]["rotation_frequency_hz"] = json!([0.0]);
    c["target"] = json!({"q_ci95_rel": 0.001, "max_replicas": 2, "max_time_s": 1.5});
    let file = write_campaign(dir.path(), "t.json", &c);
    let db = dir.path().join("sweep.db");
    let o = launch_ok(dir.path(), &file, &db);
    let replicas = rows(
        &db,
        "SELECT w.to_s, j.target_time_s, j.sim_time_s FROM target_work w
         JOIN jobs j ON j.id = w.job_id WHERE w.action = 'replica'",
    );
    assert_eq!(replicas.len(), 1, "{replicas:?}\n{}", stdout(&o));
    let first = count(
        &db,
        "SELECT COUNT(*) FROM target_work WHERE action = 'extend' AND to_s = 1.5",
    );
    assert_eq!(first, 1, "the first run was run on to max_time_s first");
    let conn = read_db(&db);
    let (to_s, target_s, sim_s): (f64, f64, f64) = conn
        .query_row(
            "SELECT w.to_s, j.target_time_s, j.sim_time_s FROM target_work w
             JOIN jobs j ON j.id = w.job_id WHERE w.action = 'replica'",
            [],
            |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)),
        )
        .unwrap();
    assert_eq!((to_s, target_s), (1.5, 1.5));
    let sibling: f64 = conn
        .query_row(
            "SELECT j.sim_time_s FROM target_work w JOIN jobs j ON j.id = w.job_id
             WHERE w.action = 'extend'",
            [],
            |r| r.get(0),
        )
        .unwrap();
    assert_eq!(sim_s, sibling, "the replica ran as far as the run it joins");
}
