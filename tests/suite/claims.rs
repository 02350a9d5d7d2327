//! Claims end to end (`"claims"` in a campaign file, `"target": {"claims": "decided"}`): a tiny
//! refilled silo whose compare claim is undecided after its first runs and decided after rounds
//! of added work; the rounds and verdicts are the same bits after a kill and `sweep resume`;
//! bad claims are refused by field with nothing registered; claims are part of the file's
//! version but not of any job's identity; `sweep report --claims` writes the table.

use std::path::Path;

use crate::common::cli::*;
use serde_json::{json, Value};
use tempfile::TempDir;

/// Four points (D = 3.4 d and 4.1 d × f = 0 and 1 Hz), 600 particles, 1 s each to start with,
/// and one claim on two of them, at f = 1 Hz: Q(4.1 d) / Q(3.4 d) > 2.5 (Beverloo's law with
/// k = 2 gives 2.6; D^{5/2} alone 1.58). The tiny silo gives about 2.45 with a wide spread
/// between replicas, so the claim stays undecided.
fn tiny_claims(allocation: &str) -> Value {
    tiny_claims_above(allocation, 2.5)
}

/// `tiny_claims` with the claim's bound at `above`. At 4 (Beverloo's law with k = 2.7) the first
/// look straddles it and the first round contradicts it.
fn tiny_claims_above(allocation: &str, above: f64) -> Value {
    let mut c = campaign("tiny_claims", &[0.02, 0.024], &[0.0, 1.0], 0.2);
    let base = c["base"].as_object_mut().unwrap();
    base.insert("particle_count".into(), json!(600));
    base.insert("discharge_time_s".into(), json!(1.0));
    base.insert("reinsert".into(), json!(true));
    c["target"] = json!({
        "claims": "decided", "max_replicas": 3, "max_time_s": 6.0, "max_rounds": 6,
        "allocation": allocation
    });
    c["claims"] = json!([{
        "id": "q_faster_than_d", "paper": "PRE 102, 042902, Fig. 3",
        "statement": "Q(4.1 d) / Q(3.4 d) exceeds 2.5 (Beverloo, k = 2)",
        "compare": {
            "result": "q",
            "at": { "orifice_diameter_m": 0.024, "rotation_frequency_hz": 1.0 },
            "against": { "orifice_diameter_m": 0.02, "rotation_frequency_hz": 1.0 },
            "above": above
        }
    }]);
    c
}

/// Every look's verdicts, bit for bit (wall times left out: they are the machine's).
fn verdicts(db: &Path) -> Vec<Vec<String>> {
    rows(
        db,
        "SELECT round, claim_id, verdict, value, lo, hi, level, bound, points, note, particle_steps,
                forecast_particle_steps
         FROM claim_verdicts ORDER BY round, claim_id",
    )
}

fn work(db: &Path) -> Vec<Vec<String>> {
    rows(
        db,
        "SELECT w.round, w.point, j.hash, w.action, w.from_s, w.to_s FROM target_work w
         JOIN jobs j ON j.id = w.job_id ORDER BY w.id",
    )
}

/// `sweep launch FILE --db DB` with `extra` arguments, whatever its exit status.
fn launch_with(dir: &Path, file: &Path, db: &Path, extra: &[&str]) -> std::process::Output {
    sweep_cmd(dir)
        .args([
            "launch",
            file.to_str().unwrap(),
            "--db",
            db.to_str().unwrap(),
        ])
        .args(extra)
        .output()
        .unwrap()
}

/// A bound the tiny silo's claim is decided against after a round.
const DECIDED_ABOVE: f64 = 4.0;

fn launch_claims(dir: &Path, allocation: &str, above: f64) -> (std::path::PathBuf, String) {
    let file = write_campaign(dir, "c.json", &tiny_claims_above(allocation, above));
    let db = dir.join("sweep.db");
    let o = launch_ok(dir, &file, &db);
    (db, stdout(&o))
}

#[test]
fn a_claim_is_decided_over_rounds_and_the_same_after_a_kill() {
    let a = TempDir::new().unwrap();
    let (db_a, out) = launch_claims(a.path(), "adaptive", DECIDED_ABOVE);
    let looks = verdicts(&db_a);
    assert!(
        looks.len() >= 2,
        "decided at the first look: no round was needed\n{out}"
    );
    assert_eq!(looks[0][2], "text undecided", "{looks:?}\n{out}");
    let last = looks.last().unwrap();
    assert_eq!(last[2], "text contradicted", "{looks:?}\n{out}");
    assert!(
        out.contains("claims: stopped: every claim is decided"),
        "{out}"
    );
    // Only the claim's points got work; the two at f = 0 Hz never did.
    for w in work(&db_a) {
        assert!(w[1].contains("rotation_frequency_hz=1"), "{w:?}");
    }
    // `sweep status` and `sweep report --claims` show the verdict.
    let st = sweep_cmd(a.path())
        .args(["status", "--db", db_a.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(stdout(&st).contains("q_faster_than_d"), "{}", stdout(&st));
    let rep = sweep_cmd(a.path())
        .args([
            "report",
            "--claims",
            "--db",
            db_a.to_str().unwrap(),
            "--out",
            "figs",
        ])
        .output()
        .unwrap();
    assert!(rep.status.success(), "{}", stderr(&rep));
    let md = std::fs::read_to_string(a.path().join("figs/tiny_claims.md")).unwrap();
    assert!(
        md.contains("**contradicted**") && md.contains("N = 600"),
        "{md}"
    );
    let csv = std::fs::read_to_string(a.path().join("figs/tiny_claims.csv")).unwrap();
    assert_eq!(csv.lines().count(), 2, "{csv}");
    // Each look recorded what had been spent by then: look 0 less than the last look, whose
    // cost the table states.
    let spent = |round: usize| {
        read_db(&db_a)
            .query_row(
                "SELECT particle_steps FROM claim_looks WHERE round = ?1",
                [round],
                |r| r.get::<_, f64>(0),
            )
            .unwrap()
    };
    let (first, last) = (spent(0), spent(looks.len() - 1));
    assert!(
        0.0 < first && first < last,
        "look 0: {first}, last look: {last}"
    );
    assert!(
        md.contains(&format!("Spent by this look: {last:.3e} particle-steps")),
        "{last:.3e}\n{md}"
    );

    // Killed once a round's work is running, then resumed: the same rounds and verdicts.
    let b = TempDir::new().unwrap();
    let file = write_campaign(
        b.path(),
        "c.json",
        &tiny_claims_above("adaptive", DECIDED_ABOVE),
    );
    let db_b = b.path().join("sweep.db");
    launch_killed_in_a_round(b.path(), &file, &db_b);
    let o = resume(b.path(), &db_b);
    assert!(o.status.success(), "{}\n{}", stdout(&o), stderr(&o));
    assert_eq!(work(&db_a), work(&db_b), "other rounds after the kill");
    assert_eq!(
        verdicts(&db_a),
        verdicts(&db_b),
        "other verdicts after the kill"
    );
    assert_same_results(&results(&db_a), &results(&db_b));
}

#[test]
fn bad_claims_are_refused_by_field_and_nothing_is_registered() {
    let dir = TempDir::new().unwrap();
    let mut c = tiny_claims("adaptive");
    c["claims"][0]["compare"]["at"]["orifice_diameter_m"] = json!(0.03);
    c["claims"].as_array_mut().unwrap().push(json!({
        "id": "q_faster_than_d", "statement": "twice",
        "trend": { "result": "D", "along": "rotation_frequency_hz", "at": { "orifice_diameter_m": 0.02 }, "direction": "rising" }
    }));
    let file = write_campaign(dir.path(), "bad.json", &c);
    let db = dir.path().join("sweep.db");
    let o = launch_with(dir.path(), &file, &db, &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    let e = stderr(&o);
    for expected in [
        "bad.json",
        "claims[0].compare.at",
        "no point of the campaign has orifice_diameter_m=0.03",
        "claims[1].id",
        "claims[1].trend.result",
        "'D' is not a result of this scene; expected one of q",
    ] {
        assert!(e.contains(expected), "missing {expected:?} in:\n{e}");
    }
    assert!(!db.exists() || count(&db, "SELECT COUNT(*) FROM jobs") == 0);
    // A claims target without claims, and a chute claim without 3 replicas.
    let mut c = tiny_claims("adaptive");
    c.as_object_mut().unwrap().remove("claims");
    let file = write_campaign(dir.path(), "none.json", &c);
    let o = sweep_cmd(dir.path())
        .args(["plan", file.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("target.claims"), "{}", stderr(&o));
    let mut chute = tiny_chute("tiny_chute_claims", "f32", 0.5);
    chute["claims"] = json!([{ "id": "d", "statement": "D > 0",
        "compare": { "result": "D", "at": {}, "value": 0.0, "as": "difference", "above": 0.0 } }]);
    let file = write_campaign(dir.path(), "chute.json", &chute);
    let o = sweep_cmd(dir.path())
        .args(["plan", file.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("replicas") && stderr(&o).contains("at least 3"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn claims_are_part_of_the_version_not_of_job_identity() {
    let dir = TempDir::new().unwrap();
    let mut plain = tiny_claims("adaptive");
    plain.as_object_mut().unwrap().remove("claims");
    plain.as_object_mut().unwrap().remove("target");
    plain["base"]["discharge_time_s"] = json!(0.3);
    let file = write_campaign(dir.path(), "c.json", &plain);
    let db = dir.path().join("sweep.db");
    launch_ok(dir.path(), &file, &db);
    let hashes = rows(&db, "SELECT hash FROM jobs ORDER BY hash");
    // The same study with a claim: the file changed (refused without --new-version) ...
    let mut claimed = plain.clone();
    claimed["claims"] = tiny_claims("adaptive")["claims"].clone();
    let file = write_campaign(dir.path(), "c.json", &claimed);
    let o = launch_with(dir.path(), &file, &db, &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    assert!(stderr(&o).contains("claims: (absent) ->"), "{}", stderr(&o));
    // ... and as version 2 it shares every job: nothing new is run.
    let o = launch_with(dir.path(), &file, &db, &["--new-version"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("0 new"), "{}", stdout(&o));
    assert_eq!(rows(&db, "SELECT hash FROM jobs ORDER BY hash"), hashes);
    // Without a target its claim is looked at once, by the report, at 95 %.
    let rep = sweep_cmd(dir.path())
        .args([
            "report",
            "--claims",
            "--db",
            db.to_str().unwrap(),
            "--out",
            "figs",
        ])
        .output()
        .unwrap();
    assert!(rep.status.success(), "{}", stderr(&rep));
    assert!(stdout(&rep).contains("q_faster_than_d"), "{}", stdout(&rep));
    assert!(stdout(&rep).contains("95.00 %"), "{}", stdout(&rep));
}

#[test]
fn a_sigterm_during_a_round_pauses_its_job() {
    let dir = TempDir::new().unwrap();
    let file = write_campaign(dir.path(), "c.json", &tiny_claims("adaptive"));
    let db = dir.path().join("sweep.db");
    let mut child = launch_until_a_round_runs(dir.path(), &file, &db);
    let ok = std::process::Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(ok.success());
    // The round's pool sees the signal: its job checkpoints and the launch ends paused (75).
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(75), "{status:?}");
    let paused = count(
        &db,
        "SELECT COUNT(*) FROM target_work w JOIN jobs j ON j.id = w.job_id WHERE j.status = 'paused'",
    );
    assert!(paused >= 1, "no round job paused");
}

/// Version 1 looks twice (its one round adds replicas), so it spends all of α; version 2 adds a
/// frequency. It carries over the two looks, their α and the replicas at the points it keeps:
/// its first look is look 2, and with no α left it decides nothing and adds no work.
#[test]
fn a_new_version_carries_the_looks_alpha_and_replicas_of_the_last() {
    let dir = TempDir::new().unwrap();
    let mut v1 = tiny_claims("adaptive");
    v1["target"] = json!({ "claims": "decided", "max_replicas": 3, "max_rounds": 1 });
    let file = write_campaign(dir.path(), "c.json", &v1);
    let db = dir.path().join("sweep.db");
    let out = stdout(&launch_ok(dir.path(), &file, &db));
    let levels = rows(
        &db,
        "SELECT round, MIN(level) FROM claim_verdicts WHERE campaign_id = 1 GROUP BY round",
    );
    assert_eq!(levels.len(), 2, "{levels:?}\n{out}");
    let added = "SELECT j.hash FROM campaign_jobs cj JOIN jobs j ON j.id = cj.job_id
                 WHERE cj.campaign_id = ?1 AND cj.origin = 'target' ORDER BY j.hash";
    let v1_added = rows(&db, &added.replace("?1", "1"));
    assert!(!v1_added.is_empty(), "round 1 added no replica\n{out}");

    let mut v2 = v1.clone();
    v2["sweep"]["rotation_frequency_hz"] = json!([0.0, 0.5, 1.0]);
    let file = write_campaign(dir.path(), "c.json", &v2);
    let o = launch_with(dir.path(), &file, &db, &["--new-version"]);
    assert!(o.status.success(), "{}\n{}", stdout(&o), stderr(&o));
    assert_eq!(rows(&db, &added.replace("?1", "2")), v1_added);
    let carried = rows(
        &db,
        "SELECT looks_carried, ABS(alpha_carried - 0.05) < 1e-12 FROM campaigns WHERE version = 2",
    );
    assert_eq!(carried[0][0], "int 2", "{carried:?}");
    assert_eq!(carried[0][1], "int 1", "{carried:?}");
    let v2_looks = rows(
        &db,
        "SELECT round, verdict, note FROM claim_verdicts WHERE campaign_id = 2",
    );
    assert_eq!(v2_looks.len(), 1, "{v2_looks:?}");
    assert_eq!(v2_looks[0][0], "int 2", "{v2_looks:?}");
    assert_eq!(v2_looks[0][1], "text undecided", "{v2_looks:?}");
    assert!(
        v2_looks[0][2].contains("no error rate left"),
        "{v2_looks:?}"
    );
    assert!(
        stdout(&o).contains("no error rate is left"),
        "{}",
        stdout(&o)
    );
    assert!(rows(&db, "SELECT id FROM target_work WHERE campaign_id = 2").is_empty());
    // The carried replicas are the target's, not the file's: the same file again is no change.
    let o = launch_with(dir.path(), &file, &db, &[]);
    assert!(o.status.success(), "{}\n{}", stdout(&o), stderr(&o));
    // Each version's claims table keeps its own file in one directory.
    for name in ["tiny_claims@v1", "tiny_claims"] {
        let o = sweep_cmd(dir.path())
            .args(["report", "--claims", "--campaign", name, "--out", "claims"])
            .args(["--db", db.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let table = |f: &str| std::fs::read_to_string(dir.path().join("claims").join(f)).unwrap();
    assert!(
        table("tiny_claims@v1.md").contains("Look 1:"),
        "{}",
        table("tiny_claims@v1.md")
    );
    assert!(
        table("tiny_claims.md").contains("Look 2:"),
        "{}",
        table("tiny_claims.md")
    );
}

/// A look recorded once stands: evaluated again on the same data (a resume after the campaign
/// ended, a later build that reads them otherwise), its stored row is kept and the difference
/// is said, not written over the record; a job finished since brings new data, and the look is
/// taken again.
#[test]
fn a_recorded_look_stands_when_its_data_read_otherwise() {
    let dir = TempDir::new().unwrap();
    let (db, _) = launch_claims(dir.path(), "adaptive", DECIDED_ABOVE);
    let last = count(&db, "SELECT MAX(round) FROM claim_verdicts");
    // Stand-in for a record taken under another reading of the same results.
    let conn = rusqlite::Connection::open(&db).unwrap();
    conn.execute(
        "UPDATE claim_verdicts SET value = 2.2, lo = 2.0, hi = 2.4 WHERE round = ?1",
        [last],
    )
    .unwrap();
    drop(conn);
    let before = verdicts(&db);

    let o = resume(dir.path(), &db);
    let out = stdout(&o);
    assert!(o.status.success(), "{out}\n{}", stderr(&o));
    assert!(
        out.contains(&format!(
            "claims: q_faster_than_d: look {last} stands as recorded (contradicted 2.2000 [2.0000, 2.4000]); its data read today give contradicted "
        )),
        "{out}"
    );
    assert_eq!(verdicts(&db), before, "the record is kept as it was");

    // A job that finished after the look (retried, extended) brings new data: the look is
    // taken again on them.
    let conn = rusqlite::Connection::open(&db).unwrap();
    conn.execute(
        "UPDATE jobs SET finished_at = '2999-01-01T00:00:00.000Z' WHERE id = 1",
        [],
    )
    .unwrap();
    drop(conn);
    let o = resume(dir.path(), &db);
    let out = stdout(&o);
    assert!(o.status.success(), "{out}\n{}", stderr(&o));
    assert!(!out.contains("stands as recorded"), "{out}");
    assert_ne!(verdicts(&db), before, "the look is read again");
}

/// `sweep plan` says when a claims campaign's own jobs alone forecast more core-hours than its
/// `max_core_hours`, or more particle-steps than its `max_particle_steps`: the caps stop only
/// added rounds, so they would run past them.
#[test]
fn plan_says_when_the_first_runs_alone_exceed_a_cap() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let db = d.join("plan.db");
    // 10⁴ particle-steps/s: the four 600-particle jobs forecast about 0.1 core-hours each.
    bench_row(&db, "silo-bed", "cpu", 1, 1.0e4);
    let plan = |cap: f64| {
        let mut c = tiny_claims("adaptive");
        c["base"]["precision"] = json!("f32");
        c["target"]["max_core_hours"] = json!(cap);
        let file = write_campaign(d, "c.json", &c);
        let o = sweep_cmd(d)
            .args(["plan", file.to_str().unwrap(), "--db", db.to_str().unwrap()])
            .args(["--threads", "1"])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}\n{}", stdout(&o), stderr(&o));
        stdout(&o)
    };
    let steps_over = {
        let mut c = tiny_claims("adaptive");
        c["target"]["max_particle_steps"] = json!(1.0e6);
        let file = write_campaign(d, "s.json", &c);
        let o = sweep_cmd(d)
            .args(["plan", file.to_str().unwrap(), "--db", db.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}\n{}", stdout(&o), stderr(&o));
        stdout(&o)
    };
    assert!(
        steps_over.contains("over the target's max_particle_steps 1.000e6: they run in full"),
        "{steps_over}"
    );
    let over = plan(0.05);
    assert!(
        over.contains("core-hours, over the target's max_core_hours 0.05: they run in full"),
        "{over}"
    );
    let under = plan(1000.0);
    assert!(
        under.contains("on this machine") && !under.contains("they run in full"),
        "{under}"
    );
}

/// A particle-step budget stops the rounds once the campaign's work reaches it, whatever the
/// core-hours: a tiny one is spent by the first runs, so look 0 is the last.
#[test]
fn a_spent_particle_step_budget_adds_no_round() {
    let dir = TempDir::new().unwrap();
    let mut c = tiny_claims_above("adaptive", DECIDED_ABOVE);
    c["target"]["max_particle_steps"] = json!(1000.0);
    let file = write_campaign(dir.path(), "c.json", &c);
    let db = dir.path().join("sweep.db");
    let out = stdout(&launch_ok(dir.path(), &file, &db));
    assert!(
        out.contains("claims: stopped: the budget is spent (")
            && out.contains(" of 1.000e3 particle-steps"),
        "{out}"
    );
    assert_eq!(verdicts(&db).len(), 1, "one look, no round\n{out}");
    assert!(work(&db).is_empty(), "no work added\n{out}");
}

/// A particle-step cap that leaves, after the tiny silo's look 0 (6.59e7 particle-steps),
/// room for two of its uniform round's four pieces (1.55e7 and 1.86e7 expected, then 1.55e7).
const ROUND_CUT_CAP: f64 = 1.05e8;

#[test]
fn a_round_is_cut_to_the_budget_left() {
    let dir = TempDir::new().unwrap();
    let mut c = tiny_claims_above("uniform", DECIDED_ABOVE);
    c["target"]["max_particle_steps"] = json!(ROUND_CUT_CAP);
    let file = write_campaign(dir.path(), "c.json", &c);
    let db = dir.path().join("sweep.db");
    let out = stdout(&launch_ok(dir.path(), &file, &db));
    assert!(
        out.contains("the budget left (3.91e7 particle-steps) covers 2 of 4 work item(s)"),
        "the round was not cut as sized (did the tiny silo's cost change?)\n{out}"
    );
    let num = |s: &str| {
        s.split_whitespace()
            .nth(s.starts_with("int").into())
            .unwrap()
            .parse::<f64>()
            .unwrap()
    };
    let spent: Vec<f64> = rows(&db, "SELECT particle_steps FROM claim_looks ORDER BY round")
        .iter()
        .map(|r| num(&r[0]))
        .collect();
    let planned = rows(
        &db,
        "SELECT round, SUM(particle_steps_expected), COUNT(*) FROM target_work GROUP BY round ORDER BY round",
    );
    assert_eq!(planned[0][2], "int 2", "{planned:?}\n{out}");
    // Every round fits in what the look before it left.
    for r in &planned {
        let round = num(&r[0]) as usize;
        assert!(
            spent[round - 1] + num(&r[1]) <= ROUND_CUT_CAP,
            "round {round} passes the cap: {spent:?} {planned:?}\n{out}"
        );
    }
}
