//! The chute figures added with the per-block orientation and D_y (`fig1b`, `orientation`,
//! `dy`) drawn from a synthetic campaign with known rows: a rod point of two replicas
//! (ξ = 1.5), a sphere point (ξ = 1: no orientation stored) and a rod job measured before
//! schema 13 (the new columns NULL). Each figure writes its SVG, PNG and CSV; the CSV holds the
//! replicas' mean of what was stored (φ = ρ/ρ_p, S2, ⟨|cos θ|⟩, D_y/D_y,max, the correlation of
//! D_y with γ̇); what has no data is named; a campaign with none says what is missing.

use rusqlite::{params, Connection};
use sweep::report::{figures_of, render_figure};

const L: f64 = 0.125;
const BLOCKS: i64 = 10;
const RODS: &str = "aspect_ratio=1.5,inclination_deg=28";
const SPHERES: &str = "aspect_ratio=1,inclination_deg=24";
const OLD: &str = "aspect_ratio=2.5,inclination_deg=30";

fn add_campaign(conn: &Connection, name: &str) -> i64 {
    conn.execute(
        "INSERT INTO campaigns (name, file, scene, spec_json) VALUES (?1, 'c.json', 'chute', '{}')",
        [name],
    )
    .unwrap();
    conn.last_insert_rowid()
}

fn add_job(conn: &Connection, campaign: i64, label: &str, status: &str) -> i64 {
    conn.execute(
        "INSERT INTO jobs (hash, scene, params_json, seed, status, target_time_s) \
         VALUES (?1, 'chute', '{}', 1, ?2, 400.0)",
        params![format!("{campaign}/{label}"), status],
    )
    .unwrap();
    let job = conn.last_insert_rowid();
    conn.execute(
        "INSERT INTO campaign_jobs (campaign_id, job_id, label) VALUES (?1, ?2, ?3)",
        params![campaign, job, label],
    )
    .unwrap();
    job
}

/// γ̇ of block k, 1/s: falls linearly with height.
fn shear(k: i64) -> f64 {
    0.5 * (1.0 - 0.08 * k as f64)
}

/// The new values of block k of replica r: (S2, ⟨|cos θ|⟩, D_y) for rods, D_y only for spheres,
/// nothing for the old job. D_y ∝ γ̇, so their correlation is 1.
fn new_values(label: &str, r: usize, k: i64) -> (Option<f64>, Option<f64>, Option<f64>) {
    let d_y = 1e-4 * shear(k) * (1.0 + 0.02 * r as f64);
    match label {
        RODS => (
            Some(0.4 + 0.01 * k as f64 + 0.02 * r as f64),
            Some(0.7 + 0.02 * r as f64),
            Some(d_y),
        ),
        SPHERES => (None, None, Some(d_y)),
        _ => (None, None, None),
    }
}

/// A done, steady job of point `label` (replica `r`) with blocks, fields and a summary.
fn add_done(conn: &Connection, campaign: i64, label: &str, r: usize) {
    let xi: f64 = label[13..label.find(',').unwrap()].parse().unwrap();
    let job = add_job(conn, campaign, &format!("{label},replica={r}"), "done");
    conn.execute(
        "INSERT INTO chute_summary (job_id, aspect_ratio, inclination_deg, total_length_m, \
         diameter_m, particles, bed_height_m, measure_start_s, measure_end_s, samples, \
         msd_fit_min_lag_s, msd_fit_max_lag_s, mean_cos_theta, d_perp_m, cg_width_m, steady) \
         VALUES (?1, ?2, 28.0, ?3, ?4, 900, ?5, 10.0, 30.0, 400, 1.0, 5.0, 0.8, ?6, ?7, 1)",
        params![job, xi, L, L / xi, BLOCKS as f64 * L, 0.8 * L, L / 4.0],
    )
    .unwrap();
    for k in 0..BLOCKS {
        let (s2, cos, d_y) = new_values(label, r, k);
        conn.execute(
            "INSERT INTO chute_blocks (job_id, block, z_m, diffusion_m2_per_s, \
             diffusion_stderr_m2_per_s, shear_rate_per_s, velocity_x_m_per_s, solid_fraction, \
             mean_particles, nematic_order_s2, mean_abs_cos_flow, diffusion_y_m2_per_s, \
             diffusion_y_stderr_m2_per_s) \
             VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, 0.55, 90.0, ?8, ?9, ?10, ?11)",
            params![
                job,
                k,
                (k as f64 + 0.5) * L,
                3e-4 * shear(k),
                1e-5,
                shear(k),
                0.1 * k as f64,
                s2,
                cos,
                d_y,
                d_y.map(|d| 0.05 * d)
            ],
        )
        .unwrap();
    }
    for i in 0..=40 {
        let z = f64::from(i) * L / 4.0;
        conn.execute(
            "INSERT INTO chute_fields (job_id, z_m, density_kg_per_m3, velocity_x_m_per_s, \
             shear_rate_per_s, stress_xz_pa, stress_zz_pa) VALUES (?1, ?2, 1430.0, ?3, 0.3, 1, 2)",
            params![job, z, 0.1 * z / L + 0.01 * r as f64],
        )
        .unwrap();
    }
}

/// The CSV rows of `file` (after the header) whose first cell is `label`, split.
fn csv_rows(file: &std::path::Path, label: &str) -> Vec<Vec<String>> {
    std::fs::read_to_string(file)
        .unwrap()
        .lines()
        .skip(1)
        .filter(|l| l.starts_with(&format!("\"{label}\"")) || l.starts_with(&format!("{label},")))
        .map(|l| {
            let rest = l.rsplit_once(label).map_or(l, |x| x.1);
            rest.trim_start_matches('"')
                .trim_start_matches(',')
                .split(',')
                .map(String::from)
                .collect()
        })
        .collect()
}

fn close(a: &str, b: f64) -> bool {
    let a: f64 = a.parse().unwrap_or_else(|_| panic!("not a number: {a}"));
    (a - b).abs() <= 1e-9 * b.abs().max(1e-12)
}

fn check_files(files: &[std::path::PathBuf], stem: &str) {
    let names: Vec<String> = files
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names,
        ["svg", "png", "csv"].map(|e| format!("chute_{stem}.{e}"))
    );
    let png = std::fs::read(&files[1]).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    assert!(png.len() > 20_000, "{stem}.png has {} bytes", png.len());
}

/// Law: each figure shows exactly what the rows hold. Fig. 1(b): φ = 1430/2600 = 0.55 and V_x
/// the replicas' mean (0.1 z/L + 0.005) with an interval; orientation: the rod point's S2 and
/// ⟨|cos θ|⟩ are the replicas' means (0.41 + 0.01 k, 0.71), spheres and the old job are named,
/// not drawn; dy: D_y/D_y,max peaks at 1 in block 0, D_y's correlation with γ̇ is 1.00, and the
/// old job is named. The pending job is listed as missing; the figures are in the chute index.
/// A failure means a figure reads the wrong column, pools wrongly, or hides a missing value.
#[test]
fn fig1b_orientation_and_dy_draw_the_stored_profiles() {
    let dir = tempfile::tempdir().unwrap();
    let conn = sweep::store::open(&dir.path().join("c.db")).unwrap();
    let c = add_campaign(&conn, "profiles");
    for r in 0..2 {
        add_done(&conn, c, RODS, r);
    }
    add_done(&conn, c, SPHERES, 0);
    add_done(&conn, c, OLD, 0);
    add_job(&conn, c, "aspect_ratio=3,inclination_deg=31", "pending");
    let out = dir.path().join("figs");
    let names: Vec<&str> = figures_of("chute").unwrap().iter().map(|f| f.0).collect();
    for f in ["fig1b", "orientation", "dy"] {
        assert!(names.contains(&f), "{f} not among {names:?}");
    }

    let r = render_figure(&conn, "fig1b", Some("profiles"), &out).unwrap();
    check_files(&r.files, "fig1b");
    assert_eq!(r.missing, ["aspect_ratio=3,inclination_deg=31"]);
    let rows = csv_rows(&r.files[2], RODS);
    let at = |q: &str, z: f64| {
        rows.iter()
            .find(|c| c[2] == q && close(&c[3], z))
            .unwrap_or_else(|| panic!("no {q} at z/L = {z}: {rows:?}"))
            .clone()
    };
    // label, xi, alpha, quantity, z/L, value, ci95, replicas (label cut off)
    let phi = at("phi", 2.0);
    assert!(close(&phi[4], 1430.0 / 2600.0) && phi[6] == "2", "{phi:?}");
    let vx = at("V_x_m_per_s", 2.0);
    assert!(close(&vx[4], 0.2 + 0.005) && !vx[5].is_empty(), "{vx:?}");
    assert!(
        !csv_rows(&r.files[2], OLD).is_empty(),
        "fields exist for the old job"
    );

    let r = render_figure(&conn, "orientation", Some("profiles"), &out).unwrap();
    check_files(&r.files, "orientation");
    let rows = csv_rows(&r.files[2], RODS);
    assert_eq!(rows.len(), BLOCKS as usize);
    for row in &rows {
        // xi, alpha, block, z/L, S2, ci, |cos|, ci, replicas
        let k: f64 = row[2].parse().unwrap();
        assert!(close(&row[4], 0.41 + 0.01 * k), "{row:?}");
        assert!(close(&row[6], 0.71) && row[8] == "2", "{row:?}");
    }
    assert!(csv_rows(&r.files[2], SPHERES).is_empty());
    assert!(csv_rows(&r.files[2], OLD).is_empty());
    assert!(r.table.contains("spheres (xi = 1): no axis"), "{}", r.table);
    assert!(
        r.table.contains(&format!("{OLD}: no orientation stored")),
        "{}",
        r.table
    );

    let r = render_figure(&conn, "dy", Some("profiles"), &out).unwrap();
    check_files(&r.files, "dy");
    let rows = csv_rows(&r.files[2], SPHERES);
    assert_eq!(rows.len(), BLOCKS as usize);
    // xi, alpha, block, z/L, central, D_y, ci, D_y/max, shear, shear/max, ...
    assert!(
        close(&rows[0][7], 1.0) && close(&rows[0][9], 1.0),
        "{:?}",
        rows[0]
    );
    assert!(close(&rows[5][7], shear(5) / shear(0)), "{:?}", rows[5]);
    let line = r
        .table
        .lines()
        .find(|l| l.trim_end().ends_with(SPHERES))
        .unwrap_or_else(|| panic!("no row for {SPHERES}:\n{}", r.table));
    assert!(
        line.split_whitespace().filter(|c| *c == "1.00").count() == 2,
        "{line}"
    );
    assert!(
        r.table.contains(&format!("{OLD}: no D_y stored")),
        "{}",
        r.table
    );

    // A campaign of old jobs only: the figures are drawn empty and say what is missing.
    let old = add_campaign(&conn, "old_only");
    add_done(&conn, old, OLD, 0);
    for (f, why) in [
        ("orientation", "no block with S2 or <|cos theta|> stored"),
        ("dy", "no block with D_y stored"),
    ] {
        let r = render_figure(&conn, f, Some("old_only"), &dir.path().join("old")).unwrap();
        assert!(r.table.contains(why), "{f}:\n{}", r.table);
        assert_eq!(r.files.len(), 3);
    }
}
