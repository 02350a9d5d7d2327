//! Claims on the silo's kinetic pressure at the orifice (`kinetic_pressure`, the paper's
//! Fig. 11): a tiny campaign with the field observer and two replicas of one point; the claim's
//! value is the point's ⟨p^k⟩ exactly as fig11 pools it (the replicas' mean, read from its CSV),
//! and its interval holds the mean of the two jobs' own averages, computed here from the stored
//! series.

use serde_json::json;

use crate::common::cli::{campaign, launch_ok, sweep_cmd};

#[test]
fn a_claim_reads_the_kinetic_pressure_fig11_draws() {
    let dir = tempfile::tempdir().unwrap();
    let mut c = campaign("tiny_pk", &[0.02], &[1.0], 0.2);
    c["replicas"] = json!(2);
    c["observers"]["fields"] = json!({
        "sample_interval_s": 0.05,
        "map_times_s": [0.2],
        "map_window_s": 0.1,
        "mean_start_s": 0.1
    });
    c["claims"] = json!([{
        "id": "pk_positive",
        "paper": "PRE 102, 042902, Fig. 11",
        "statement": "The kinetic pressure at the orifice is positive.",
        "paper_value": "positive",
        "compare": {
            "result": "kinetic_pressure",
            "at": { "orifice_diameter_m": 0.02, "rotation_frequency_hz": 1.0 },
            "value": 0.0,
            "as": "difference",
            "above": 0.0
        }
    }]);
    let file = dir.path().join("tiny_pk.json");
    std::fs::write(&file, serde_json::to_string_pretty(&c).unwrap()).unwrap();
    let db = dir.path().join("pk.db");
    launch_ok(dir.path(), &file, &db);
    let out = dir.path().join("out");
    for args in [
        vec!["report", "--claims"],
        vec!["report", "--figure", "fig11"],
    ] {
        sweep_cmd(dir.path())
            .args(&args)
            .args(["--campaign", "tiny_pk", "--db"])
            .arg(&db)
            .arg("--out")
            .arg(&out)
            .assert()
            .success();
    }
    let read = |name: &str| -> Vec<Vec<String>> {
        std::fs::read_to_string(out.join(name))
            .unwrap()
            .lines()
            .map(csv_fields)
            .collect()
    };
    let col = |rows: &[Vec<String>], name: &str| rows[0].iter().position(|h| h == name).unwrap();
    let claims = read("tiny_pk.csv");
    let fig = read("fig11.csv");
    let value: f64 = claims[1][col(&claims, "value")]
        .parse()
        .expect("a claim value");
    let (lo, hi): (f64, f64) = (
        claims[1][col(&claims, "lo")].parse().unwrap(),
        claims[1][col(&claims, "hi")].parse().unwrap(),
    );
    let pk: f64 = fig[1][col(&fig, "pk_pa")].parse().unwrap();
    assert_eq!(fig[1][col(&fig, "jobs")], "2", "{fig:?}");
    assert!(
        (value - pk).abs() <= 1e-9 * pk.abs(),
        "claim {value} Pa, fig11 {pk} Pa"
    );
    // Each job's mean over its flowing samples, from the store.
    let conn = rusqlite::Connection::open(&db).unwrap();
    let mut means = Vec::new();
    for job in [1, 2] {
        let s = sweep::store::fields::load_flagged_series(&conn, job, "orifice_kinetic_pressure")
            .unwrap();
        let flowing: Vec<f64> = s
            .iter()
            .filter(|x| x.flowing != Some(false))
            .map(|x| x.value)
            .collect();
        assert!(!flowing.is_empty(), "job {job} has no flowing sample");
        means.push(flowing.iter().sum::<f64>() / flowing.len() as f64);
    }
    let mean = 0.5 * (means[0] + means[1]);
    assert!(
        value > 0.0 && (value - mean).abs() <= 1e-9 * mean,
        "{value} vs {means:?}"
    );
    assert!(lo < value && value < hi, "[{lo}, {hi}] around {value}");
}

/// The fields of one CSV line (RFC 4180: quoted fields may hold commas and doubled quotes).
fn csv_fields(line: &str) -> Vec<String> {
    let mut out = vec![String::new()];
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '"' if quoted && chars.peek() == Some(&'"') => {
                chars.next();
                out.last_mut().unwrap().push('"');
            }
            '"' => quoted = !quoted,
            ',' if !quoted => out.push(String::new()),
            _ => out.last_mut().unwrap().push(c),
        }
    }
    out
}
