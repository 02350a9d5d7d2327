//! A tiny chute job (`common::cli::tiny_chute`) killed while it measures and resumed through the
//! `sweep` binary: from its own checkpoint, every chute row equals an uninterrupted run's, the
//! per-block orientation and D_y included; from the same checkpoint rewritten as the build
//! before those accumulators wrote it (the observer's `orientation` and `lateral` removed from
//! the progress record, the file re-encoded with its checksum), it resumes, stores those four
//! columns NULL and every other value bit for bit.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use rusqlite::types::Value as Sql;
use rusqlite::Connection;

use crate::common::cli::{tiny_chute, write_campaign};

/// The columns added in schema 13, blank in a job resumed from an older checkpoint.
const NEW_COLUMNS: [&str; 4] = [
    "nematic_order_s2",
    "mean_abs_cos_flow",
    "diffusion_y_m2_per_s",
    "diffusion_y_stderr_m2_per_s",
];

fn sweep(dir: &Path) -> Command {
    let mut c = Command::new(crate::common::cli::bin());
    c.current_dir(dir).env_remove("SWEEP_DB");
    c
}

fn launch_args(file: &Path, db: &Path) -> Vec<String> {
    let (f, d) = (file.to_str().unwrap(), db.to_str().unwrap());
    ["launch", f, "--db", d, "--backend", "cpu", "--threads", "1"]
        .map(String::from)
        .to_vec()
}

fn check(o: &std::process::Output) {
    assert!(
        o.status.success(),
        "sweep failed:\n{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// Every row of the chute result tables as (table, column, value) text, in a fixed order; the
/// schema-13 columns of `chute_blocks` are collected apart.
fn rows(db: &Path) -> (Vec<String>, Vec<Sql>) {
    let conn = Connection::open(db).unwrap();
    let (mut out, mut new) = (Vec::new(), Vec::new());
    for (table, order) in [
        ("chute_summary", "job_id"),
        ("chute_blocks", "block"),
        ("chute_msd", "block, lag_s"),
        ("chute_fields", "z_m"),
        ("chute_vz_pdf", "block, x"),
        ("chute_correlation", "block, r_m"),
        ("chute_series", "t_s"),
        ("chute_flow_state", "job_id"),
    ] {
        let mut st = conn
            .prepare(&format!("SELECT * FROM {table} ORDER BY {order}"))
            .unwrap();
        let names: Vec<String> = st.column_names().iter().map(|s| s.to_string()).collect();
        let mut q = st.query([]).unwrap();
        while let Some(r) = q.next().unwrap() {
            for (k, name) in names.iter().enumerate() {
                let v: Sql = r.get(k).unwrap();
                if table == "chute_blocks" && NEW_COLUMNS.contains(&name.as_str()) {
                    new.push(v);
                } else {
                    out.push(format!("{table}.{name} = {v:?}"));
                }
            }
        }
    }
    (out, new)
}

/// Launches the tiny chute in `dir` and kills it once it has written a checkpoint while
/// measuring (its observer in the progress record); returns the job's directory.
fn killed_while_measuring(dir: &Path) -> PathBuf {
    let file = write_campaign(dir, "tiny.json", &tiny_chute("chute_tiny", "f64", 0.25));
    let db = dir.join("sweep.db");
    let mut child = sweep(dir)
        .args(launch_args(&file, &db))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let jobs = dir.join("sweep-work").join("sweep").join("jobs");
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_secs(300) {
        for e in std::fs::read_dir(&jobs).into_iter().flatten().flatten() {
            if sweep::checkpoint::list(&e.path())
                .iter()
                .any(|p| observer_of(p).is_some_and(|o| !o.is_null()))
            {
                child.kill().unwrap();
                child.wait().unwrap();
                return e.path();
            }
        }
        if child.try_wait().unwrap().is_some() {
            panic!("the job ended before a checkpoint while measuring: lengthen it");
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    panic!("no checkpoint while measuring within 300 s");
}

/// The `observer` of a checkpoint's progress record (None when unreadable).
fn observer_of(path: &Path) -> Option<serde_json::Value> {
    let bytes = std::fs::read(path).ok()?;
    let (_, _, extra) = sweep::checkpoint::decode(&bytes, "ckpt", None).ok()?;
    let mut v: serde_json::Value = serde_json::from_str(&extra).ok()?;
    Some(v["observer"].take())
}

/// Rewrites every checkpoint of `job_dir` whose observer measures as the previous build wrote
/// it: without `orientation` and `lateral` (and the z MSD as it was: it never had more).
fn as_previous_build(job_dir: &Path) -> usize {
    let mut rewritten = 0;
    for path in sweep::checkpoint::list(job_dir) {
        let bytes = std::fs::read(&path).unwrap();
        let (h, s, extra) = sweep::checkpoint::decode(&bytes, "ckpt", None).unwrap();
        let mut v: serde_json::Value = serde_json::from_str(&extra).unwrap();
        let Some(obs) = v["observer"].as_object_mut() else {
            continue;
        };
        assert!(obs.remove("orientation").is_some() && obs.remove("lateral").is_some());
        // Nor did it count CPU time (the ledger is flattened into the progress record).
        assert!(v.as_object_mut().unwrap().remove("cpu_time_s").is_some());
        let text = serde_json::to_string(&v).unwrap();
        sweep::checkpoint::write_atomic(&path, &sweep::checkpoint::encode(&h, &s, &text)).unwrap();
        rewritten += 1;
    }
    rewritten
}

fn resume(dir: &Path) {
    let db = dir.join("sweep.db");
    let o = sweep(dir)
        .args(["resume", "--db", db.to_str().unwrap(), "--stale-after", "0"])
        .args(["--backend", "cpu", "--threads", "1"])
        .output()
        .unwrap();
    check(&o);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("resuming from"), "{err}");
}

/// Law: resume gives the same bytes, and an older checkpoint gives the same bytes but for the
/// values it cannot have. The reference measures S2, ⟨|cos θ|⟩ (rods, ξ = 1.5) and D_y in some
/// block (not D_y's window error: 1 s of measurement is shorter than M windows of the longest
/// fitted lag, and D_z has none either); the job resumed from its own mid-measurement checkpoint equals it row for row,
/// column for column; resumed from the previous build's checkpoint, every old column equals
/// it and the four new ones are NULL. A failure means the new accumulators are not in the
/// checkpoint, change the old results, or an old checkpoint is refused.
#[test]
fn a_chute_resumes_from_checkpoints_of_this_and_the_previous_build() {
    let reference = tempfile::TempDir::new().unwrap();
    let d = reference.path();
    let file = write_campaign(d, "tiny.json", &tiny_chute("chute_tiny", "f64", 0.25));
    check(
        &sweep(d)
            .args(launch_args(&file, &d.join("sweep.db")))
            .output()
            .unwrap(),
    );
    let (old_ref, new_ref) = rows(&d.join("sweep.db"));
    assert!(old_ref.len() > 100, "{} values", old_ref.len());
    let measured = |v: &[Sql], col: usize| {
        v.chunks(4)
            .filter(|c| matches!(c[col], Sql::Real(_)))
            .count()
    };
    // 1 s of measurement is too short for window errors (D_z has none either).
    for (col, name) in NEW_COLUMNS.iter().enumerate().take(3) {
        assert!(measured(&new_ref, col) > 0, "{name} never measured");
    }

    let same = tempfile::TempDir::new().unwrap();
    killed_while_measuring(same.path());
    resume(same.path());
    let (old_same, new_same) = rows(&same.path().join("sweep.db"));
    assert_eq!(old_same, old_ref, "resumed from this build's checkpoint");
    assert_eq!(
        new_same, new_ref,
        "the new columns, resumed from this build's checkpoint"
    );
    let cpu = |d: &Path| crate::common::cli::job_field(&d.join("sweep.db"), 1, "cpu_time_s");
    assert!(
        cpu(same.path()).parse::<f64>().is_ok_and(|c| c > 0.0),
        "a job resumed from its own checkpoint counts its CPU time: {}",
        cpu(same.path())
    );

    let previous = tempfile::TempDir::new().unwrap();
    let job_dir = killed_while_measuring(previous.path());
    assert!(as_previous_build(&job_dir) >= 1);
    resume(previous.path());
    let (old_prev, new_prev) = rows(&previous.path().join("sweep.db"));
    assert_eq!(
        old_prev, old_ref,
        "resumed from the previous build's checkpoint"
    );
    assert_eq!(new_prev.len(), new_ref.len());
    assert!(
        new_prev.iter().all(|v| *v == Sql::Null),
        "a job resumed from an older checkpoint stores the new columns NULL: {new_prev:?}"
    );
    // Its CPU time is partly unknown: stored NULL, not as the part counted after the resume.
    assert_eq!(cpu(previous.path()), "null");
}
