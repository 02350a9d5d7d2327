//! Faults a cluster user meets, each with real processes: a running job whose directory is
//! deleted is not run twice; a SIGTERM stops the placing of a large bed at once and a fill
//! goes on from its own checkpoint; too many threads fail the job with the reason; exit codes
//! say that failed jobs remain or that the disk is full; −0 and 0 are one job (typos no
//! experiment has are refused by field in `cli.rs`); temp files of killed writers are removed;
//! a damaged store is refused before anything runs; a large campaign's status is a summary; and
//! Slurm arrays are split at MaxArraySize.

use std::path::Path;
use std::time::{Duration, Instant};

use crate::common::cli::*;
use serde_json::{json, Value};
use tempfile::TempDir;

/// A one-job tiny silo discharging for `discharge_s`, checkpointed every `every_s`.
fn one(name: &str, discharge_s: f64, every_s: f64) -> Value {
    let mut c = campaign(name, &[0.02], &[1.0], every_s);
    c["base"]["discharge_time_s"] = json!(discharge_s);
    c
}

#[test]
fn a_running_job_whose_directory_is_deleted_is_not_run_twice() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let file = write_campaign(d, "c.json", &one("gone_dir", 3.0, 0.2));
    let db = d.join("sweep.db");
    let mut child = spawn_launch(d, &file, &db);
    let jobs = d.join("sweep-work").join("sweep").join("jobs");
    let running = wait_for(&mut child, "the discharge", || {
        job_field(&db, 1, "stage") == "discharge"
    });
    assert!(running, "the launch ended before its discharge was seen");
    std::fs::remove_dir_all(&jobs).unwrap();
    let o = resume(d, &db);
    let out = text(&o);
    assert!(
        out.contains("job 1 left alone: running in process"),
        "the process that holds the job lives, though its lock file is gone:\n{out}"
    );
    assert!(
        !out.contains("job 1 started"),
        "resume ran the job again:\n{out}"
    );
    assert!(child.wait().unwrap().success(), "the launch failed");
    assert_eq!(job_field(&db, 1, "status"), "done");
    assert_eq!(job_field(&db, 1, "attempts"), "1", "one attempt, one run");
}

#[test]
fn a_sigterm_while_a_large_bed_is_placed_stops_within_seconds() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    // 10⁶ spheres in a wide silo: placing them alone takes longer than the patience below.
    let mut c = one("large_bed", 1.0, 0.2);
    c["base"]["particle_count"] = json!(1_000_000);
    c["base"]["cylinder_radius_m"] = json!(0.3);
    c["base"]["cylinder_height_m"] = json!(1.5);
    c["base"]["orifice_diameter_m"] = json!(0.04);
    c["run"]["precision"] = json!("f32");
    c["sweep"] = json!({});
    let file = write_campaign(d, "c.json", &c);
    let db = d.join("sweep.db");
    let mut child = spawn_launch(d, &file, &db);
    let filling = wait_for(&mut child, "the fill", || {
        job_field(&db, 1, "stage") == "fill"
    });
    assert!(filling, "the launch ended before its fill was seen");
    std::thread::sleep(Duration::from_millis(300));
    let t = Instant::now();
    signal(&child, "-TERM");
    let code = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s.code();
        }
        if t.elapsed() > Duration::from_secs(20) {
            kill(&mut child);
            panic!("a SIGTERM during the placing of the bed was ignored for 20 s");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    assert_eq!(code, Some(75), "an interrupted launch exits 75");
    assert_eq!(job_field(&db, 1, "status"), "paused");
}

#[test]
fn a_fill_cut_by_sigterm_goes_on_from_its_checkpoint_to_the_same_bits() {
    // The reference: the same job, never interrupted.
    let (a, b) = (TempDir::new().unwrap(), TempDir::new().unwrap());
    let mut c = one("fill_ckpt", 0.4, 0.02);
    c["base"]["particle_count"] = json!(1500);
    c["base"]["settle_max_time_s"] = json!(1.0);
    let file = write_campaign(a.path(), "c.json", &c);
    launch_ok(a.path(), &file, &a.path().join("sweep.db"));
    let reference = results(&a.path().join("sweep.db"));

    let d = b.path();
    let file = write_campaign(d, "c.json", &c);
    let db = d.join("sweep.db");
    let mut child = spawn_launch(d, &file, &db);
    let stages = d.join("sweep-work").join("sweep").join("stages");
    let settling_checkpoint = || {
        std::fs::read_dir(&stages)
            .into_iter()
            .flatten()
            .flatten()
            .any(|e| !sweep::checkpoint::list(&e.path().join("settling")).is_empty())
    };
    let seen = wait_for(
        &mut child,
        "a checkpoint of the settling",
        settling_checkpoint,
    );
    assert!(seen, "the fill ended before it was checkpointed");
    signal(&child, "-TERM");
    assert_eq!(child.wait().unwrap().code(), Some(75));
    assert_eq!(job_field(&db, 1, "status"), "paused");
    // The settling checkpoint carries the fill's CPU time so far, and the job ends with more.
    let settled_cpu = std::fs::read_dir(&stages)
        .unwrap()
        .flatten()
        .flat_map(|e| sweep::checkpoint::list(&e.path().join("settling")))
        .filter_map(|p| {
            let (_, _, extra) =
                sweep::checkpoint::decode(&std::fs::read(p).ok()?, "ckpt", None).ok()?;
            serde_json::from_str::<serde_json::Value>(&extra).ok()?["cpu_time_s"].as_f64()
        })
        .fold(0.0, f64::max);
    assert!(settled_cpu > 0.0, "no CPU time in the settling checkpoint");
    let o = resume(d, &db);
    let out = text(&o);
    assert!(o.status.success(), "resume failed:\n{out}");
    assert!(
        out.contains("settling goes on from"),
        "the fill must go on from its checkpoint, not start again:\n{out}"
    );
    let cpu: f64 = job_field(&db, 1, "cpu_time_s").parse().unwrap();
    assert!(cpu > settled_cpu, "{cpu} s after a fill of {settled_cpu} s");
    assert_same_results(&reference, &results(&db));
}

#[test]
fn more_threads_than_the_system_allows_fail_the_job_with_the_reason() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    write_campaign(d, "c.json", &one("threads", 0.2, 0.2));
    let db = d.join("sweep.db");
    // 1024 thread stacks do not fit in 1.5 GB of address space (root ignores `ulimit -u`).
    let o = std::process::Command::new("bash")
        .current_dir(d)
        .args([
            "-c",
            &format!(
                "ulimit -v 1500000 && exec {} launch c.json --db sweep.db --backend cpu --threads 1024",
                bin()
            ),
        ])
        .env_remove("SWEEP_DB")
        .output()
        .unwrap();
    let out = text(&o);
    assert_eq!(o.status.code(), Some(1), "a failed job exits 1:\n{out}");
    assert!(!out.contains("panicked"), "no panic:\n{out}");
    assert!(
        out.contains("cannot start 1024 CPU engine thread(s)"),
        "the job says what failed:\n{out}"
    );
    assert_eq!(job_field(&db, 1, "status"), "failed");
    assert!(job_field(&db, 1, "last_error").contains("--threads"));
}

#[test]
fn resume_exits_1_while_failed_jobs_remain() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let mut c = one("spent", 0.2, 0.2);
    c["run"]["max_attempts"] = json!(1);
    let file = write_campaign(d, "c.json", &c);
    let db = d.join("sweep.db");
    launch_ok(d, &file, &db);
    // A job that failed on its last attempt, as a crash would leave it.
    let conn = rusqlite::Connection::open(&db).unwrap();
    conn.execute(
        "UPDATE jobs SET status = 'failed', attempts = 1, last_error = 'made to fail'",
        [],
    )
    .unwrap();
    drop(conn);
    let o = resume(d, &db);
    let out = text(&o);
    assert_eq!(o.status.code(), Some(1), "a failed job remains:\n{out}");
    assert!(out.contains("failed with no attempts left"), "{out}");
}

/// Runs `f` with a tmpfs of `size` mounted at `at`, unmounted after (even on a panic). `None`
/// where mounting is not allowed (not root, no mount namespace): the test then says so and
/// passes, except under CI=true, where it fails.
fn with_tmpfs<T>(at: &Path, size: &str, f: impl FnOnce() -> T) -> Option<T> {
    struct Unmount<'a>(&'a Path);
    impl Drop for Unmount<'_> {
        fn drop(&mut self) {
            let _ = std::process::Command::new("umount").arg(self.0).status();
        }
    }
    std::fs::create_dir_all(at).unwrap();
    let mounted = std::process::Command::new("mount")
        .args(["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs"])
        .arg(at)
        .output()
        .is_ok_and(|o| o.status.success());
    if !mounted {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "CI=true and no tmpfs can be mounted (the full-disk test needs root)"
        );
        eprintln!("skipped: cannot mount a tmpfs here (not root?)");
        return None;
    }
    let _guard = Unmount(at);
    Some(f())
}

#[test]
fn a_full_disk_exits_1_and_leaves_the_jobs_resumable() {
    let dir = TempDir::new().unwrap();
    let disk = dir.path().join("disk");
    let _ = with_tmpfs(&disk, "400k", || {
        let file = write_campaign(&disk, "c.json", &one("full", 0.2, 0.05));
        let db = disk.join("sweep.db");
        let o = sweep_cmd(&disk)
            .args(["launch", "c.json", "--db", "sweep.db", "--backend", "cpu"])
            .args(["--threads", "1"])
            .output()
            .unwrap();
        let out = text(&o);
        assert_eq!(
            o.status.code(),
            Some(1),
            "a full disk is a failure, not bad input:\n{out}"
        );
        assert!(out.contains("No space left on device"), "{out}");
        assert!(out.contains("sweep resume"), "it says how to go on:\n{out}");
        let status = job_field(&db, 1, "status");
        assert!(status != "running", "no job is left running: {status}");
        // Room again: the same job runs to its end.
        let grown = std::process::Command::new("mount")
            .args(["-o", "remount,size=8m"])
            .arg(&disk)
            .status()
            .unwrap()
            .success();
        assert!(grown);
        let o = resume(&disk, &db);
        assert!(o.status.success(), "resume:\n{}", text(&o));
        assert_eq!(job_field(&db, 1, "status"), "done");
        assert!(file.exists());
    });
}

#[test]
fn minus_zero_and_zero_are_one_job() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    // −0 Hz and 0 Hz are one bottom at rest: one job.
    let mut c = one("zeros", 0.2, 0.2);
    c["sweep"]["rotation_frequency_hz"] = json!([0.0, -0.0]);
    let file = write_campaign(d, "z.json", &c);
    let db = d.join("z.db");
    launch_ok(d, &file, &db);
    assert_eq!(
        count(&db, "SELECT COUNT(*) FROM jobs"),
        1,
        "one physics, one job"
    );
    let o = sweep_cmd(d)
        .args([
            "launch",
            file.to_str().unwrap(),
            "--db",
            db.to_str().unwrap(),
        ])
        .args(["--backend", "cpu", "--threads", "1"])
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "launching it again adds nothing:\n{}",
        text(&o)
    );
}

#[test]
fn temp_files_of_a_killed_checkpoint_write_are_removed() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let db = launch_and_kill(d, 0.05);
    let ckpt = job_checkpoints(d).pop().expect("a checkpoint");
    let leftover = ckpt.with_extension("tmp.999999");
    std::fs::write(&leftover, b"half a checkpoint").unwrap();
    let o = resume(d, &db);
    assert!(o.status.success(), "resume:\n{}", text(&o));
    assert!(
        !leftover.exists(),
        "the leftover {} is still there",
        leftover.display()
    );
}

#[test]
fn a_damaged_store_is_refused_before_anything_runs() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let file = write_campaign(d, "c.json", &campaign("damaged", &[0.02], &[0.0, 1.0], 0.2));
    let db = d.join("sweep.db");
    launch_ok(d, &file, &db);
    // Fold the log into the file, then break the b-tree page of the jobs table's hash index:
    // a page no launch reads until it looks a job up by hash.
    let conn = rusqlite::Connection::open(&db).unwrap();
    conn.pragma_update(None, "journal_mode", "DELETE").unwrap();
    let root: i64 = conn
        .query_row(
            "SELECT rootpage FROM sqlite_master WHERE tbl_name = 'jobs' AND type = 'index' AND sql IS NULL",
            [],
            |r| r.get(0),
        )
        .unwrap();
    let page: i64 = conn
        .query_row("PRAGMA page_size", [], |r| r.get(0))
        .unwrap();
    drop(conn);
    let mut bytes = std::fs::read(&db).unwrap();
    let at = ((root - 1) * page) as usize;
    // The page's cell count (bytes 3–4 of a b-tree page header) beyond any page's room.
    bytes[at + 3] = 0xff;
    bytes[at + 4] = 0xff;
    std::fs::write(&db, &bytes).unwrap();
    let before = std::fs::read(&db).unwrap();
    for args in [
        vec!["resume", "--db", "sweep.db"],
        vec!["launch", "c.json", "--db", "sweep.db"],
    ] {
        let o = sweep_cmd(d).args(&args).output().unwrap();
        let out = text(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}:\n{out}");
        assert!(
            out.contains("the database is damaged") && out.contains(".recover"),
            "{args:?} says what is wrong and what to do:\n{out}"
        );
    }
    // Opening switches the file back to WAL (header bytes 18–19); the pages are untouched.
    let after = std::fs::read(&db).unwrap();
    assert!(
        after[100..] == before[100..],
        "the store's pages are left as they were"
    );
}

#[test]
fn status_of_a_large_campaign_is_a_summary() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let mut c = one("large", 0.2, 0.2);
    c["replicas"] = json!(500);
    let file = write_campaign(d, "c.json", &c);
    let db = d.join("sweep.db");
    let (parsed, jobs) = sweep::campaign::load(&file).unwrap();
    let mut conn = sweep::store::open(&db).unwrap();
    sweep::store::jobs::register(&mut conn, "c.json", &parsed, &jobs, false).unwrap();
    drop(conn);
    let o = sweep_cmd(d)
        .args(["status", "--db", db.to_str().unwrap()])
        .output()
        .unwrap();
    let out = stdout(&o);
    assert!(o.status.success());
    assert!(
        out.contains("500 jobs — 0 done, 0 running, 500 pending"),
        "{out}"
    );
    assert!(out.contains("`--all-jobs` lists every one"), "{out}");
    assert!(
        out.lines().count() < 20,
        "a summary, not a line per job:\n{out}"
    );
    let o = sweep_cmd(d)
        .args(["status", "--db", db.to_str().unwrap(), "--all-jobs"])
        .output()
        .unwrap();
    assert!(
        stdout(&o).lines().count() > 500,
        "--all-jobs lists them all"
    );
}

#[test]
fn a_slurm_submission_of_thousands_of_jobs_is_split_at_max_array_size() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let mut c = one("thousands", 0.2, 0.2);
    c["replicas"] = json!(2500);
    let file = write_campaign(d, "c.json", &c);
    let o = sweep_cmd(d)
        .args(["launch", file.to_str().unwrap(), "--db", "sweep.db"])
        .args(["--executor", "slurm", "--dry-run"])
        .output()
        .unwrap();
    let out = text(&o);
    assert!(o.status.success(), "{out}");
    // MaxArraySize: this machine's Slurm's, or Slurm's default (1001).
    let arrays: Vec<usize> = out
        .lines()
        .filter_map(|l| l.strip_prefix("#SBATCH --array=0-"))
        .map(|n| n.split('%').next().unwrap().parse::<usize>().unwrap() + 1)
        .collect();
    let max = sweep::runner::slurm::query::max_array_size();
    assert_eq!(
        arrays.len(),
        2500usize.div_ceil(max),
        "arrays of at most {max}: {arrays:?}"
    );
    assert!(arrays.iter().all(|&n| n <= max), "{arrays:?}");
    assert_eq!(
        arrays.iter().sum::<usize>(),
        2500,
        "every job once: {arrays:?}"
    );
    assert!(!d.join("sweep.db").exists(), "a dry run registers nothing");
}
