//! The chute figures (Soft Matter 2022, Figs. 2–7) drawn from a synthetic campaign whose rows
//! obey D = c γ̇ d_⊥² exactly, with a shear rate linear in z. Every figure must write its SVG, PNG
//! and CSV; Fig. 6 must give back c as the slope with R = 1; Fig. 3 must normalise D by its
//! maximum; jobs that are not done must be listed; and the campaign's scene must pick the figure
//! set (a silo figure asked of a chute campaign is an error naming the scene).

use std::path::Path;

use rusqlite::{params, Connection};
use sweep::report::render_figure;

/// The coefficient of the synthetic law D = C γ̇ d_⊥².
const C: f64 = 0.0731;
/// Particle length L, m (the paper's 2/16 m).
const L: f64 = 0.125;
/// Bed height H = 20 L, m.
const H: f64 = 20.0 * L;
const BLOCKS: i64 = 20;
/// (ξ, α) of the done jobs with a summary.
const CASES: [(f64, f64); 6] = [
    (1.0, 24.0),
    (1.3, 26.0),
    (1.3, 27.0),
    (1.3, 28.0),
    (2.5, 29.0),
    (2.5, 30.0),
];
const PENDING: &str = "aspect_ratio=2.5,inclination_deg=31";
const FAILED: &str = "aspect_ratio=1.3,inclination_deg=29";
const NO_SUMMARY: &str = "aspect_ratio=1,inclination_deg=25";

/// d_⊥ = sqrt(4/π (d l ⟨cos θ⟩ + π d²/4)) with ⟨cos θ⟩ = 0.5.
fn d_perp_m(xi: f64) -> f64 {
    let d = L / xi;
    let l = L - d;
    (4.0 / std::f64::consts::PI * (d * l * 0.5 + std::f64::consts::PI * d * d / 4.0)).sqrt()
}

/// The linear shear-rate profile of a job at inclination `alpha`, 1/s.
fn shear(alpha: f64, z: f64) -> f64 {
    0.004 * (alpha - 20.0) * (1.0 - 0.9 * z / H)
}

fn add_campaign(conn: &Connection, name: &str, scene: &str, created_at: &str) -> i64 {
    conn.execute(
        "INSERT INTO campaigns (name, file, scene, spec_json, created_at) \
         VALUES (?1, ?2, ?3, '{}', ?4)",
        params![name, format!("{name}.json"), scene, created_at],
    )
    .expect("insert campaign");
    conn.last_insert_rowid()
}

fn add_job(conn: &Connection, campaign: i64, label: &str, status: &str) -> i64 {
    conn.execute(
        "INSERT INTO jobs (hash, scene, params_json, seed, status, target_time_s) \
         VALUES (?1, 'chute', '{}', 1, ?2, 400.0)",
        params![label, status],
    )
    .expect("insert job");
    let job = conn.last_insert_rowid();
    conn.execute(
        "INSERT INTO campaign_jobs (campaign_id, job_id, label) VALUES (?1, ?2, ?3)",
        params![campaign, job, label],
    )
    .expect("insert campaign_job");
    job
}

/// A done job with a summary and every per-block table filled from the synthetic law.
fn add_done_job(conn: &Connection, campaign: i64, xi: f64, alpha: f64) {
    let label = format!("aspect_ratio={xi},inclination_deg={alpha}");
    let job = add_job(conn, campaign, &label, "done");
    let d_perp = d_perp_m(xi);
    conn.execute(
        "INSERT INTO chute_summary (job_id, aspect_ratio, inclination_deg, total_length_m, \
         diameter_m, particles, bed_height_m, steady_time_s, steady_stress_ratio, \
         measure_start_s, measure_end_s, samples, msd_fit_min_lag_s, msd_fit_max_lag_s, \
         mean_cos_theta, d_perp_m, cg_width_m, steady) \
         VALUES (?1, ?2, ?3, ?4, ?5, 4000, ?6, 150.0, ?7, 160.0, 400.0, 240, 1.0, 20.0, 0.5, ?8, \
         ?9, ?10)",
        params![
            job,
            xi,
            alpha,
            L,
            L / xi,
            H,
            alpha.to_radians().tan(),
            d_perp,
            L / 4.0,
            i64::from(alpha != 24.0)
        ],
    )
    .expect("insert summary");
    for k in 0..BLOCKS {
        let z = (k as f64 + 0.5) * L;
        let g = shear(alpha, z);
        // The top block has too few particles for a D, as the observer may report.
        let d = (k < BLOCKS - 1).then_some(C * g * d_perp * d_perp);
        let skew = 0.3 * (z / H - 0.5);
        let l_corr = (0.5 + 0.1 * k as f64) * L;
        conn.execute(
            "INSERT INTO chute_blocks (job_id, block, z_m, diffusion_m2_per_s, \
             diffusion_stderr_m2_per_s, msd_fit_r, shear_rate_per_s, velocity_x_m_per_s, \
             solid_fraction, mean_particles, vz_std_m_per_s, vz_skewness, correlation_length_m) \
             VALUES (?1, ?2, ?3, ?4, NULL, 0.999, ?5, ?6, 0.55, 200.0, ?7, ?8, ?9)",
            params![
                job,
                k,
                z,
                d,
                g,
                g * z,
                0.01 + 0.001 * k as f64,
                skew,
                l_corr
            ],
        )
        .expect("insert block");
        let d_msd = d.unwrap_or(1e-4);
        for i in 0..=40 {
            let tau = 0.05 * 1.2_f64.powi(i);
            // Ballistic (∝ τ²) below τ ≈ 1 s, diffusive 2 D τ above.
            let msd = 2.0 * d_msd * tau * tau / (tau + 1.0);
            conn.execute(
                "INSERT INTO chute_msd (job_id, block, lag_s, msd_m2, pairs) \
                 VALUES (?1, ?2, ?3, ?4, 1000)",
                params![job, k, tau, msd],
            )
            .expect("insert msd");
        }
        for i in 0..=32 {
            let x = -4.0 + 0.25 * f64::from(i);
            let gauss = (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt();
            let density = (gauss * (1.0 + skew * (x * x * x - 3.0 * x) / 6.0)).max(1e-7);
            conn.execute(
                "INSERT INTO chute_vz_pdf (job_id, block, x, density) VALUES (?1, ?2, ?3, ?4)",
                params![job, k, x, density],
            )
            .expect("insert pdf");
        }
        for n in 0..32 {
            let r = (f64::from(n) + 0.5) * L / 4.0;
            let c = 1e-4 * (-r / l_corr).exp();
            conn.execute(
                "INSERT INTO chute_correlation (job_id, block, r_m, c_m2_per_s2, pairs) \
                 VALUES (?1, ?2, ?3, ?4, 500)",
                params![job, k, r, c],
            )
            .expect("insert correlation");
        }
    }
    for i in 0..=80 {
        let z = f64::from(i) * L / 4.0;
        conn.execute(
            "INSERT INTO chute_fields (job_id, z_m, density_kg_per_m3, velocity_x_m_per_s, \
             shear_rate_per_s, stress_xz_pa, stress_zz_pa) VALUES (?1, ?2, 1430.0, ?3, ?4, ?5, ?6)",
            params![
                job,
                z,
                shear(alpha, z) * z,
                shear(alpha, z),
                (H - z) * alpha.to_radians().sin(),
                (H - z) * alpha.to_radians().cos()
            ],
        )
        .expect("insert field");
    }
    for i in 0..10 {
        conn.execute(
            "INSERT INTO chute_series (job_id, t_s, kinetic_energy_j, stress_ratio) \
             VALUES (?1, ?2, ?3, ?4)",
            params![job, 20.0 * f64::from(i), 100.0, alpha.to_radians().tan()],
        )
        .expect("insert series");
    }
}

/// The campaign 'chute_test' (the most recent) with six done jobs, a pending, a failed and a
/// done job without a summary, plus an older silo campaign.
fn synthetic_db(dir: &Path) -> Connection {
    let conn = sweep::store::open(&dir.join("chute.db")).expect("open store");
    let silo = add_campaign(&conn, "silo_old", "silo", "2024-01-01T00:00:00.000Z");
    add_job(&conn, silo, "orifice_diameter_m=0.03", "pending");
    let id = add_campaign(&conn, "chute_test", "chute", "2025-01-01T00:00:00.000Z");
    for (xi, alpha) in CASES {
        add_done_job(&conn, id, xi, alpha);
    }
    add_job(&conn, id, PENDING, "pending");
    add_job(&conn, id, FAILED, "failed");
    add_job(&conn, id, NO_SUMMARY, "done");
    conn
}

fn check_files(files: &[std::path::PathBuf], figure: &str) {
    let names: Vec<String> = files
        .iter()
        .map(|p| p.file_name().expect("name").to_string_lossy().into_owned())
        .collect();
    let expected: Vec<String> = ["svg", "png", "csv"]
        .iter()
        .map(|e| format!("chute_{figure}.{e}"))
        .collect();
    assert_eq!(names, expected);
    for f in files {
        let len = std::fs::metadata(f).expect("written").len();
        assert!(len > 200, "{} has {len} bytes", f.display());
    }
    let png = std::fs::read(&files[1]).expect("png");
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n", "{figure}.png");
    // A PNG with axes, labels and data compresses far worse than a blank one.
    assert!(png.len() > 20_000, "{figure}.png has {} bytes", png.len());
    let csv = std::fs::read_to_string(&files[2]).expect("csv");
    assert!(csv.lines().count() > 1, "{figure}.csv has no data row");
}

/// A CSV line's label (quoted: it holds a comma) and the cells after it.
fn csv_cells(line: &str) -> (&str, Vec<&str>) {
    let (label, rest) = line[1..].split_once("\",").expect("quoted label");
    (label, rest.split(',').collect())
}

/// The cells of the table line whose first cell is `first`.
fn table_row<'a>(table: &'a str, first: &str) -> Vec<&'a str> {
    table
        .lines()
        .map(|l| l.split_whitespace().collect::<Vec<_>>())
        .find(|c| c.first() == Some(&first))
        .unwrap_or_else(|| panic!("no row '{first}' in\n{table}"))
}

#[test]
fn every_chute_figure_draws_and_lists_unfinished_jobs() {
    let dir = tempfile::tempdir().expect("tempdir");
    let conn = synthetic_db(dir.path());
    let out = dir.path().join("figures");
    for figure in ["fig2", "fig3", "fig4", "fig5", "fig6", "fig7"] {
        for campaign in [Some("chute_test"), None] {
            let report = render_figure(&conn, figure, campaign, &out).expect(figure);
            check_files(&report.files, figure);
            assert!(
                report.table.contains("campaign 'chute_test'"),
                "{}",
                report.table
            );
            assert_eq!(
                report.missing,
                vec![FAILED.to_string(), PENDING.to_string()]
            );
            assert!(
                report.table.contains("2 of 9 jobs not done"),
                "{}",
                report.table
            );
            // The 24° job was not steady: left out, and said so.
            assert!(
                report.table.contains("5 done job(s) drawn")
                    && report.table.contains(NO_SUMMARY)
                    && report.table.contains(
                        "1 done job(s) not steady, left out of the figure: \
                         aspect_ratio=1,inclination_deg=24"
                    ),
                "{}",
                report.table
            );
        }
    }
}

#[test]
fn fig6_gives_back_the_synthetic_coefficient() {
    let dir = tempfile::tempdir().expect("tempdir");
    let conn = synthetic_db(dir.path());
    let report = render_figure(&conn, "fig6", Some("chute_test"), dir.path()).expect("fig6");
    // Blocks with 6 L < z < 14 L: centres 6.5 L .. 13.5 L, 8 per job, the unsteady 24° job
    // left out.
    let n = 8 * (CASES.len() - 1);
    assert!(
        report.table.contains("H/L = 20.00 to 20.00") && report.table.contains("6 L < z < 14 L"),
        "{}",
        report.table
    );
    for panel in ["a", "b"] {
        let row = table_row(&report.table, panel);
        let slope: f64 = row[3].parse().expect("slope");
        let intercept: f64 = row[4].parse().expect("intercept");
        let r: f64 = row[5].parse().expect("R");
        assert!(
            ((slope - C) / C).abs() < 1e-9,
            "panel {panel}: slope {slope}\n{}",
            report.table
        );
        assert!(intercept.abs() < 1e-12, "panel {panel}: {intercept}");
        assert!((r - 1.0).abs() < 1e-9, "panel {panel}: R {r}");
        assert_eq!(row[6], n.to_string(), "panel {panel}");
    }
    let csv = std::fs::read_to_string(dir.path().join("chute_fig6.csv")).expect("csv");
    assert_eq!(csv.lines().count(), 1 + n);
    for line in csv.lines().skip(1) {
        let z_over_h: f64 = csv_cells(line).1[4].parse().expect("z/H");
        assert!(z_over_h > 0.3 && z_over_h < 0.7, "{line}");
    }
}

#[test]
fn fig3_and_fig4_normalise_by_the_maxima_at_the_paper_xi() {
    let dir = tempfile::tempdir().expect("tempdir");
    let conn = synthetic_db(dir.path());
    for (figure, xi, alphas) in [("fig3", 1.3, 3), ("fig4", 2.5, 2)] {
        let report = render_figure(&conn, figure, None, dir.path()).expect(figure);
        assert!(
            report
                .table
                .contains(&format!("xi = {xi} (the campaign's xi closest")),
            "{}",
            report.table
        );
        let csv =
            std::fs::read_to_string(dir.path().join(format!("chute_{figure}.csv"))).expect("csv");
        let mut d_max = f64::NEG_INFINITY;
        let mut labels = std::collections::BTreeSet::new();
        for line in csv.lines().skip(1) {
            // xi, alpha_deg, quantity, z_over_L, value, value_over_max, ci95, ci95_over_max,
            // replicas
            let (label, cells) = csv_cells(line);
            assert_eq!(cells[0], xi.to_string(), "{line}");
            // One run per point here: no replicas to combine, no interval over them.
            assert_eq!(cells.last(), Some(&"1"), "replicas: {line}");
            labels.insert(label.to_string());
            if cells[2] == "D_L2_per_s" {
                let r: f64 = cells[5].parse().expect("ratio");
                assert!(r <= 1.0, "{line}");
                d_max = d_max.max(r);
            }
        }
        assert_eq!(d_max, 1.0, "{figure}: D/D_max peaks at {d_max}");
        assert_eq!(labels.len(), alphas, "{figure}: {labels:?}");
    }
}

#[test]
fn the_campaign_scene_picks_the_figure_set() {
    let dir = tempfile::tempdir().expect("tempdir");
    let conn = synthetic_db(dir.path());
    let msg = format!(
        "{:#}",
        render_figure(&conn, "silo:fig3", Some("chute_test"), dir.path())
            .expect_err("silo figure of a chute campaign")
    );
    assert!(
        msg.contains("silo figure") && msg.contains("'chute' campaign"),
        "{msg}"
    );
    let msg = format!(
        "{:#}",
        render_figure(&conn, "fig12", None, dir.path()).expect_err("unknown")
    );
    assert!(
        msg.contains("fig12") && msg.contains("silo: fig2") && msg.contains("chute: fig1b"),
        "{msg}"
    );
    // A newer silo campaign becomes the default: fig6 is then its fig6 (field maps, which it
    // lacks the data for), but "chute:fig6" still finds the most recent chute campaign.
    add_campaign(&conn, "silo_new", "silo", "2026-01-01T00:00:00.000Z");
    let msg = format!(
        "{:#}",
        render_figure(&conn, "fig6", None, dir.path()).expect_err("fig6 of silo")
    );
    assert!(
        msg.contains("campaign 'silo_new' has no done job with coarse-grained fields"),
        "{msg}"
    );
    let msg = format!(
        "{:#}",
        render_figure(&conn, "fig12", None, dir.path()).expect_err("fig12 of silo")
    );
    assert!(msg.contains("unknown figure 'fig12'"), "{msg}");
    let report = render_figure(&conn, "chute:fig6", None, dir.path()).expect("chute:fig6");
    assert!(report.table.contains("campaign 'chute_test'"));
    let msg = format!(
        "{:#}",
        render_figure(&conn, "chute:fig2", Some("silo_new"), dir.path()).expect_err("scene")
    );
    assert!(msg.contains("'silo' campaign"), "{msg}");
}

/// Law: a job whose flow was not steady is left out of every chute figure and listed with its
/// verdict (a not-flowing job has no summary, and is not an unexplained "without summary"); with
/// `include_unsteady` a measured one is drawn and marked "NOT steady" where jobs are named.
#[test]
fn unsteady_jobs_are_left_out_or_marked() {
    let dir = tempfile::tempdir().expect("tempdir");
    let conn = synthetic_db(dir.path());
    let campaign: i64 = conn
        .query_row("SELECT id FROM campaigns", [], |r| r.get(0))
        .unwrap();
    let stopped = add_job(
        &conn,
        campaign,
        "aspect_ratio=2.5,inclination_deg=20",
        "done",
    );
    let drifted: i64 = conn
        .query_row(
            "SELECT job_id FROM campaign_jobs WHERE label = 'aspect_ratio=1.3,inclination_deg=27'",
            [],
            |r| r.get(0),
        )
        .unwrap();
    for (job, state, measured) in [(stopped, "not_flowing", 0), (drifted, "drifted", 1)] {
        conn.execute(
            "INSERT INTO chute_flow_state (job_id, state, measured, min_flow_velocity_m_per_s) \
             VALUES (?1, ?2, ?3, 0.0177)",
            params![job, state, measured],
        )
        .unwrap();
    }
    let out = dir.path().join("figures");
    let report = render_figure(&conn, "fig2", Some("chute_test"), &out).expect("fig2");
    let t = &report.table;
    assert!(t.contains("4 done job(s) drawn\n"), "{t}");
    assert!(
        t.contains(
            "3 done job(s) not steady, left out of the figure: \
             aspect_ratio=1,inclination_deg=24 (not steady by steady_max_time_s); \
             aspect_ratio=1.3,inclination_deg=27 (drifted while measured); \
             aspect_ratio=2.5,inclination_deg=20 (not flowing, nothing measured)"
        ),
        "{t}"
    );
    assert!(!t.contains("inclination_deg=20\n"), "{t}");
    let with = sweep::report::Output {
        dir: out.clone(),
        titles: true,
        include_unsteady: true,
    };
    let report =
        sweep::report::render_figure_with(&conn, "fig2", Some("chute_test"), &with).expect("fig2");
    let t = &report.table;
    assert!(
        t.contains("6 done job(s) drawn, 2 of them NOT steady"),
        "{t}"
    );
}
