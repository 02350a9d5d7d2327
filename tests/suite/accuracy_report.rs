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
        if p.contact_steps == Some(10.0) {
            1
        } else if p.youngs_modulus_pa == 3e7 {
            3
        } else if j.precision.name() == "f32" {
            2
        } else {
            0
        }
    };
    for j in jobs.iter() {
        let (s, r) = (setting_of(&j), j.silo().replica as usize);
        let id: i64 = conn
            .query_row("SELECT id FROM jobs WHERE hash = ?1", [j.hash()], |r| {
                r.get(0)
            })
            .unwrap();
        conn.execute(
            "UPDATE jobs SET status = 'done', wall_time_s = ?2, cpu_time_s = ?2 / 2,
                 particle_steps = 1000000 WHERE id = ?1",
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
    // Every job counted its CPU time (half its wall time here): the map draws it as the cost.
    assert!(
        rep.table
            .contains("cost drawn: CPU time per replica (s) (every job counted it)"),
        "{}",
        rep.table
    );
    for (s, row) in rows.iter().enumerate() {
        assert_eq!(
            row[col("wall_s_per_replica")],
            format!("{:.1}", 10.0 * (s + 1) as f64)
        );
        assert_eq!(
            row[col("cpu_s_per_replica")],
            format!("{:.1}", 5.0 * (s + 1) as f64)
        );
    }
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

/// A chute accuracy campaign of one replica per setting: the bulk D of a job is the mean of D_z
/// over its central blocks (0.2 H < z < 0.8 H) with the standard error √(Σ se²)/n of their
/// window errors (4 windows: 3 degrees of freedom); the shift's interval is Welch's from the
/// two jobs' errors. Blocks outside the centre (one without an error) are left out.
#[test]
fn a_chute_setting_of_one_replica_uses_its_window_errors() {
    let text = r#"{"name": "accc", "scene": "chute", "base": {"measure_time_s": 8.0},
                   "zip": {"contact_steps": [100, 50, 10]}}"#;
    let c = CampaignFile::parse_str(text, "accc.json").unwrap();
    let jobs = expand(&c, "accc.json").unwrap();
    let dir = tempfile::TempDir::new().unwrap();
    let mut conn = sweep::store::open(&dir.path().join("c.db")).unwrap();
    sweep::store::jobs::register(&mut conn, "accc.json", &c, &jobs, false).unwrap();
    // D_z (m²/s) and its standard error per block at z = 0.1, 0.3, 0.5, 0.7, 0.9 m (H = 1 m).
    let d: [[f64; 5]; 3] = [
        [9.0, 1.00, 1.10, 0.90, 5.0],
        [9.0, 1.02, 1.06, 0.98, 5.0],
        [9.0, 1.30, 1.40, 1.20, 5.0],
    ];
    let se = [0.03, 0.04, 0.05];
    for (k, j) in jobs.iter().enumerate() {
        let id: i64 = conn
            .query_row("SELECT id FROM jobs WHERE hash = ?1", [j.hash()], |r| {
                r.get(0)
            })
            .unwrap();
        conn.execute(
            "UPDATE jobs SET status = 'done', wall_time_s = ?2, particle_steps = 1000000 WHERE id = ?1",
            params![id, 100.0 / (k + 1) as f64],
        )
        .unwrap();
        conn.execute(
            "INSERT INTO chute_summary (job_id, aspect_ratio, inclination_deg, total_length_m, diameter_m,
                particles, bed_height_m, measure_start_s, measure_end_s, samples, msd_fit_min_lag_s,
                msd_fit_max_lag_s, mean_cos_theta, d_perp_m, cg_width_m, steady)
             VALUES (?1, 1.5, 30, 0.1, 0.05, 500, 1.0, 10, 18, 160, 1, 3, 0.5, 0.06, 0.025, 1)",
            params![id],
        )
        .unwrap();
        for (b, z) in [0.1, 0.3, 0.5, 0.7, 0.9].iter().enumerate() {
            let err = (b > 0).then_some(se[(b + k) % 3]);
            conn.execute(
                "INSERT INTO chute_blocks (job_id, block, z_m, diffusion_m2_per_s,
                    diffusion_stderr_m2_per_s, shear_rate_per_s, velocity_x_m_per_s,
                    solid_fraction, mean_particles)
                 VALUES (?1, ?2, ?3, ?4, ?5, 2.0, 1.0, 0.5, 40)",
                params![id, b as i64, z, d[k][b], err],
            )
            .unwrap();
        }
    }
    let out = dir.path().join("figs");
    let rep = render_figure(&conn, "accuracy", Some("accc"), &out).unwrap();
    let csv = std::fs::read_to_string(out.join("chute_accuracy.csv")).unwrap();
    let mut lines = csv.lines().map(csv_cells);
    let header = lines.next().unwrap();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("no {name} column in {header:?}"))
    };
    let rows: Vec<Vec<String>> = lines.collect();
    assert_eq!(rows.len(), 3, "{}", rep.table);
    // No job counted its CPU time (ran before it was counted): the wall time is the cost.
    assert!(
        rep.table
            .contains("cost drawn: wall time per replica (s) (some jobs ran before"),
        "{}",
        rep.table
    );
    assert!(rows.iter().all(|r| r[col("cpu_s_per_replica")] == "-"));
    // Each central triple has the errors 0.03, 0.04, 0.05 in some order.
    let se_job = (0.03f64.powi(2) + 0.04f64.powi(2) + 0.05f64.powi(2)).sqrt() / 3.0;
    let half = student_t_975(6) * (2.0 * se_job * se_job).sqrt();
    let bulk = |k: usize| (d[k][1] + d[k][2] + d[k][3]) / 3.0;
    let ci_ref: f64 = rows[0][col("ci95_D_pct")].parse().unwrap();
    assert!(
        (ci_ref - 100.0 * student_t_975(3) * se_job / bulk(0)).abs() < 6e-3,
        "the reference's own interval: {ci_ref}"
    );
    for (k, verdict) in [(1, "within noise"), (2, "shifted")] {
        let row = &rows[k];
        let shift: f64 = row[col("shift_D_pct")].parse().unwrap();
        let ci: f64 = row[col("ci95_D_pct")].parse().unwrap();
        let expect = 100.0 * (bulk(k) - bulk(0)) / bulk(0);
        assert!((shift - expect).abs() < 6e-3, "{shift} vs {expect}");
        assert!((ci - 100.0 * half / bulk(0)).abs() < 6e-3, "{ci}");
        assert_eq!(row[col("verdict")], verdict);
        assert_eq!(row[col("replicas")], "1");
    }
}
