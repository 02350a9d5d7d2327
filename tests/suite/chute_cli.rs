//! The chute study end to end through the `sweep` binary, on a tiny chute (about 130
//! spherocylinders, 4L × 4L, 2 s): launch fills every chute table; the report draws fig2–fig7
//! from them; `plan` prints the job's spherocylinder effects; a job killed with SIGKILL after a
//! checkpoint and resumed gives bitwise the same rows as an uninterrupted run (detector and
//! observer state travel in the checkpoint).

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use rusqlite::types::Value as Sql;
use rusqlite::Connection;
use serde_json::json;
use tempfile::TempDir;

use crate::common::cli::{tiny_chute, write_campaign};

/// The shared tiny chute (`common::cli::tiny_chute`): f64, a checkpoint every 0.25 s.
fn campaign(dir: &Path) -> PathBuf {
    write_campaign(dir, "tiny.json", &tiny_chute("chute_tiny", "f64", 0.25))
}

/// The tiny chute with `base` settings changed, written as `name` in `dir`.
fn campaign_with(dir: &Path, name: &str, base: &[(&str, serde_json::Value)]) -> PathBuf {
    let mut c: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(campaign(dir)).unwrap()).unwrap();
    let fields = c["base"].as_object_mut().unwrap();
    for (k, v) in base {
        fields.insert((*k).into(), v.clone());
    }
    let file = dir.join(name);
    std::fs::write(&file, c.to_string()).unwrap();
    file
}

fn run(dir: &Path, args: &[&str]) -> Output {
    Command::new(crate::common::cli::bin())
        .args(args)
        .current_dir(dir)
        .env_remove("SWEEP_DB")
        .output()
        .unwrap()
}

fn ok(o: &Output) -> String {
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        o.status.success(),
        "sweep failed:\n{out}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    out
}

fn launch_args(file: &Path, db: &Path) -> Vec<String> {
    [
        "launch",
        file.to_str().unwrap(),
        "--db",
        db.to_str().unwrap(),
        "--backend",
        "cpu",
        "--threads",
        "1",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect()
}

/// Every row of every chute table, as text, in a fixed order.
fn chute_rows(db: &Path) -> Vec<String> {
    let conn = Connection::open(db).unwrap();
    let mut out = Vec::new();
    for (table, order) in [
        ("chute_summary", "job_id"),
        ("chute_blocks", "block"),
        ("chute_msd", "block, lag_s"),
        ("chute_fields", "z_m"),
        ("chute_vz_pdf", "block, x"),
        ("chute_correlation", "block, r_m"),
        ("chute_series", "t_s"),
        ("chute_flow_state", "job_id"),
        ("chute_stationarity", "phase"),
    ] {
        let mut st = conn
            .prepare(&format!("SELECT * FROM {table} ORDER BY {order}"))
            .unwrap();
        let n = st.column_count();
        let rows = st
            .query_map([], |r| {
                let v: Vec<String> = (0..n)
                    .map(|k| format!("{:?}", r.get::<_, Sql>(k).unwrap()))
                    .collect();
                Ok(format!("{table}: {}", v.join(" | ")))
            })
            .unwrap();
        out.extend(rows.map(|r| r.unwrap()));
    }
    out
}

fn count(rows: &[String], table: &str) -> usize {
    rows.iter()
        .filter(|r| r.starts_with(&format!("{table}:")))
        .count()
}

#[test]
fn a_tiny_chute_runs_reports_and_resumes_exactly() {
    // Uninterrupted reference.
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let file = campaign(d);
    let db = d.join("sweep.db");
    let args = launch_args(&file, &db);
    ok(&run(
        d,
        &args.iter().map(|s| s.as_str()).collect::<Vec<_>>(),
    ));
    let reference = chute_rows(&db);
    assert_eq!(count(&reference, "chute_summary"), 1);
    assert!(
        count(&reference, "chute_blocks") >= 3,
        "blocks: {reference:?}"
    );
    assert!(count(&reference, "chute_msd") >= 10);
    assert!(count(&reference, "chute_fields") >= 20);
    assert!(count(&reference, "chute_vz_pdf") >= 10);
    assert!(count(&reference, "chute_correlation") >= 5);
    // 20 samples a second for 2 s.
    assert!(count(&reference, "chute_series") >= 39);
    let conn = Connection::open(&db).unwrap();
    let (status, backend): (String, String) = conn
        .query_row("SELECT status, backend FROM jobs", [], |r| {
            Ok((r.get(0)?, r.get(1)?))
        })
        .unwrap();
    assert_eq!((status.as_str(), backend.as_str()), ("done", "cpu"));
    // The flow goes down the slope: positive mean v_x in the bed.
    let vx: f64 = conn
        .query_row(
            "SELECT AVG(velocity_x_m_per_s) FROM chute_blocks WHERE block < 3",
            [],
            |r| r.get(0),
        )
        .unwrap();
    assert!(vx > 0.0, "mean v_x {vx}");

    // Figures from the database.
    let figs = d.join("figs");
    for f in [
        "fig1b",
        "fig2",
        "fig3",
        "fig4",
        "fig5",
        "fig6",
        "fig7",
        "orientation",
        "dy",
    ] {
        let out = ok(&run(
            d,
            &[
                "report",
                "--figure",
                f,
                "--include-unsteady",
                "--db",
                db.to_str().unwrap(),
                "--out",
                figs.to_str().unwrap(),
            ],
        ));
        // 1 s is no steady state: the figure says so, and draws it only because it was asked.
        assert!(out.contains("1 of them NOT steady"), "{out}");
        for ext in ["svg", "png", "csv"] {
            let p = figs.join(format!("chute_{f}.{ext}"));
            assert!(
                std::fs::metadata(&p).map(|m| m.len() > 0).unwrap_or(false),
                "{} missing after `report --figure {f}`:\n{out}",
                p.display()
            );
        }
    }

    // The plan shows the oriented effects.
    let out = ok(&run(d, &["plan", file.to_str().unwrap()]));
    assert!(out.contains("\"shape\":\"spherocylinder\""), "{out}");

    // Killed after a checkpoint, then resumed: the same rows, bit for bit.
    let dir2 = TempDir::new().unwrap();
    let d2 = dir2.path();
    let file2 = campaign(d2);
    let db2 = d2.join("sweep.db");
    let mut child = Command::new(crate::common::cli::bin())
        .args(launch_args(&file2, &db2))
        .current_dir(d2)
        .env_remove("SWEEP_DB")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let jobs = d2.join("sweep-work").join("sweep").join("jobs");
    let t0 = Instant::now();
    let mut seen = false;
    while t0.elapsed() < Duration::from_secs(120) {
        let any = std::fs::read_dir(&jobs)
            .into_iter()
            .flatten()
            .flatten()
            .any(|e| !sweep::checkpoint::list(&e.path()).is_empty());
        if any {
            seen = true;
            break;
        }
        if child.try_wait().unwrap().is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    assert!(
        seen,
        "the job ended before its first checkpoint: lengthen it"
    );
    child.kill().unwrap();
    child.wait().unwrap();
    let o = run(
        d2,
        &[
            "resume",
            "--db",
            db2.to_str().unwrap(),
            "--stale-after",
            "0",
            "--backend",
            "cpu",
            "--threads",
            "1",
        ],
    );
    ok(&o);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("resuming from"), "{err}");
    let got = chute_rows(&db2);
    assert_eq!(got.len(), reference.len());
    for (a, b) in reference.iter().zip(&got) {
        assert_eq!(
            a, b,
            "a resumed chute job differs from an uninterrupted one"
        );
    }
}

/// Jobs that differ only in how they are observed (here the sampling interval, 0.05 s against
/// 0.1 s) share the seed and the engine's chunking, so they follow bitwise the same trajectory:
/// their kinetic-energy series agree at every common time, and only the observer differs.
#[test]
fn observer_only_differences_follow_the_same_trajectory() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let mut c: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(campaign(d)).unwrap()).unwrap();
    c["name"] = json!("chute_sampling");
    c["observers"]["chute"]["max_lag_s"] = json!(0.4);
    c["sweep"] = json!({ "observers.chute.sample_interval_s": [0.05, 0.1] });
    let file = d.join("sampling.json");
    std::fs::write(&file, serde_json::to_string_pretty(&c).unwrap()).unwrap();
    let db = d.join("s.db");
    ok(&run(
        d,
        &launch_args(&file, &db)
            .iter()
            .map(|s| s.as_str())
            .collect::<Vec<_>>(),
    ));
    let conn = Connection::open(&db).unwrap();
    let series = |job: i64| -> Vec<(i64, u64)> {
        let mut st = conn
            .prepare(
                "SELECT t_s, kinetic_energy_j FROM chute_series WHERE job_id = ?1 ORDER BY t_s",
            )
            .unwrap();
        st.query_map([job], |r| {
            // Times on the 0.05 s chunk grid, as whole chunks.
            Ok((
                (r.get::<_, f64>(0)? / 0.05).round() as i64,
                r.get::<_, f64>(1)?.to_bits(),
            ))
        })
        .unwrap()
        .map(|r| r.unwrap())
        .collect()
    };
    let (a, b) = (series(1), series(2));
    assert!(a.len() > 20, "series too short: {}", a.len());
    assert_eq!(
        a, b,
        "the kinetic energy must agree bit for bit at every chunk"
    );
    // The observers did differ: the MSD lags are on each job's own sampling grid.
    let lags = |job: i64| -> f64 {
        conn.query_row(
            "SELECT MIN(lag_s) FROM chute_msd WHERE job_id = ?1 AND lag_s > 0",
            [job],
            |r| r.get(0),
        )
        .unwrap()
    };
    assert!(
        (lags(1) - 0.05).abs() < 1e-3 && (lags(2) - 0.1).abs() < 2e-3,
        "{} {}",
        lags(1),
        lags(2)
    );
}

/// ξ = 1 is a sphere: the job runs on the sphere engine (no orientations, half lists), `plan`
/// says so and times it with the sphere bench, and its chute tables fill as for rods, with
/// d⊥ = d. ξ = 1.01 stays a spherocylinder.
#[test]
fn a_chute_of_spheres_runs_on_the_sphere_engine() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let mut c: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(campaign(d)).unwrap()).unwrap();
    c["base"]["aspect_ratio"] = json!(1.0);
    let file = d.join("spheres.json");
    std::fs::write(&file, c.to_string()).unwrap();
    let out = ok(&run(d, &["plan", file.to_str().unwrap()]));
    assert!(out.contains("\"shape\":\"sphere\""), "{out}");
    assert!(out.contains("--scene chute-bed"), "{out}");
    let db = d.join("sweep.db");
    let args = launch_args(&file, &db);
    ok(&run(
        d,
        &args.iter().map(String::as_str).collect::<Vec<_>>(),
    ));
    let conn = Connection::open(&db).unwrap();
    let (d_perp, length): (f64, f64) = conn
        .query_row("SELECT d_perp_m, 0.125 FROM chute_summary", [], |r| {
            Ok((r.get(0)?, r.get(1)?))
        })
        .unwrap();
    assert!(
        (d_perp - length).abs() < 1e-12,
        "d⊥ = {d_perp} for spheres of d = {length}"
    );
    let blocks: i64 = conn
        .query_row("SELECT COUNT(*) FROM chute_blocks", [], |r| r.get(0))
        .unwrap();
    assert!(blocks > 0, "no D(z) blocks");

    c["base"]["aspect_ratio"] = json!(1.01);
    std::fs::write(&file, c.to_string()).unwrap();
    let out = ok(&run(d, &["plan", file.to_str().unwrap()]));
    assert!(out.contains("\"shape\":\"spherocylinder\""), "{out}");
}

/// A bed below its stopping angle (spheres at 10°) comes to rest after the pour: the job is
/// recorded as not flowing, measures nothing (no summary, no D(z)), stores the criteria that
/// decided it, and `sweep status` and the report say so.
#[test]
fn a_bed_at_rest_is_recorded_as_not_flowing() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let file = campaign_with(
        d,
        "rest.json",
        &[
            ("aspect_ratio", json!(1.0)),
            ("inclination_deg", json!(10.0)),
            ("steady_min_time_s", json!(8.0)),
            ("steady_max_time_s", json!(12.0)),
            ("steady_window_s", json!(2.0)),
            ("measure_unsteady", json!(false)),
        ],
    );
    let db = d.join("sweep.db");
    let args = launch_args(&file, &db);
    ok(&run(
        d,
        &args.iter().map(String::as_str).collect::<Vec<_>>(),
    ));
    let conn = Connection::open(&db).unwrap();
    let (state, measured): (String, i64) = conn
        .query_row("SELECT state, measured FROM chute_flow_state", [], |r| {
            Ok((r.get(0)?, r.get(1)?))
        })
        .unwrap();
    assert_eq!((state.as_str(), measured), ("not_flowing", 0));
    let (phase, vx, flowing, end): (String, f64, i64, f64) = conn
        .query_row(
            "SELECT phase, vx_mean_m_per_s, flowing, end_s FROM chute_stationarity",
            [],
            |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?)),
        )
        .unwrap();
    // 0.05 √(g L) with g = 1 m/s², L = 0.125 m.
    let threshold = 0.05 * 0.125f64.sqrt();
    assert!(
        phase == "transient" && flowing == 0 && vx < threshold,
        "{vx}"
    );
    assert!((8.0..12.0).contains(&end), "decided at {end} s");
    let summaries: i64 = conn
        .query_row("SELECT COUNT(*) FROM chute_summary", [], |r| r.get(0))
        .unwrap();
    assert_eq!(summaries, 0);
    let status = ok(&run(d, &["status", "--db", db.to_str().unwrap()]));
    assert!(status.contains("flow: NOT FLOWING"), "{status}");
    assert!(status.contains("nothing measured"), "{status}");
    let out = ok(&run(
        d,
        &[
            "report",
            "--figure",
            "fig4",
            "--db",
            db.to_str().unwrap(),
            "--out",
            d.join("figs").to_str().unwrap(),
        ],
    ));
    assert!(out.contains("(not flowing, nothing measured)"), "{out}");
}

/// A job still waiting for the steady state past `steady_min_time_s` says, four times a window,
/// which criterion holds it up: each trend's change with its t statistic, and μ against tan α.
#[test]
fn a_long_wait_for_the_steady_state_names_its_criteria() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    // 10 samples a window in 4 batches: a window is tested from 0.5 s on; the young flow
    // still accelerates, so it waits until 1.5 s and measures nothing.
    let file = campaign_with(
        d,
        "wait.json",
        &[
            ("steady_max_time_s", json!(1.5)),
            ("steady_batches", json!(4)),
            ("measure_unsteady", json!(false)),
        ],
    );
    let db = d.join("sweep.db");
    let args = launch_args(&file, &db);
    let launched = run(d, &args.iter().map(String::as_str).collect::<Vec<_>>());
    ok(&launched);
    // The job's log goes to stderr, beside the campaign's progress.
    let out = String::from_utf8_lossy(&launched.stderr);
    let waits: Vec<&str> = out
        .lines()
        .filter(|l| l.contains("not steady yet at t = "))
        .collect();
    // One line per quarter window (0.125 s) from the first tested window until 1.5 s.
    assert!((5..=9).contains(&waits.len()), "{out}");
    assert!(
        waits.iter().all(|l| l.contains("V_x change")
            && l.contains(" of 4.30)")
            && l.contains("tan α = 0.532")),
        "{out}"
    );
}
