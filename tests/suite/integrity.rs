//! Campaign integrity with real processes and real signals: a killed job is resumed at once and
//! never run twice, a job whose process keeps dying ends failed, signals stop the fill, an
//! edited campaign never mixes into old results, bad command lines and read-only stores are
//! refused by name, and exit codes and records say what happened.

use std::path::Path;

use crate::common::cli::*;
use serde_json::{json, Value};
use tempfile::TempDir;

/// A one-job silo whose fill stage lasts seconds on one thread (1500 particles settling for up
/// to 1.5 s of simulated time), long enough to act on a job while it fills.
fn slow_fill(name: &str, max_attempts: u32) -> Value {
    let mut c = campaign(name, &[0.02], &[1.0], 0.05);
    c["base"]["particle_count"] = json!(1500);
    c["base"]["settle_max_time_s"] = json!(1.5);
    c["run"]["max_attempts"] = json!(max_attempts);
    c
}

fn launch_args<'a>(file: &'a Path, db: &'a Path) -> Vec<&'a str> {
    vec![
        "launch",
        file.to_str().unwrap(),
        "--db",
        db.to_str().unwrap(),
        "--backend",
        "cpu",
        "--threads",
        "1",
    ]
}

fn resume_args(db: &Path) -> Vec<&str> {
    vec![
        "resume",
        "--db",
        db.to_str().unwrap(),
        "--backend",
        "cpu",
        "--threads",
        "1",
    ]
}

/// The fill stage's checkpoints under the default work directory of `dir/sweep.db`.
fn fill_checkpoints(dir: &Path) -> usize {
    let stages = dir.join("sweep-work").join("sweep").join("stages");
    std::fs::read_dir(stages)
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| sweep::checkpoint::list(&e.path()).len())
        .sum()
}

// 1. kill -9, then resume at once.

#[test]
fn resume_right_after_kill_finishes_the_killed_job() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let file = write_campaign(
        d,
        "two.json",
        &campaign("two", &[0.02, 0.025], &[1.0], 0.05),
    );
    let db = d.join("sweep.db");
    let mut child = spawn(d, &launch_args(&file, &db), "launch.log");
    let seen = wait_for(&mut child, "job 1's discharge checkpoint", || {
        !job_checkpoints(d).is_empty()
    });
    assert!(seen, "the launch ended before job 1 wrote a checkpoint");
    kill(&mut child);
    assert_eq!(job_field(&db, 1, "status"), "running");

    // At once: the heartbeat is fresh, but the killed process's lock is gone with it.
    let o = sweep_cmd(d).args(resume_args(&db)).output().unwrap();
    let out = text(&o);
    assert!(o.status.success(), "resume failed:\n{out}");
    assert!(
        out.contains("job 1 resumed: its process"),
        "resume must say it resumes the killed job and why:\n{out}"
    );
    assert!(out.contains("2 job(s) done"), "{out}");
    assert_eq!(
        count(&db, "SELECT COUNT(*) FROM jobs WHERE status = 'done'"),
        2,
        "both jobs done:\n{out}"
    );
    assert_eq!(count(&db, "SELECT COUNT(*) FROM discharge_summary"), 2);
}

// 2. A resume while another process fills does not run the job a second time.

#[test]
fn a_resume_during_a_long_fill_leaves_the_filling_job_alone() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let file = write_campaign(d, "slow.json", &slow_fill("slow", 3));
    let db = d.join("sweep.db");
    let mut child = spawn(d, &launch_args(&file, &db), "launch.log");
    let filling = wait_for(&mut child, "the fill stage", || {
        job_field(&db, 1, "stage") == "fill"
    });
    assert!(filling, "the launch ended before its fill stage was seen");
    // Longer than --stale-after below, with no chunk (and no progress heartbeat) in the fill.
    std::thread::sleep(std::time::Duration::from_millis(600));
    assert_eq!(
        fill_checkpoints(d),
        0,
        "the fill must still be running for this test to mean anything"
    );
    let mut args = resume_args(&db);
    args.extend(["--stale-after", "0.2"]);
    let o = sweep_cmd(d).args(args).output().unwrap();
    let out = text(&o);
    assert!(o.status.success(), "resume failed:\n{out}");
    assert!(
        out.contains("job 1 left alone: running in process"),
        "resume must leave the filling job to its process and say so:\n{out}"
    );
    assert!(!out.contains("started"), "resume ran the job again:\n{out}");
    let status = child.wait().unwrap();
    assert!(status.success(), "the launch failed");
    assert_eq!(job_field(&db, 1, "status"), "done");
    assert_eq!(job_field(&db, 1, "attempts"), "1", "one attempt, one run");
}

// 3. A job whose process keeps dying ends failed after its attempts.

#[test]
fn a_job_whose_process_keeps_dying_is_failed_after_max_attempts() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let file = write_campaign(d, "dies.json", &slow_fill("dies", 2));
    let db = d.join("sweep.db");
    // Attempt 1: the launch, killed while it runs the job.
    let mut child = spawn(d, &launch_args(&file, &db), "launch.log");
    assert!(wait_for(&mut child, "attempt 1", || job_field(
        &db, 1, "stage"
    ) == "fill"));
    kill(&mut child);
    // Attempt 2: a resume, killed the same way.
    let mut child = spawn(d, &resume_args(&db), "resume.log");
    assert!(wait_for(&mut child, "attempt 2", || {
        job_field(&db, 1, "attempts") == "2" && job_field(&db, 1, "status") == "running"
    }));
    kill(&mut child);
    // No attempt left: the job is failed with the cause, and nothing runs.
    let o = sweep_cmd(d).args(resume_args(&db)).output().unwrap();
    let out = text(&o);
    assert_eq!(o.status.code(), Some(1), "a failed job exits 1:\n{out}");
    assert!(!out.contains("started"), "a spent job ran again:\n{out}");
    assert_eq!(job_field(&db, 1, "status"), "failed");
    assert_eq!(
        job_field(&db, 1, "attempts"),
        "2",
        "attempts never exceed 2"
    );
    let error = job_field(&db, 1, "last_error");
    assert!(
        error.contains("is gone") && error.contains("no attempts left (2 of 2)"),
        "the cause is kept: {error}"
    );
    let o = sweep_cmd(d)
        .args(["status", "--db", db.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        stdout(&o).contains("no attempts left (2 of 2)"),
        "status says why:\n{}",
        stdout(&o)
    );
}

// 4. SIGTERM during the fill stops the fill; the job is paused, and resumes.

#[test]
fn sigterm_during_the_fill_pauses_the_job_at_once() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let file = write_campaign(d, "slow.json", &slow_fill("slow", 3));
    let db = d.join("sweep.db");
    let mut child = spawn(d, &launch_args(&file, &db), "launch.log");
    assert!(wait_for(&mut child, "the fill stage", || job_field(
        &db, 1, "stage"
    ) == "fill"));
    signal(&child, "-TERM");
    let status = child.wait().unwrap();
    assert_eq!(
        status.code(),
        Some(75),
        "an interrupted run exits 75 (EX_TEMPFAIL)"
    );
    assert_eq!(
        fill_checkpoints(d),
        0,
        "the fill stopped on the signal instead of running to its end"
    );
    assert_eq!(job_field(&db, 1, "status"), "paused");
    assert_eq!(
        job_field(&db, 1, "attempts"),
        "0",
        "a pause is not a failure"
    );
    let o = sweep_cmd(d).args(resume_args(&db)).output().unwrap();
    assert!(o.status.success(), "resume:\n{}", text(&o));
    assert_eq!(job_field(&db, 1, "status"), "done");
}

// 5. An edited campaign is refused, or launched as a new version apart from the old one.

#[test]
fn an_edited_campaign_is_refused_unless_launched_as_a_new_version() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let db = d.join("sweep.db");
    let v1 = campaign("two", &[0.02, 0.025], &[1.0], 0.05);
    let file = write_campaign(d, "two.json", &v1);
    launch_ok(d, &file, &db);

    // A changed value of every job: refused with the field, nothing registered.
    let mut v2 = v1.clone();
    v2["base"]["particle_count"] = json!(250);
    write_campaign(d, "two.json", &v2);
    let o = sweep_cmd(d).args(launch_args(&file, &db)).output().unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        stderr(&o).contains("base.particle_count: 300 -> 250")
            && stderr(&o).contains("--new-version"),
        "the refusal names the changed field and the way out:\n{}",
        stderr(&o)
    );
    assert_eq!(
        count(&db, "SELECT COUNT(*) FROM jobs"),
        2,
        "nothing registered"
    );

    // As a new version: its own jobs, the old version's results untouched.
    let mut args = launch_args(&file, &db);
    args.push("--new-version");
    let o = sweep_cmd(d).args(args).output().unwrap();
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        stdout(&o).contains("two (version 2): 2 job(s), 2 new"),
        "{}",
        stdout(&o)
    );
    assert_eq!(
        count(&db, "SELECT COUNT(*) FROM campaigns WHERE name = 'two'"),
        2
    );
    for version in [1, 2] {
        assert_eq!(
            count(
                &db,
                &format!(
                    "SELECT COUNT(*) FROM campaign_jobs cj JOIN campaigns c ON c.id = cj.campaign_id
                     WHERE c.version = {version}"
                )
            ),
            2,
            "each version has its own two jobs"
        );
    }
    // Reports read one version: the latest by default, `NAME@vK` for an older one; each
    // combines only its own jobs (two orifices, one point each).
    let table = |name: &str| {
        let o = sweep_cmd(d)
            .args(["report", "--figure", "fig4", "--campaign", name, "--db"])
            .arg(&db)
            .arg("--out")
            .arg(d.join(format!("fig-{name}")))
            .output()
            .unwrap();
        assert!(o.status.success(), "report {name}:\n{}", text(&o));
        stdout(&o)
    };
    let (latest, first) = (table("two"), table("two@v1"));
    assert_ne!(
        latest, first,
        "the two versions' figures differ (N differs)"
    );
    for t in [&latest, &first] {
        // The table's replicas column: one run per point, none from the other version.
        let lines: Vec<&str> = t.lines().collect();
        let header = lines
            .iter()
            .position(|l| l.contains("Q/Q_ref") && l.contains("replicas"))
            .unwrap_or_else(|| panic!("no fig4 table:\n{t}"));
        let col = lines[header]
            .split_whitespace()
            .position(|c| c == "replicas")
            .unwrap();
        let rows: Vec<&str> = lines[header + 1..]
            .iter()
            .take_while(|l| !l.trim().is_empty())
            .map(|l| l.split_whitespace().nth(col).unwrap_or(""))
            .collect();
        assert!(
            !rows.is_empty() && rows.iter().all(|n| *n == "1"),
            "no point combines jobs of both versions: {rows:?}\n{t}"
        );
    }

    // Forgetting version 1 removes its jobs, their rows and directories, after confirmation.
    let dirs_before = std::fs::read_dir(d.join("sweep-work/sweep/jobs"))
        .unwrap()
        .count();
    let o = sweep_cmd(d)
        .args(["forget", "--campaign", "two@v1", "--db"])
        .arg(&db)
        .write_stdin("n\n")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1), "declined: {}", text(&o));
    assert_eq!(
        count(&db, "SELECT COUNT(*) FROM jobs"),
        4,
        "nothing forgotten"
    );
    let o = sweep_cmd(d)
        .args(["forget", "--campaign", "two@v1", "--db"])
        .arg(&db)
        .write_stdin("y\n")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(count(&db, "SELECT COUNT(*) FROM jobs"), 2);
    assert_eq!(count(&db, "SELECT COUNT(*) FROM campaigns"), 1);
    assert_eq!(count(&db, "SELECT COUNT(*) FROM discharge_summary"), 2);
    assert_eq!(
        count(
            &db,
            "SELECT COUNT(*) FROM discharge_series WHERE job_id NOT IN (SELECT id FROM jobs)"
        ),
        0,
        "no orphan rows"
    );
    let dirs_after = std::fs::read_dir(d.join("sweep-work/sweep/jobs"))
        .unwrap()
        .count();
    assert_eq!(
        dirs_after + 2,
        dirs_before,
        "the two job directories are gone"
    );
}

// 6. Bad command lines and read-only stores.

#[test]
fn bad_counts_and_a_read_only_database_are_refused_by_name() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let file = write_campaign(d, "tiny.json", &one_job(0.05));
    let db = d.join("sweep.db");
    for (flag, value) in [("--parallel", "0"), ("--threads", "100000")] {
        let mut args = launch_args(&file, &db);
        args.extend([flag, value]);
        let o = sweep_cmd(d).args(args).output().unwrap();
        assert_eq!(o.status.code(), Some(2), "{flag} {value}: {}", text(&o));
        assert!(stderr(&o).contains(flag), "{flag}: {}", stderr(&o));
        assert!(!db.exists(), "{flag} {value}: nothing created");
    }

    launch_ok(d, &file, &db);
    // Read-only for the user who runs sweep (root ignores permissions: run as nobody then).
    let mut perms = std::fs::metadata(&db).unwrap().permissions();
    std::os::unix::fs::PermissionsExt::set_mode(&mut perms, 0o444);
    std::fs::set_permissions(&db, perms).unwrap();
    let mut open = std::fs::metadata(d).unwrap().permissions();
    std::os::unix::fs::PermissionsExt::set_mode(&mut open, 0o755);
    std::fs::set_permissions(d, open).unwrap();
    let root = std::fs::read_to_string("/proc/self/status")
        .unwrap()
        .lines()
        .any(|l| l.starts_with("Uid:") && l.split_whitespace().nth(1) == Some("0"));
    let mut cmd = if root {
        // As nobody, from a copy nobody can run wherever the build directory is.
        let bin = d.join("sweep-as-nobody");
        std::fs::copy(BIN, &bin).unwrap();
        let mut c = assert_cmd::Command::new("setpriv");
        c.args(["--reuid=65534", "--regid=65534", "--clear-groups"])
            .arg(&bin);
        c
    } else {
        assert_cmd::Command::new(BIN)
    };
    let o = cmd
        .current_dir(d)
        .env_remove("SWEEP_DB")
        .args(launch_args(&file, &db))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let err = stderr(&o);
    assert!(
        err.contains(db.to_str().unwrap()) && err.contains("read-only"),
        "the error names the file and says it is read-only:\n{err}"
    );
}

// 7. Exit codes and records: a renamed database resumes from its checkpoints, and the job's
// particle count is its own.

#[test]
fn a_renamed_database_resumes_from_its_checkpoints_and_keeps_the_job_record() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let file = write_campaign(d, "tiny.json", &one_job(0.05));
    let db = d.join("sweep.db");
    let mut child = spawn(d, &launch_args(&file, &db), "launch.log");
    // Past the first checkpoints, so the resumed state has lost particles through the orifice.
    assert!(wait_for(&mut child, "discharge checkpoints", || {
        job_checkpoints(d).len() >= 2
    }));
    kill(&mut child);
    // Reading the store once folds its WAL into the file, so the file alone can be renamed.
    let o = sweep_cmd(d)
        .args(["status", "--db", db.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success());
    let moved = d.join("renamed.db");
    std::fs::rename(&db, &moved).unwrap();
    let o = sweep_cmd(d).args(resume_args(&moved)).output().unwrap();
    let out = text(&o);
    assert!(o.status.success(), "{out}");
    assert!(
        out.contains("resuming from"),
        "the renamed store found its checkpoints:\n{out}"
    );
    assert!(
        !out.contains("restarting from the beginning"),
        "checkpoints lost:\n{out}"
    );
    assert_eq!(job_field(&moved, 1, "status"), "done");
    assert_eq!(
        job_field(&moved, 1, "particles"),
        "300",
        "jobs.particles is the job's particle count, not the checkpoint's"
    );
    let attempts: i64 = job_field(&moved, 1, "attempts").parse().unwrap();
    let max: i64 = job_field(&moved, 1, "max_attempts").parse().unwrap();
    assert!(attempts <= max, "attempts {attempts} > max {max}");
}

// 6. A plain `resume` continues each campaign's latest version; `--campaign NAME@vK` an older one.

/// Launches `file` (with `extra` arguments) and stops it with SIGTERM during job `job`'s fill.
fn launch_and_pause(d: &Path, file: &Path, db: &Path, extra: &[&str], job: i64) {
    let mut args = launch_args(file, db);
    args.extend_from_slice(extra);
    let mut child = spawn(d, &args, &format!("launch-{job}.log"));
    assert!(wait_for(&mut child, "the fill stage", || job_field(
        db, job, "stage"
    ) == "fill"));
    signal(&child, "-TERM");
    assert_eq!(child.wait().unwrap().code(), Some(75));
    assert_eq!(job_field(db, job, "status"), "paused");
}

/// An older version's open job that a newer version shares is resumed by a plain resume, so
/// `sweep status` does not call it left; `--campaign NAME@vK` lists that version alone.
#[test]
fn status_marks_only_the_jobs_a_newer_version_leaves() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let db = d.join("sweep.db");
    let register = |c: &Value, new_version: bool| {
        let file = write_campaign(d, "kept.json", c);
        let mut args = launch_args(&file, &db);
        args.push("--register-only");
        if new_version {
            args.push("--new-version");
        }
        let o = sweep_cmd(d).args(args).output().unwrap();
        assert!(o.status.success(), "{}", text(&o));
    };
    let v1 = campaign("kept", &[0.02], &[1.0], 0.05);
    register(&v1, false);
    // Version 2 adds an orifice and keeps version 1's one job.
    register(&campaign("kept", &[0.02, 0.025], &[1.0], 0.05), true);
    let status = |name: &str| {
        let o = sweep_cmd(d)
            .args(["status", "--db", db.to_str().unwrap(), "--campaign", name])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", text(&o));
        stdout(&o)
    };
    let out = status("kept");
    assert!(!out.contains("replaced by version"), "{out}");
    let v1_only = status("kept@v1");
    assert!(
        v1_only.contains("campaign kept (") && !v1_only.contains("kept version 2"),
        "{v1_only}"
    );
}

#[test]
fn resume_leaves_an_older_campaign_version_paused_unless_named() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let db = d.join("sweep.db");
    let v1 = slow_fill("slow", 3);
    let file = write_campaign(d, "slow.json", &v1);
    launch_and_pause(d, &file, &db, &[], 1);
    let mut v2 = v1.clone();
    v2["base"]["particle_count"] = json!(1400);
    write_campaign(d, "slow.json", &v2);
    launch_and_pause(d, &file, &db, &["--new-version"], 2);

    let o = sweep_cmd(d).args(resume_args(&db)).output().unwrap();
    assert!(o.status.success(), "plain resume:\n{}", text(&o));
    assert_eq!(job_field(&db, 2, "status"), "done");
    assert_eq!(
        job_field(&db, 1, "status"),
        "paused",
        "version 1's paused job is left alone"
    );
    assert!(
        stdout(&o).contains("1 job(s) of older campaign versions left as they are"),
        "{}",
        stdout(&o)
    );
    let o = sweep_cmd(d)
        .args(["status", "--db", db.to_str().unwrap()])
        .output()
        .unwrap();
    let replaced = "replaced by version 2: 1 open job(s) that a plain `sweep resume` leaves (it continues the latest versions' jobs); `--campaign slow@v1` continues them";
    assert_eq!(
        stdout(&o).matches(replaced).count(),
        1,
        "status says why version 1's job waits, and only of version 1:\n{}",
        stdout(&o)
    );

    let resume = |campaign: &str| {
        let mut args = resume_args(&db);
        args.extend_from_slice(&["--campaign", campaign]);
        sweep_cmd(d).args(args).output().unwrap()
    };
    let o = resume("nope");
    assert_ne!(o.status.code(), Some(0));
    assert!(
        stderr(&o).contains("no campaign named 'nope'") && stderr(&o).contains("slow"),
        "an unknown name is refused with the known ones:\n{}",
        stderr(&o)
    );
    assert_eq!(job_field(&db, 1, "status"), "paused");

    let o = resume("slow@v1");
    assert!(o.status.success(), "resume version 1:\n{}", text(&o));
    assert!(
        stdout(&o).contains("1 job(s) to resume, 0 of 1 already done"),
        "counts are the campaign's own:\n{}",
        stdout(&o)
    );
    assert_eq!(job_field(&db, 1, "status"), "done");
}
