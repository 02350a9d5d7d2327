//! The accuracy–cost report on a synthetic silo accuracy campaign: jobs registered from a real
//! campaign file (n_c and Y swept in a zip, precision swept), results written by hand. Checks
//! that the reference is the f64, stiffest, smallest-dt job; that the paper's setting is found;
//! that each error is |Q − Q_ref|/Q_ref exactly (1e-12); and that a precision value other than
//! f64/f32 is refused with its path.

use rusqlite::params;
use sweep::campaign::{expand, CampaignFile};
use sweep::report::render_figure;

const CAMPAIGN: &str = r#"{
  "name": "acc",
  "scene": "silo",
  "base": {"particle_count": 500, "dt_s": null},
  "zip": {
    "contact_steps":     [50,    10,    50,    50],
    "youngs_modulus_pa": [3e9,   3e9,   3e9,   3e7],
    "shear_modulus_pa":  [1e8,   1e8,   1e8,   1e6],
    "precision":         ["f64", "f64", "f32", "f64"]
  }
}"#;

#[test]
fn errors_are_measured_against_the_most_accurate_job() {
    let c = CampaignFile::parse_str(CAMPAIGN, "acc.json").unwrap();
    let jobs = expand(&c, "acc.json").unwrap();
    assert_eq!(
        jobs.iter().map(|j| j.precision.name()).collect::<Vec<_>>(),
        ["f64", "f64", "f32", "f64"]
    );
    let dir = tempfile::TempDir::new().unwrap();
    let mut conn = sweep::store::open(&dir.path().join("a.db")).unwrap();
    sweep::store::jobs::register(&mut conn, "acc.json", &c, &jobs, false).unwrap();
    // Q per job (in registration order), and dt from n_c (only their order matters here).
    let q: [f64; 4] = [0.100, 0.130, 0.104, 0.091];
    let dt = [1e-6, 5e-6, 1e-6, 6e-6];
    for (k, j) in jobs.iter().enumerate() {
        let id: i64 = conn
            .query_row("SELECT id FROM jobs WHERE hash = ?1", [j.hash()], |r| {
                r.get(0)
            })
            .unwrap();
        conn.execute(
            "UPDATE jobs SET status = 'done', wall_time_s = ?2, particle_steps = 1000000 WHERE id = ?1",
            params![id, 10.0 * (k + 1) as f64],
        )
        .unwrap();
        conn.execute(
            "INSERT INTO discharge_summary (job_id, orifice_diameter_m, rotation_frequency_hz, particle_diameter_m,
                bulk_density_kg_per_m3, q_kg_per_s, q_ci95_kg_per_s, q_method, flowing_time_s, discharged_mass_kg,
                discharged_count, clogs, clogged_time_s, permanently_clogged)
             VALUES (?1, 0.036, 0, 0.0058, 1600, ?2, 0.005, 'test', 1, 0.1, 100, 0, 0, 0)",
            params![id, q[k]],
        )
        .unwrap();
        conn.execute(
            "INSERT INTO job_numerics (job_id, dt_s, steps, max_overlap_ratio, mean_contacts, list_builds)
             VALUES (?1, ?2, 1000, 0.01, 4.0, 10)",
            params![id, dt[k]],
        )
        .unwrap();
    }
    let out = dir.path().join("figs");
    let rep = render_figure(&conn, "accuracy", Some("acc"), &out).unwrap();
    assert!(
        rep.table.contains("reference (most accurate): job 1"),
        "{}",
        rep.table
    );
    assert!(rep.table.contains("paper setting: job 1"), "{}", rep.table);
    let csv = std::fs::read_to_string(out.join("silo_accuracy.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let q_col = header
        .iter()
        .position(|h| h.trim_matches('"') == "error_Q")
        .unwrap_or_else(|| panic!("no error_Q column in {header:?}"));
    let rows: Vec<Vec<String>> = csv
        .lines()
        .skip(1)
        .map(|l| {
            l.split(',')
                .map(|s| s.trim_matches('"').to_string())
                .collect()
        })
        .collect();
    assert_eq!(rows.len(), 4);
    for (k, row) in rows.iter().enumerate() {
        // Counted from the end: the setting column before it holds commas of its own.
        let err = &row[row.len() - (header.len() - q_col)];
        if k == 0 {
            assert_eq!(err, "reference");
            continue;
        }
        let got: f64 = err.parse().unwrap();
        let expect = (q[k] - q[0]).abs() / q[0];
        assert!(
            (got - expect).abs() <= 1e-3 * expect,
            "job {}: error {got} vs {expect} (the table prints 4 significant digits)",
            k + 1
        );
    }
    for ext in ["svg", "png"] {
        assert!(out.join(format!("silo_accuracy.{ext}")).exists());
    }
}

#[test]
fn a_bad_precision_is_refused_with_its_path() {
    let text = CAMPAIGN.replace("\"f32\"", "\"f16\"");
    let c = CampaignFile::parse_str(&text, "acc.json").unwrap();
    let e = expand(&c, "acc.json").unwrap_err().to_string();
    assert!(
        e.contains("zip.precision[2]") && e.contains("\"f64\" or \"f32\""),
        "{e}"
    );
}
