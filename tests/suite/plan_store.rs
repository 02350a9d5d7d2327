//! `sweep plan FILE --db DB` against a store that already holds some of the file's jobs: each
//! such job is named with its state, and the work still to run leaves out what ended.

use tempfile::TempDir;

use crate::common::cli::{campaign, launch_ok, stderr, stdout, sweep_cmd, write_campaign};

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
