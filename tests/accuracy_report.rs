//! The accuracy–cost report on a synthetic silo accuracy campaign: jobs registered from a real
//! campaign file (n_c and Y swept in a zip, precision swept, two replicas each), results written
//! by hand. Checks that the replicas of a setting are pooled into one row; that the reference is
//! the f64, stiffest, smallest-dt setting; that the paper's setting is found; that each shift is
//! (Q̄ − Q̄_ref)/Q̄_ref with Welch's 95 % interval from the replicas' block errors, computed here
//! by hand (1e-3, the table's two decimals of a per cent); that the verdicts follow; and that a
//! precision value other than f64/f32 is refused with its path.

use rusqlite::params;
use sweep::campaign::{expand, CampaignFile};
use sweep::observe::fits::student_t_975;
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
  },
  "replicas": 2
}"#;

/// Q of each replica of each setting (settings in zip order), kg/s; every job's 95 % CI is
/// 0.005 kg/s from 10 blocks.
const Q: [[f64; 2]; 4] = [
    [0.100, 0.102],
    [0.130, 0.128],
    [0.104, 0.100],
    [0.091, 0.093],
];
const CI: f64 = 0.005;
const BLOCKS: i64 = 10;

#[test]
fn replicas_are_pooled_and_shifts_carry_welchs_interval() {
    let c = CampaignFile::parse_str(CAMPAIGN, "acc.json").unwrap();
    let jobs = expand(&c, "acc.json").unwrap();
    assert_eq!(jobs.len(), 8);
    let dir = tempfile::TempDir::new().unwrap();
    let mut conn = sweep::store::open(&dir.path().join("a.db")).unwrap();
    sweep::store::jobs::register(&mut conn, "acc.json", &c, &jobs, false).unwrap();
    let setting_of = |j: &sweep::campaign::JobSpec| {
        let p = j.silo();
        match (p.contact_steps, p.youngs_modulus_pa, j.precision.name()) {
            (Some(n), _, _) if n == 10.0 => 1,
            (_, y, _) if y == 3e7 => 3,
            (_, _, "f32") => 2,
            _ => 0,
        }
    };
    for j in &jobs {
        let (s, r) = (setting_of(j), j.silo().replica as usize);
        let id: i64 = conn
            .query_row("SELECT id FROM jobs WHERE hash = ?1", [j.hash()], |r| {
                r.get(0)
            })
            .unwrap();
        conn.execute(
            "UPDATE jobs SET status = 'done', wall_time_s = ?2, particle_steps = 1000000 WHERE id = ?1",
            params![id, 10.0 * (s + 1) as f64],
        )
        .unwrap();
        conn.execute(
            "INSERT INTO discharge_summary (job_id, orifice_diameter_m, rotation_frequency_hz, particle_diameter_m,
                bulk_density_kg_per_m3, q_kg_per_s, q_ci95_kg_per_s, q_method, flowing_time_s, discharged_mass_kg,
                discharged_count, clogs, clogged_time_s, permanently_clogged, q_blocks)
             VALUES (?1, 0.036, 0, 0.0058, 1600, ?2, ?3, 'test', 1, 0.1, 100, 0, 0, 0, ?4)",
            params![id, Q[s][r], CI, BLOCKS],
        )
        .unwrap();
        // dt from n_c (only their order matters here).
        let dt = [1e-6, 5e-6, 1e-6, 6e-6][s];
        conn.execute(
            "INSERT INTO job_numerics (job_id, dt_s, steps, max_overlap_ratio, mean_contacts, list_builds)
             VALUES (?1, ?2, 1000, 0.01, 4.0, 10)",
            params![id, dt],
        )
        .unwrap();
    }
    let out = dir.path().join("figs");
    let rep = render_figure(&conn, "accuracy", Some("acc"), &out).unwrap();
    assert!(
        rep.table.contains("8 done job(s) in 4 setting(s)")
            && rep.table.contains("reference (most accurate): setting 1"),
        "{}",
        rep.table
    );
    assert!(
        rep.table.contains("paper setting: setting 1"),
        "{}",
        rep.table
    );
    let csv = std::fs::read_to_string(out.join("silo_accuracy.csv")).unwrap();
    let mut lines = csv.lines().map(csv_cells);
    let header = lines.next().unwrap();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("no {name} column in {header:?}"))
    };
    let rows: Vec<Vec<String>> = lines.collect();
    assert_eq!(rows.len(), 4, "one row per setting");
    // By hand: a job's se = CI / t₉; two equal replicas pool to se/√2 (dof 18); the shift's
    // variance is se²/2 + se²/2 = se² with Welch's dof 36.
    let se = CI / student_t_975(BLOCKS as usize - 1);
    let half = student_t_975(36) * se;
    let mean = |s: usize| (Q[s][0] + Q[s][1]) / 2.0;
    for (s, row) in rows.iter().enumerate() {
        assert_eq!(&row[col("replicas")], "2");
        assert_eq!(&row[col("reference_replicas")], "2");
        if s == 0 {
            assert_eq!(&row[col("verdict")], "reference");
            continue;
        }
        let got: f64 = row[col("shift_Q_pct")].parse().unwrap();
        let expect = 100.0 * (mean(s) - mean(0)) / mean(0);
        assert!(
            (got - expect).abs() < 6e-3,
            "setting {s}: shift {got} vs {expect} %"
        );
        let got_ci: f64 = row[col("ci95_Q_pct")].parse().unwrap();
        let expect_ci = 100.0 * half / mean(0);
        assert!(
            (got_ci - expect_ci).abs() < 6e-3,
            "setting {s}: CI {got_ci} vs {expect_ci} %"
        );
        let verdict = if expect.abs() <= expect_ci {
            "within noise"
        } else {
            "shifted"
        };
        assert_eq!(&row[col("verdict")], verdict, "setting {s}");
    }
    // The synthetic values were chosen so that both verdicts occur.
    let verdicts: Vec<&str> = rows.iter().map(|r| r[col("verdict")].as_str()).collect();
    assert_eq!(
        verdicts,
        ["reference", "shifted", "within noise", "shifted"]
    );
    for ext in ["svg", "png"] {
        assert!(out.join(format!("silo_accuracy.{ext}")).exists());
    }
}

/// The cells of one CSV line (quoted cells may hold commas; "" is a quote).
fn csv_cells(line: &str) -> Vec<String> {
    let (mut out, mut cell, mut quoted) = (Vec::new(), String::new(), false);
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '"' if quoted && chars.peek() == Some(&'"') => {
                cell.push('"');
                chars.next();
            }
            '"' => quoted = !quoted,
            ',' if !quoted => out.push(std::mem::take(&mut cell)),
            c => cell.push(c),
        }
    }
    out.push(cell);
    out
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
