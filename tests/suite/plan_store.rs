//! `sweep plan FILE --db DB` against a store that already holds some of the file's jobs: each
//! such job is named with its state, and the work still to run leaves out what ended.

use std::path::{Path, PathBuf};

use serde_json::json;
use tempfile::TempDir;

use crate::common::cli::{campaign, launch_ok, rows, stderr, stdout, sweep_cmd, write_campaign};

#[test]
fn a_plan_names_the_jobs_a_store_already_holds() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let db = d.join("plan.db");
    let first = write_campaign(d, "first.json", &campaign("first", &[0.02], &[1.0], 0.1));
    launch_ok(d, &first, &db);
    // Another campaign with the same job among its own: the store runs it once.
    let second = write_campaign(
        d,
        "second.json",
        &campaign("second", &[0.02, 0.025], &[1.0], 0.1),
    );
    let o = sweep_cmd(d)
        .args([
            "plan",
            second.to_str().unwrap(),
            "--db",
            db.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let text = stdout(&o);
    assert!(o.status.success(), "{text}\n{}", stderr(&o));
    let line = |k: &str| {
        text.lines()
            .find(|l| l.split_whitespace().next() == Some(k))
            .unwrap_or_else(|| panic!("no line for job {k}:\n{text}"))
    };
    assert!(
        line("1").contains("orifice_diameter_m=0.02,") && line("1").contains("[job 1: done,"),
        "the shared job is named with its state:\n{text}"
    );
    assert!(!line("2").contains("[job"), "job 2 is new:\n{text}");
    let new_steps = line("2").split_whitespace().nth(4).unwrap();
    assert!(
        text.contains(&format!(
            "in this store: 1 of 2 job(s) already (job(s) 1), 1 of them ended; still to run: at most {new_steps} particle-steps"
        )),
        "only the new job is left to run:\n{text}"
    );
}

/// A two-job silo campaign with one claim, launched into `d`/plan.db: its jobs done and its
/// one look stored.
fn launched_claims_campaign(d: &Path) -> (PathBuf, PathBuf) {
    let db = d.join("plan.db");
    let mut c = campaign("plan_claims", &[0.02, 0.024], &[1.0], 0.2);
    let base = c["base"].as_object_mut().unwrap();
    base.insert("particle_count".into(), json!(600));
    base.insert("discharge_time_s".into(), json!(1.0));
    base.insert("reinsert".into(), json!(true));
    c["claims"] = json!([{
        "id": "q_faster_than_d", "paper": "PRE 102, 042902, Fig. 3",
        "statement": "Q(4.1 d) / Q(3.4 d) exceeds 2.5",
        "compare": {
            "result": "q",
            "at": { "orifice_diameter_m": 0.024, "rotation_frequency_hz": 1.0 },
            "against": { "orifice_diameter_m": 0.02, "rotation_frequency_hz": 1.0 },
            "above": 2.5
        }
    }]);
    let file = write_campaign(d, "claims.json", &c);
    launch_ok(d, &file, &db);
    (file, db)
}

/// `sweep plan --db` on a campaign with claims shows what a look taken now would read, said as
/// a preview: it stores no verdict, so the campaign's looks and α stay as they were.
#[test]
fn a_plans_claims_are_a_preview_and_store_nothing() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let (file, db) = launched_claims_campaign(d);
    let stored = || {
        rows(
            &db,
            "SELECT round, claim_id, verdict, value FROM claim_verdicts",
        )
    };
    let before = stored();
    assert_eq!(before.len(), 1, "the launch's one look: {before:?}");
    let o = sweep_cmd(d)
        .args(["plan", file.to_str().unwrap(), "--db", db.to_str().unwrap()])
        .output()
        .unwrap();
    let text = stdout(&o);
    assert!(o.status.success(), "{text}\n{}", stderr(&o));
    assert!(
        text.contains("(a preview, not a look: nothing is stored and no α spent; ")
            && text.contains(" of 1 would be decided"),
        "{text}"
    );
    assert!(
        !text.lines().any(|l| l.contains("decided at look")),
        "no line reads as a look's verdicts:\n{text}"
    );
    assert_eq!(stored(), before, "plan stored nothing");
}

/// `sweep status --brief`: a campaign's jobs by state and its latest look's verdicts counted,
/// without a line per job.
#[test]
fn a_brief_status_counts_the_latest_looks_verdicts() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let (_, db) = launched_claims_campaign(d);
    let o = sweep_cmd(d)
        .args(["status", "--brief", "--db", db.to_str().unwrap()])
        .output()
        .unwrap();
    let text = stdout(&o);
    assert!(o.status.success(), "{text}\n{}", stderr(&o));
    // `rows` gives each value with its SQLite type: "text undecided".
    let verdict = rows(&db, "SELECT verdict FROM claim_verdicts")[0][0].replace("text ", "");
    let counts = ["supported", "contradicted", "undecided"]
        .map(|v| format!("{} {v}", usize::from(verdict == v)))
        .join(", ");
    assert!(
        text.contains("2 jobs — 2 done") && text.contains(&format!("claims at look 0: {counts}")),
        "{text}"
    );
    assert!(
        !text.contains("orifice_diameter_m="),
        "no job lines:\n{text}"
    );
}
