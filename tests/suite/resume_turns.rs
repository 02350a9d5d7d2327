//! A plain `sweep resume` of a store that holds several campaigns takes them in turn, the
//! fewest open jobs first, each through its jobs and then its claims' look or its target's
//! rounds: a small campaign's verdict does not wait behind every job of a large one.

use std::path::Path;

use crate::common::cli::*;
use serde_json::json;
use tempfile::TempDir;

/// Launches `file` into `db` and SIGKILLs it once one of campaign `name`'s jobs runs.
fn launch_killed_once_running(dir: &Path, file: &Path, db: &Path, name: &str) {
    let sql = format!(
        "SELECT COUNT(*) FROM jobs j JOIN campaign_jobs cj ON cj.job_id = j.id
         JOIN campaigns c ON c.id = cj.campaign_id
         WHERE c.name = '{name}' AND j.status = 'running'"
    );
    let mut child = launch_until(dir, file, db, &format!("a job of {name} running"), &sql);
    kill(&mut child);
}

/// Three campaigns, each launched and killed while running: "short" (job 1, 0.1 s of
/// discharge), registered first, "third" (jobs 2 and 3) and "tiny" (job 4, the reference's
/// single job). In turn, tiny comes before third: fewer open jobs.
fn three_campaigns_interrupted(dir: &Path, db: &Path) {
    let mut short = campaign("short", &[0.024], &[0.0], 0.05);
    short["base"]["discharge_time_s"] = json!(0.1);
    let short = write_campaign(dir, "short.json", &short);
    let third = write_campaign(
        dir,
        "third.json",
        &campaign("third", &[0.026], &[0.0, 1.0], 0.05),
    );
    let tiny = write_campaign(dir, "tiny.json", &one_job(0.05));
    launch_killed_once_running(dir, &short, db, "short");
    launch_killed_once_running(dir, &third, db, "third");
    launch_killed_once_running(dir, &tiny, db, "tiny");
}

#[test]
fn a_small_campaign_is_looked_at_before_a_large_one_runs() {
    let dir = TempDir::new().unwrap();
    let db = dir.path().join("sweep.db");
    // Four jobs, launched first (jobs 1–4), and two of other orifices with a claim (jobs 5–6).
    let large = campaign("large", &[0.02, 0.022], &[0.0, 1.0], 0.2);
    let mut small = campaign("small", &[0.024], &[0.0, 1.0], 0.2);
    small["claims"] = json!([{
        "id": "q_rises_with_f", "paper": "PRE 102, 042902, Fig. 4",
        "statement": "Q at 1 Hz exceeds Q at rest",
        "compare": {
            "result": "q",
            "at": { "orifice_diameter_m": 0.024, "rotation_frequency_hz": 1.0 },
            "against": { "orifice_diameter_m": 0.024, "rotation_frequency_hz": 0.0 },
            "above": 1.0
        }
    }]);
    let large = write_campaign(dir.path(), "large.json", &large);
    let small = write_campaign(dir.path(), "small.json", &small);
    launch_killed_once_running(dir.path(), &large, &db, "large");
    launch_killed_once_running(dir.path(), &small, &db, "small");

    let o = resume(dir.path(), &db);
    let out = stdout(&o);
    assert!(o.status.success(), "{out}\n{}", stderr(&o));
    assert!(
        out.contains("campaigns in turn, the fewest open jobs first, each through its jobs and its rounds: small (2 open), large (4 open)"),
        "{out}"
    );
    let lines: Vec<&str> = out.lines().collect();
    let at = |p: &dyn Fn(&str) -> bool| lines.iter().position(|l| p(l));
    let look = at(&|l| l.starts_with("claims: ")).expect("the small campaign's look");
    let small_done = at(&|l| l.starts_with("job 6 done")).expect("job 6 done");
    let large_start = at(&|l| (1..=4).any(|k| l.starts_with(&format!("job {k} started"))))
        .expect("a large job started");
    assert!(small_done < look && look < large_start, "{out}");
    assert_eq!(
        count(&db, "SELECT COUNT(*) FROM jobs WHERE status = 'done'"),
        6,
        "{out}"
    );
    assert_eq!(
        count(&db, "SELECT COUNT(*) FROM claim_verdicts"),
        1,
        "one look, once the small campaign's jobs had ended"
    );
}

/// With two workers, the one that finds no job of the first campaign left runs a job of the
/// next while the first campaign's last job ends, then hands it back at a checkpoint; the next
/// campaign's turn finishes it with the same results as a run that was never lent. The tiny
/// campaign's job (4), registered after third's (2, 3) but before them in turn, is lent first.
#[test]
fn an_idle_core_runs_the_next_campaigns_job_and_hands_it_back() {
    let dir = TempDir::new().unwrap();
    let db = dir.path().join("sweep.db");
    three_campaigns_interrupted(dir.path(), &db);

    let o = sweep_cmd(dir.path())
        .args(["resume", "--db", db.to_str().unwrap(), "--stale-after", "0"])
        .args(["--backend", "cpu", "--threads", "1", "--parallel", "2"])
        .output()
        .unwrap();
    let (out, err) = (stdout(&o), stderr(&o));
    assert!(o.status.success(), "{out}\n{err}");
    assert!(
        out.contains("campaigns in turn, the fewest open jobs first, each through its jobs and its rounds: short (1 open), tiny (1 open), third (2 open)"),
        "{out}"
    );
    let first_lent = err
        .lines()
        .find(|l| l.ends_with("(on an idle core while the campaign's last jobs run)"));
    assert!(
        first_lent.is_some_and(|l| l.starts_with("job 4 started: ")),
        "the tiny job, next in turn, runs beside the short one:\n{err}"
    );
    assert!(
        err.contains("job 4 handed back at its checkpoint"),
        "and is handed back when the short job ends:\n{err}"
    );
    assert_eq!(
        count(&db, "SELECT COUNT(*) FROM jobs WHERE status = 'done'"),
        4,
        "{out}\n{err}"
    );
    // Only the tiny job's rows: the same bits as the reference run.
    let reference = reference();
    let hash = &reference.jobs[0][0];
    let mut got = results(&db);
    for rows in [
        &mut got.jobs,
        &mut got.series,
        &mut got.summary,
        &mut got.clogs,
    ] {
        rows.retain(|r| &r[0] == hash);
    }
    assert_same_results(reference, &got);
}

/// `--campaign` named more than once takes those campaigns in the order named, whatever their
/// open jobs, and leaves the campaigns not named as they are.
#[test]
fn named_campaigns_run_in_the_order_named_and_no_other() {
    let dir = TempDir::new().unwrap();
    let db = dir.path().join("sweep.db");
    three_campaigns_interrupted(dir.path(), &db);

    let o = sweep_cmd(dir.path())
        .args(["resume", "--db", db.to_str().unwrap(), "--stale-after", "0"])
        .args([
            "--campaign",
            "third",
            "--campaign",
            "tiny",
            "--campaign",
            "third",
        ])
        .args(["--backend", "cpu", "--threads", "1", "--parallel", "1"])
        .output()
        .unwrap();
    let (out, err) = (stdout(&o), stderr(&o));
    assert!(o.status.success(), "{out}\n{err}");
    assert!(
        out.contains("third: 0 of 2 already done; tiny: 0 of 1 already done"),
        "{out}"
    );
    assert!(
        out.contains("campaigns in turn, in the order named, each through its jobs and its rounds: third (2 open), tiny (1 open)"),
        "{out}"
    );
    let lines: Vec<&str> = out.lines().collect();
    let at = |id: i64| {
        lines
            .iter()
            .position(|l| l.starts_with(&format!("job {id} started")))
    };
    let (j2, j3, j4) = (at(2), at(3), at(4));
    assert!(
        j2.is_some() && j3.is_some() && j4.is_some() && j2.max(j3) < j4,
        "third's jobs (2, 3) before tiny's (4):\n{out}"
    );
    assert!(at(1).is_none(), "short was not named:\n{out}");
    assert_eq!(
        count(
            &db,
            "SELECT COUNT(*) FROM jobs WHERE id = 1 AND status != 'done'"
        ),
        1,
        "short's job is left as it was"
    );
    assert_eq!(
        count(&db, "SELECT COUNT(*) FROM jobs WHERE status = 'done'"),
        3,
        "{out}\n{err}"
    );
}

/// `launch --register-only` queues a campaign: its jobs are registered and none runs; a later
/// resume runs them.
#[test]
fn a_campaign_registered_only_runs_at_the_next_resume() {
    let dir = TempDir::new().unwrap();
    let db = dir.path().join("sweep.db");
    let file = write_campaign(dir.path(), "tiny.json", &one_job(0.05));
    let o = sweep_cmd(dir.path())
        .args([
            "launch",
            file.to_str().unwrap(),
            "--db",
            db.to_str().unwrap(),
        ])
        .arg("--register-only")
        .output()
        .unwrap();
    let out = stdout(&o);
    assert!(o.status.success(), "{out}\n{}", stderr(&o));
    assert!(out.contains("registered only: `sweep resume --db"), "{out}");
    assert_eq!(
        count(
            &db,
            "SELECT COUNT(*) FROM jobs WHERE status = 'pending' AND attempts = 0"
        ),
        1
    );
    let o = resume(dir.path(), &db);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        count(&db, "SELECT COUNT(*) FROM jobs WHERE status = 'done'"),
        1
    );
}
