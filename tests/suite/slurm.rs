//! The Slurm executor against a real single-node Slurm (`scripts/slurm-dev-cluster.sh`, Debian's
//! slurmctld, slurmd and munge, all state in a temporary directory), not a mock.
//!
//! A tiny silo campaign of 4 jobs is launched with `--executor slurm --array-max 2`; one running
//! task is requeued with `scontrol requeue` (SIGTERM, Slurm requeues it), another gets
//! `scancel --batch --signal=USR1` (the warning before a time limit: it checkpoints and requeues
//! itself). Every job must finish exactly once — no task started more often than it was
//! interrupted, both interrupted ones resuming from a checkpoint — and `sweep collect` must give
//! results bitwise equal to the same campaign run by the local executor. Then a rejected
//! submission (a partition that does not exist) and `sweep cancel` followed by `sweep resume`.
//!
//! Needs root (the daemons run as root; missing packages are installed with apt-get). Without
//! root or without apt-get and Slurm, the test says so and skips, except under CI=true, where it
//! fails. The cluster is stopped even when the test fails (a Drop guard).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use crate::common::cli::{count, read_db, rows, stderr, stdout, write_campaign};
use serde_json::{json, Value};
use tempfile::TempDir;

/// Longest the test waits for Slurm to bring a campaign to some point.
const PATIENCE: Duration = Duration::from_secs(150);

/// The dev cluster of one test, stopped when dropped.
struct Cluster {
    dir: PathBuf,
    conf: PathBuf,
}

fn script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/slurm-dev-cluster.sh")
}

impl Cluster {
    fn start(dir: &Path) -> Cluster {
        let o = Command::new("bash")
            .arg(script())
            .arg("start")
            .arg(dir)
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&o.stdout).into_owned();
        let conf = text
            .lines()
            .find_map(|l| l.strip_prefix("export SLURM_CONF="))
            .map(PathBuf::from);
        // Stop whatever started, even if the start failed half-way.
        let c = Cluster {
            dir: dir.to_path_buf(),
            conf: conf.clone().unwrap_or_default(),
        };
        assert!(
            o.status.success() && conf.is_some(),
            "slurm-dev-cluster.sh start failed:\n{text}\n{}",
            String::from_utf8_lossy(&o.stderr)
        );
        c
    }

    /// A Slurm client command against this cluster.
    fn cmd(&self, program: &str) -> Command {
        let mut c = Command::new(program);
        c.env("SLURM_CONF", &self.conf);
        c
    }

    /// The sweep binary, in `dir`, against this cluster.
    fn sweep(&self, dir: &Path, args: &[&str]) -> Output {
        let mut c = self.cmd(&crate::common::cli::bin());
        c.args(args).current_dir(dir).env_remove("SWEEP_DB");
        c.output().unwrap()
    }

    /// Runs a Slurm command until it succeeds (30 s at most).
    fn retry(&self, program: &str, args: &[&str]) {
        let t0 = Instant::now();
        let mut errors: Vec<String> = Vec::new();
        loop {
            let o = self.cmd(program).args(args).output().unwrap();
            if o.status.success() {
                return;
            }
            let e = format!("{}{}", stdout(&o), stderr(&o)).trim().to_string();
            if !errors.contains(&e) {
                errors.push(e);
            }
            assert!(
                t0.elapsed() < Duration::from_secs(30),
                "{program} {}: {}\ntasks: {:?}",
                args.join(" "),
                errors.join("\n"),
                self.tasks_in("all")
            );
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    /// Array tasks in a state: (`array_task`, its own job id, the array's job id).
    fn tasks_in(&self, state: &str) -> Vec<(String, String, String)> {
        let o = self
            .cmd("squeue")
            .args(["-h", "-r", "-t", state, "-o", "%i %A %F"])
            .output()
            .unwrap();
        String::from_utf8_lossy(&o.stdout)
            .lines()
            .filter_map(|l| {
                let f: Vec<&str> = l.split_whitespace().collect();
                (f.len() == 3).then(|| (f[0].to_string(), f[1].to_string(), f[2].to_string()))
            })
            .collect()
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new("bash")
            .arg(script())
            .arg("stop")
            .arg(&self.dir)
            .output();
    }
}

fn which(cmd: &str) -> bool {
    std::env::var_os("PATH")
        .map(|p| std::env::split_paths(&p).any(|d| d.join(cmd).is_file()))
        .unwrap_or(false)
}

/// Why the dev cluster cannot run here, if it cannot.
fn cannot_run_cluster() -> Option<String> {
    let uid = Command::new("id").arg("-u").output().ok()?;
    if String::from_utf8_lossy(&uid.stdout).trim() != "0" {
        return Some("not root: the dev cluster runs slurmctld, slurmd and munged as root".into());
    }
    let installed = ["slurmctld", "slurmd", "sbatch", "munged"]
        .iter()
        .all(|c| which(c));
    if !installed && !which("apt-get") {
        return Some("Slurm is not installed and there is no apt-get to install it".into());
    }
    None
}

/// Skips (returns true) when the cluster cannot run here, unless CI=true.
fn skip() -> bool {
    match cannot_run_cluster() {
        None => false,
        Some(why) if std::env::var("CI").as_deref() == Ok("true") => {
            panic!("CI=true and the Slurm dev cluster cannot run: {why}")
        }
        Some(why) => {
            eprintln!("skipping the Slurm test: {why}");
            true
        }
    }
}

fn ok(o: Output, what: &str) -> Output {
    assert!(
        o.status.success(),
        "{what} failed ({}):\n{}\n{}",
        o.status,
        stdout(&o),
        stderr(&o)
    );
    o
}

/// The tiny silo campaign (`common::cli::campaign`), discharging long enough (4 s simulated,
/// with re-insertion, a few seconds of wall time per job) for a task to be caught running.
fn campaign(name: &str, orifices: &[f64], frequencies: &[f64]) -> Value {
    let mut c = crate::common::cli::campaign(name, orifices, frequencies, 0.05);
    c["base"]["discharge_time_s"] = json!(4.0);
    c["base"]["reinsert"] = json!(true);
    c
}

/// The results tables, keyed by job hash (row ids may differ between databases).
fn results(db: &Path) -> Vec<(&'static str, Vec<Vec<String>>)> {
    vec![
        ("jobs (hash, status, sim_time_s, target_time_s, attempts)", rows(db, "SELECT hash, status, sim_time_s, target_time_s, attempts FROM jobs ORDER BY hash")),
        ("discharge_series", rows(
            db,
            "SELECT j.hash, s.t_s, s.mass_kg, s.count FROM discharge_series s JOIN jobs j ON j.id = s.job_id ORDER BY j.hash, s.t_s",
        )),
        ("discharge_summary", rows(
            db,
            "SELECT j.hash, s.orifice_diameter_m, s.rotation_frequency_hz, s.particle_diameter_m, s.bulk_density_kg_per_m3,
                    s.q_kg_per_s, s.q_ci95_kg_per_s, s.q_method, s.flowing_time_s, s.discharged_mass_kg, s.discharged_count,
                    s.clogs, s.clogged_time_s, s.permanently_clogged
             FROM discharge_summary s JOIN jobs j ON j.id = s.job_id ORDER BY j.hash",
        )),
        ("clogs", rows(
            db,
            "SELECT j.hash, c.start_s, c.duration_s, c.permanent FROM clogs c JOIN jobs j ON j.id = c.job_id ORDER BY j.hash, c.start_s",
        )),
    ]
}

/// Task `array_task` → (job id, job directory), from the database.
fn task_jobs(db: &Path, work: &Path) -> Vec<(String, i64, PathBuf)> {
    let conn = read_db(db);
    let mut q = conn
        .prepare("SELECT t.array_job_id || '_' || t.array_task_id, t.job_id, j.hash FROM slurm_tasks t JOIN jobs j ON j.id = t.job_id ORDER BY t.id")
        .unwrap();
    let out = q
        .query_map([], |r| {
            let hash: String = r.get(2)?;
            Ok((r.get(0)?, r.get(1)?, work.join("jobs").join(&hash[..16])))
        })
        .unwrap()
        .collect::<rusqlite::Result<Vec<_>>>()
        .unwrap();
    out
}

/// Fraction of its target a job's task last reported, if it reported.
fn reported_progress(job_dir: &Path) -> Option<f64> {
    let p: Value =
        serde_json::from_str(&std::fs::read_to_string(job_dir.join("progress.json")).ok()?).ok()?;
    Some(p["sim_time_s"].as_f64()? / p["target_time_s"].as_f64()?)
}

fn has_checkpoint(job_dir: &Path) -> bool {
    std::fs::read_dir(job_dir).is_ok_and(|d| {
        d.flatten()
            .any(|e| e.file_name().to_string_lossy().starts_with("ckpt-"))
    })
}

/// Polls `sweep collect` until `done` jobs are done in the database.
fn collect_until_done(cluster: &Cluster, dir: &Path, db: &Path, done: i64, what: &str) {
    let t0 = Instant::now();
    loop {
        ok(
            cluster.sweep(dir, &["collect", "--db", db.to_str().unwrap()]),
            "sweep collect",
        );
        if count(db, "SELECT COUNT(*) FROM jobs WHERE status = 'done'") >= done {
            return;
        }
        assert!(
            t0.elapsed() < PATIENCE,
            "timed out waiting for {what}; status:\n{}",
            stdout(&cluster.sweep(dir, &["status", "--db", db.to_str().unwrap()]))
        );
        std::thread::sleep(Duration::from_millis(500));
    }
}

/// All task logs of a work directory, by file name.
fn logs(work: &Path) -> Vec<(String, String)> {
    let mut v: Vec<(String, String)> = std::fs::read_dir(work.join("slurm/logs"))
        .unwrap()
        .flatten()
        .map(|e| {
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read_to_string(e.path()).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

#[test]
fn without_sbatch_launch_says_so_and_registers_nothing() {
    let dir = TempDir::new().unwrap();
    let file = write_campaign(dir.path(), "c.json", &campaign("c", &[0.02], &[1.0]));
    let empty = dir.path().join("empty-path");
    std::fs::create_dir(&empty).unwrap();
    let o = Command::new(crate::common::cli::bin())
        .args(["launch", file.to_str().unwrap(), "--executor", "slurm"])
        .current_dir(dir.path())
        .env_remove("SWEEP_DB")
        .env("PATH", &empty)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("sbatch not found on PATH") && stderr(&o).contains("--executor local"),
        "{}",
        stderr(&o)
    );
    assert!(!dir.path().join("sweep.db").exists(), "nothing registered");
}

#[test]
fn slurm_campaign_with_requeue_and_usr1_equals_the_local_run() {
    if skip() {
        return;
    }
    let t_start = Instant::now();
    let tmp = TempDir::new().unwrap();
    let c = campaign("tiny_slurm", &[0.02, 0.025], &[0.5, 1.0]);

    // The reference: the same campaign on the local executor.
    let local = tmp.path().join("local");
    std::fs::create_dir(&local).unwrap();
    let file = write_campaign(&local, "tiny.json", &c);
    let ref_db = local.join("sweep.db");
    let o = Command::new(crate::common::cli::bin())
        .args([
            "launch",
            file.to_str().unwrap(),
            "--db",
            ref_db.to_str().unwrap(),
        ])
        .args(["--backend", "cpu", "--threads", "1", "--parallel", "2"])
        .current_dir(&local)
        .env_remove("SWEEP_DB")
        .output()
        .unwrap();
    ok(o, "the local reference run");
    let reference = results(&ref_db);
    assert_eq!(reference[2].1.len(), 4, "the reference has 4 summaries");

    // NOTE: declared after `tmp`, so it is dropped (stopped) before the directory goes.
    let cluster = Cluster::start(&tmp.path().join("slurm"));
    let run = tmp.path().join("run");
    std::fs::create_dir(&run).unwrap();
    let file = write_campaign(&run, "tiny.json", &c);
    let db = run.join("sweep.db");
    let work = run.join("sweep-work").join("sweep");
    let dbs = db.to_str().unwrap();
    let o = ok(
        cluster.sweep(
            &run,
            &[
                "launch",
                file.to_str().unwrap(),
                "--db",
                dbs,
                "--executor",
                "slurm",
                "--array-max",
                "2",
                "--backend",
                "cpu",
            ],
        ),
        "launch --executor slurm",
    );
    assert!(
        stdout(&o).contains("submitted 4 job(s) to Slurm as array")
            && stdout(&o).contains("at most 2 at a time"),
        "{}",
        stdout(&o)
    );
    let scripts: Vec<_> = std::fs::read_dir(work.join("slurm"))
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().ends_with(".sbatch"))
        .collect();
    assert_eq!(scripts.len(), 1, "one script kept for provenance");
    let text = std::fs::read_to_string(scripts[0].path()).unwrap();
    for want in [
        "--array=0-3%2",
        "--requeue",
        "--signal=B:USR1@",
        "run-job --db-dir",
    ] {
        assert!(text.contains(want), "{want} missing from\n{text}");
    }

    // Two running tasks, each past its first checkpoint and less than half done.
    let t0 = Instant::now();
    let (requeued, signalled) = loop {
        let running = cluster.tasks_in("running");
        let ready: Vec<(String, PathBuf)> = task_jobs(&db, &work)
            .into_iter()
            .filter(|(t, _, d)| {
                running.iter().any(|r| &r.0 == t)
                    && has_checkpoint(d)
                    && reported_progress(d).is_some_and(|p| p < 0.5)
            })
            .map(|(t, _, d)| (t, d))
            .collect();
        if ready.len() >= 2 {
            break (ready[0].clone(), ready[1].clone());
        }
        assert!(
            t0.elapsed() < PATIENCE,
            "timed out waiting for two running tasks with a checkpoint; running: {running:?}"
        );
        std::thread::sleep(Duration::from_millis(50));
    };
    let status = stdout(&ok(cluster.sweep(&run, &["status", "--db", dbs]), "status"));
    assert!(
        status.contains(&format!("slurm: task {} RUNNING", requeued.0)),
        "status shows Slurm's view:\n{status}"
    );

    // Requeue one (SIGTERM, then Slurm queues it again) and start it again at once.
    // NOTE: in this order. A requeued task stays "in a transitional state" until it starts
    // again (about cred_expire without StartTime=now), and meanwhile Slurm defers signals to
    // the other tasks of its array.
    cluster.retry("scontrol", &["requeue", &requeued.0]);
    cluster.retry(
        "scontrol",
        &["update", &format!("jobid={}", requeued.0), "StartTime=now"],
    );
    // Warn the other one of its time limit. NOTE: scancel returns at once, except when the
    // task requeues itself meanwhile (as this one does): then scancel keeps retrying ("job is in
    // transitional state") and signals the task again once it has restarted. The task's log
    // says when the one signal wanted has arrived; scancel is stopped there.
    let mut scancel = cluster
        .cmd("scancel")
        .args(["--batch", "--signal=USR1", &signalled.0])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let log = work.join("slurm/logs").join(format!("{}.out", signalled.0));
    let t0 = Instant::now();
    while !std::fs::read_to_string(&log)
        .unwrap_or_default()
        .contains("checkpointed on SIGUSR1")
    {
        if let Some(st) = scancel.try_wait().unwrap() {
            assert!(st.success(), "scancel --batch --signal=USR1 failed: {st}");
        }
        assert!(
            t0.elapsed() < PATIENCE,
            "task {} never checkpointed on SIGUSR1",
            signalled.0
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let _ = scancel.kill();
    let _ = scancel.wait();

    collect_until_done(&cluster, &run, &db, 4, "the 4 jobs to finish under Slurm");

    // Bitwise equal to the local run (attempts included: Slurm's requeues are not retries).
    for ((what, a), (_, b)) in reference.iter().zip(results(&db)) {
        assert_eq!(a.len(), b.len(), "{what}: row counts differ");
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(x, y, "{what} differs between the local and the Slurm run");
        }
    }
    assert_eq!(
        count(&db, "SELECT COUNT(*) FROM slurm_tasks WHERE state = 'done'"),
        4,
        "one submission per job, each collected"
    );
    assert_eq!(count(&db, "SELECT COUNT(*) FROM slurm_tasks"), 4);
    // Each task's CPU time and threads came in with its results, across its requeue.
    assert_eq!(
        count(
            &db,
            "SELECT COUNT(*) FROM jobs WHERE cpu_time_s > 0 AND threads >= 1"
        ),
        4,
        "CPU time and threads ingested"
    );

    // Exactly once: one "done" per job; a task started again only when it was interrupted, and
    // then from its checkpoint.
    let logs = logs(&work);
    let all: String = logs.iter().map(|l| l.1.as_str()).collect();
    for id in 1..=4 {
        assert_eq!(
            all.matches(&format!("job {id} done:")).count(),
            1,
            "job {id} finished exactly once; logs:\n{all}"
        );
    }
    for (name, text) in &logs {
        let task = name.trim_end_matches(".out");
        let starts = text.matches("sweep run-job: job").count();
        if task == requeued.0 {
            assert_eq!(starts, 2, "{name}:\n{text}");
            assert!(text.contains("checkpointed on SIGTERM"), "{name}:\n{text}");
            assert!(text.contains("resuming from"), "{name}:\n{text}");
        } else if task == signalled.0 {
            assert_eq!(starts, 2, "{name}:\n{text}");
            assert!(text.contains("checkpointed on SIGUSR1"), "{name}:\n{text}");
            assert!(text.contains("resuming from"), "{name}:\n{text}");
        } else {
            assert_eq!(starts, 1, "{name} ran once:\n{text}");
        }
        assert!(!text.contains("already done"), "{name}:\n{text}");
    }
    // Slurm may still be tidying a task up (COMPLETING), or not yet have noted its end
    // (RUNNING) under load, right after its result was collected: ask again for a while.
    let ended = |status: &str, t: &str| {
        (status.contains(&format!("task {t} COMPLETED on"))
            || status.contains(&format!("task {t} COMPLETING on")))
            && status.contains("requeued 1×")
    };
    let mut status = String::new();
    for _ in 0..40 {
        status = stdout(&ok(cluster.sweep(&run, &["status", "--db", dbs]), "status"));
        if [&requeued.0, &signalled.0]
            .iter()
            .all(|t| ended(&status, t))
        {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(250));
    }
    for t in [&requeued.0, &signalled.0] {
        assert!(
            ended(&status, t),
            "status shows the requeue of {t}:\n{status}"
        );
    }
    assert!(status.contains("4 done"), "{status}");

    // A submission Slurm refuses: a clear message, the job left pending.
    let extra = write_campaign(&run, "extra.json", &campaign("extra", &[0.03], &[1.0]));
    let o = cluster.sweep(
        &run,
        &[
            "launch",
            extra.to_str().unwrap(),
            "--db",
            dbs,
            "--executor",
            "slurm",
            "--partition",
            "nosuch",
        ],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    assert!(
        stderr(&o).contains("sbatch refused") && stderr(&o).contains("nosuch"),
        "{}",
        stderr(&o)
    );
    let extra_job = "SELECT j.status || ' ' || j.attempts FROM jobs j JOIN campaign_jobs cj ON cj.job_id = j.id JOIN campaigns c ON c.id = cj.campaign_id WHERE c.name = 'extra'";
    assert_eq!(
        rows(&db, extra_job),
        vec![vec!["text pending 0".to_string()]]
    );

    // `resume` sends it to Slurm as launched (not to this machine), where it is refused again.
    let o = cluster.sweep(&run, &["resume", "--db", dbs]);
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    assert!(stderr(&o).contains("sbatch refused"), "{}", stderr(&o));
    assert_eq!(
        rows(&db, extra_job),
        vec![vec!["text pending 0".to_string()]]
    );

    // The same job submitted properly, cancelled while running, resumed.
    ok(
        cluster.sweep(
            &run,
            &[
                "launch",
                extra.to_str().unwrap(),
                "--db",
                dbs,
                "--executor",
                "slurm",
                "--backend",
                "cpu",
            ],
        ),
        "launch extra",
    );
    let t0 = Instant::now();
    loop {
        let running = cluster.tasks_in("running");
        let caught = task_jobs(&db, &work)
            .into_iter()
            .any(|(t, _, d)| running.iter().any(|r| r.0 == t) && has_checkpoint(&d));
        if caught {
            break;
        }
        assert!(
            t0.elapsed() < PATIENCE,
            "timed out waiting for the extra job to run"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    let o = ok(
        cluster.sweep(&run, &["cancel", "--campaign", "extra", "--db", dbs]),
        "sweep cancel",
    );
    assert!(
        stdout(&o).contains("cancelled Slurm array") && stdout(&o).contains("1 job(s) paused"),
        "{}",
        stdout(&o)
    );
    assert_eq!(
        rows(&db, extra_job),
        vec![vec!["text paused 1".to_string()]]
    );
    // Wait for the cancelled task to be gone before resubmitting.
    let t0 = Instant::now();
    while !cluster.tasks_in("running,completing").is_empty() {
        assert!(t0.elapsed() < PATIENCE, "the cancelled task did not end");
        std::thread::sleep(Duration::from_millis(100));
    }
    let o = ok(
        cluster.sweep(&run, &["resume", "--db", dbs]),
        "sweep resume",
    );
    assert!(
        stdout(&o).contains("submitted 1 job(s) to Slurm"),
        "resume resubmits to Slurm:\n{}",
        stdout(&o)
    );
    collect_until_done(&cluster, &run, &db, 5, "the resumed extra job");
    assert_eq!(rows(&db, extra_job), vec![vec!["text done 2".to_string()]]);
    assert_eq!(
        count(&db, "SELECT COUNT(*) FROM discharge_summary"),
        5,
        "5 jobs, one summary each"
    );
    eprintln!(
        "slurm test: {:.0} s in all (cluster, local reference, Slurm run)",
        t_start.elapsed().as_secs_f64()
    );
}
