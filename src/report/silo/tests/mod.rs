//! A synthetic campaign whose flow rates follow Eq. (1) exactly, with α1 and α2 varying
//! linearly with f and C constant (as the paper reports), two replicas at some points, and
//! one pending and one failed job. Each figure must draw, and Fig. 3 must give back the law.

use std::path::Path;

use rusqlite::Connection;

use crate::store::test_rows;

use crate::report::render_figure;

mod clogged;
mod fig2_samples;
mod map_order;
mod pooled;
mod running_on;

const PARTICLE_D_M: f64 = 0.0058;
const BULK_DENSITY: f64 = 1550.0;
const C: f64 = 2900.0;
const ORIFICES_M: [f64; 8] = [0.0118, 0.016, 0.020, 0.024, 0.028, 0.030, 0.036, 0.048];
const PENDING: &str = "orifice_diameter_m=0.02,rotation_frequency_hz=0.3,replica=2";
const FAILED: &str = "orifice_diameter_m=0.048,rotation_frequency_hz=0,replica=1";

fn alpha1(f: f64) -> f64 {
    4.0 - 2.0 * f
}
fn alpha2_m(f: f64) -> f64 {
    0.006 - 0.002 * f
}
fn law(d: f64, f: f64) -> f64 {
    C * (1.0 - alpha1(f) * (-d / alpha2_m(f)).exp()) * d.powf(2.5)
}

fn add_campaign(conn: &Connection, name: &str, scene: &str, created_at: &str) -> i64 {
    test_rows::campaign(conn, name, scene, created_at)
}

/// Adds a job; a done one gets a summary with `q` and `ci` and an M(t) = Q t series.
fn add_job(
    conn: &Connection,
    campaign: i64,
    label: &str,
    status: &str,
    d: f64,
    f: f64,
    q: Option<(f64, f64)>,
) {
    add_job_with_blocks(conn, campaign, label, status, d, f, q, None);
}

/// As `add_job`, with Q's block count (None: not recorded, as before schema 8).
#[allow(clippy::too_many_arguments)]
fn add_job_with_blocks(
    conn: &Connection,
    campaign: i64,
    label: &str,
    status: &str,
    d: f64,
    f: f64,
    q: Option<(f64, f64)>,
    q_blocks: Option<i64>,
) {
    let params_json = format!(
        r#"{{"orifice_diameter_m": {d}, "rotation_frequency_hz": {f}, "gravity_m_per_s2": 9.81}}"#
    );
    let job = test_rows::silo_job(conn, campaign, label, status, &params_json);
    let Some((q, ci)) = q else { return };
    let summary = test_rows::Summary {
        d,
        f,
        particle_d: PARTICLE_D_M,
        bulk_density: BULK_DENSITY,
        q: Some((q, ci)),
        flowing_time_s: 3.0,
        discharged_mass_kg: 3.0 * q,
        discharged_count: 100,
        clogs: 0,
        clogged_time_s: 0.0,
        permanently_clogged: false,
        q_blocks,
    };
    test_rows::discharge_summary(conn, job, &summary);
    for i in 0..=150 {
        let t = f64::from(i) * 0.02;
        test_rows::discharge_sample(conn, job, t, q * t, i64::from(i));
    }
}

/// The synthetic silo campaign 'rotating' over `freqs`, the most recent campaign (so the
/// default), plus an older silo campaign and an older chute campaign.
fn synthetic_db(freqs: &[f64]) -> Connection {
    let conn = test_rows::empty_db();
    let old = add_campaign(&conn, "old_silo", "silo", "2020-01-01T00:00:00.000Z");
    add_job(&conn, old, "old", "done", 0.03, 0.5, Some((9.0, 0.1)));
    let id = add_campaign(&conn, "rotating", "silo", "2025-01-01T00:00:00.000Z");
    add_campaign(&conn, "chute_earlier", "chute", "2024-01-01T00:00:00.000Z");
    for (i, &d) in ORIFICES_M.iter().enumerate() {
        for &f in freqs {
            let q = law(d, f);
            let label =
                |r: u32| format!("orifice_diameter_m={d},rotation_frequency_hz={f},replica={r}");
            if i % 2 == 0 && f > 0.0 {
                // Replicas ±1 %: their mean is the law, their CI comes from the spread.
                add_job(
                    &conn,
                    id,
                    &label(0),
                    "done",
                    d,
                    f,
                    Some((q * 1.01, 0.5 * q)),
                );
                add_job(
                    &conn,
                    id,
                    &label(1),
                    "done",
                    d,
                    f,
                    Some((q * 0.99, 0.5 * q)),
                );
            } else {
                add_job(&conn, id, &label(0), "done", d, f, Some((q, 0.02 * q)));
            }
        }
    }
    add_job(&conn, id, PENDING, "pending", 0.02, 0.3, None);
    add_job(&conn, id, FAILED, "failed", 0.048, 0.0, None);
    conn
}

/// A done job that clogged before Q could be measured: a summary with Q NULL.
fn add_clogged_job(conn: &Connection, campaign: i64, d: f64, f: f64) {
    let label = format!("orifice_diameter_m={d},rotation_frequency_hz={f},replica=0");
    add_job(conn, campaign, &label, "done", d, f, None);
    let job = conn.last_insert_rowid();
    let summary = test_rows::Summary {
        d,
        f,
        particle_d: PARTICLE_D_M,
        bulk_density: BULK_DENSITY,
        q: None,
        flowing_time_s: 0.1,
        discharged_mass_kg: 0.01,
        discharged_count: 3,
        clogs: 1,
        clogged_time_s: 2.9,
        permanently_clogged: true,
        q_blocks: None,
    };
    test_rows::discharge_summary(conn, job, &summary);
}

/// Width and height from the PNG signature and IHDR chunk.
fn png_size(path: &Path) -> (u32, u32) {
    let bytes = std::fs::read(path).expect("read png");
    assert_eq!(
        &bytes[..8],
        b"\x89PNG\r\n\x1a\n",
        "{} is not a PNG",
        path.display()
    );
    assert_eq!(&bytes[12..16], b"IHDR");
    let be = |i: usize| u32::from_be_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    (be(16), be(20))
}

fn check_files(files: &[std::path::PathBuf], dir: &Path, figure: &str, size: (u32, u32)) {
    let names: Vec<String> = files
        .iter()
        .map(|p| p.file_name().expect("name").to_string_lossy().into_owned())
        .collect();
    let expected: Vec<String> = ["svg", "png", "csv"]
        .iter()
        .map(|e| format!("{figure}.{e}"))
        .collect();
    assert_eq!(names, expected);
    for f in files {
        assert!(f.starts_with(dir));
        let len = std::fs::metadata(f).expect("written").len();
        assert!(len > 200, "{} has {len} bytes", f.display());
    }
    assert_eq!(png_size(&files[1]), size, "{figure}.png size");
    // A PNG with axes, labels and data compresses far worse than a blank one.
    assert!(std::fs::metadata(&files[1]).expect("png").len() > 20_000);
    let svg = std::fs::read_to_string(&files[0]).expect("svg");
    assert!(
        svg.contains("<text") && (svg.contains("f (Hz)") || svg.contains("t (s)")),
        "{figure}.svg has no axis label"
    );
}

/// (f_Hz, C, α1, α2 in mm) from the fit section of the Fig. 3 table.
fn parse_janda_table(table: &str) -> Vec<(f64, f64, f64, f64)> {
    let lines: Vec<&str> = table.lines().collect();
    let header = lines
        .iter()
        .position(|l| l.trim_start().starts_with("f_Hz") && l.contains("alpha1"))
        .expect("fit header");
    lines[header + 1..]
        .iter()
        .take_while(|l| !l.trim().is_empty())
        .map(|l| {
            let c: Vec<f64> = l
                .split_whitespace()
                .take(5)
                .map(|x| x.parse().expect(x))
                .collect();
            (c[0], c[2], c[3], c[4])
        })
        .collect()
}

#[test]
fn every_figure_draws_and_lists_unfinished_jobs() {
    let conn = synthetic_db(&[0.0, 0.1, 0.3, 1.0]);
    let dir = tempfile::tempdir().expect("tempdir");
    let sizes = [
        ("fig2", (1000, 740)),
        ("fig3", (1800, 680)),
        ("fig4", (1000, 740)),
        ("fig5", (1400, 1080)),
    ];
    for (figure, size) in sizes {
        let report = render_figure(&conn, figure, None, dir.path()).expect(figure);
        check_files(&report.files, dir.path(), figure, size);
        assert!(
            report.table.contains("campaign 'rotating'"),
            "{}",
            report.table
        );
        assert_eq!(
            report.missing,
            vec![PENDING.to_string(), FAILED.to_string()]
        );
        assert!(
            report.table.contains("2 of 46 jobs not done"),
            "{}",
            report.table
        );
    }
    let fig2 = render_figure(&conn, "fig2", Some("rotating"), dir.path()).expect("fig2");
    // 8 orifices × 4 frequencies: 4 D × 2 f curves, spread to include the ends.
    let curves = fig2
        .table
        .lines()
        .filter(|l| l.contains("replica="))
        .count();
    assert_eq!(curves, 8, "{}", fig2.table);
    assert!(fig2.table.contains("11.8") && fig2.table.contains("48"));
}

#[test]
fn fig3_table_gives_back_the_generating_law() {
    let freqs = [0.0, 0.1, 0.3, 1.0];
    let conn = synthetic_db(&freqs);
    let dir = tempfile::tempdir().expect("tempdir");
    let report = render_figure(&conn, "fig3", None, dir.path()).expect("fig3");
    let fits = parse_janda_table(&report.table);
    assert_eq!(fits.len(), freqs.len(), "{}", report.table);
    for ((f, c, a1, a2_mm), &f_true) in fits.iter().zip(&freqs) {
        assert!((f - f_true).abs() < 1e-9);
        let rel = |a: f64, b: f64| ((a - b) / b).abs();
        assert!(rel(*c, C) < 0.01, "f {f}: C {c}\n{}", report.table);
        assert!(
            rel(*a1, alpha1(f_true)) < 0.01,
            "f {f}: alpha1 {a1}\n{}",
            report.table
        );
        assert!(
            rel(*a2_mm, alpha2_m(f_true) * 1e3) < 0.01,
            "f {f}: alpha2 {a2_mm}\n{}",
            report.table
        );
    }
    assert!(report.table.contains("Beverloo fit at f = 0 Hz") && report.table.contains("k = "));
    assert!(
        report.table.contains("; 95 % bootstrap ") && report.table.contains("], k in ["),
        "the Beverloo fit carries its intervals:\n{}",
        report.table
    );
    assert!(
        report.table.contains("9.810 m/s^2 from params_json"),
        "{}",
        report.table
    );
    // The CSV carries the same fit next to every point.
    let csv = std::fs::read_to_string(dir.path().join("fig3.csv")).expect("csv");
    assert_eq!(csv.lines().count(), 1 + ORIFICES_M.len() * freqs.len());
}

#[test]
fn fig4_ratios_follow_the_law_and_fig5_keeps_large_orifices() {
    let conn = synthetic_db(&[0.0, 0.1, 0.3, 1.0]);
    let dir = tempfile::tempdir().expect("tempdir");
    let fig4 = render_figure(&conn, "fig4", None, dir.path()).expect("fig4");
    assert!(
        fig4.table.contains("normalised by Q at f = 1 Hz"),
        "{}",
        fig4.table
    );
    let csv = std::fs::read_to_string(dir.path().join("fig4.csv")).expect("csv");
    let mut rows = 0;
    for line in csv.lines().skip(1) {
        // Numbers up to the replica count; the CI's source is a word.
        let v: Vec<f64> = line
            .split(',')
            .take(9)
            .map(|x| x.parse().expect(x))
            .collect();
        let (d, f, q, ci, ratio, err) = (v[0], v[2], v[3], v[4], v[6], v[7]);
        // As `synthetic_db` adds them: two replicas at every other orifice when f > 0.
        let i = ORIFICES_M.iter().position(|o| *o == d).expect("D");
        let replicas = if f > 0.0 && i % 2 == 0 { 2.0 } else { 1.0 };
        assert_eq!(v[8], replicas, "{line}");
        assert!(
            (ratio - law(d, f) / law(d, 1.0)).abs() < 1e-9 * ratio,
            "{line}"
        );
        if f == 1.0 {
            assert_eq!(err, 0.0);
        } else {
            let ci_ref: f64 = csv
                .lines()
                .map(|l| {
                    l.split(',')
                        .map(|x| x.parse().unwrap_or(f64::NAN))
                        .collect::<Vec<f64>>()
                })
                .find(|r| r[0] == d && r[2] == 1.0)
                .map(|r| r[4] / r[3])
                .expect("reference row");
            let expected = ratio * ((ci / q).powi(2) + ci_ref.powi(2)).sqrt();
            assert!((err - expected).abs() < 1e-12 + 1e-9 * expected, "{line}");
        }
        rows += 1;
    }
    assert_eq!(rows, 32);

    let fig5 = render_figure(&conn, "fig5", None, dir.path()).expect("fig5");
    assert!(
        fig5.table.contains("D/d > 4.5: 4 found, 4 shown"),
        "{}",
        fig5.table
    );
    let csv = std::fs::read_to_string(dir.path().join("fig5.csv")).expect("csv");
    for line in csv.lines().skip(1) {
        let v: Vec<f64> = line
            .split(',')
            .take(2)
            .map(|x| x.parse().expect(x))
            .collect();
        assert!(v[0] / v[1] > 4.5, "{line}");
    }
}

#[test]
fn without_one_hz_the_largest_f_is_the_reference_and_the_table_says_so() {
    let conn = synthetic_db(&[0.0, 0.2, 0.5]);
    let dir = tempfile::tempdir().expect("tempdir");
    let fig4 = render_figure(&conn, "fig4", None, dir.path()).expect("fig4");
    assert!(
        fig4.table.contains("f = 1 Hz is not in the campaign"),
        "{}",
        fig4.table
    );
    assert!(
        fig4.table.contains("largest f present, 0.5 Hz"),
        "{}",
        fig4.table
    );
    let svg = std::fs::read_to_string(dir.path().join("fig4.svg")).expect("svg");
    assert!(svg.contains("Q / Q(f = 0.5 Hz), largest f"));
    let csv = std::fs::read_to_string(dir.path().join("fig4.csv")).expect("csv");
    for line in csv.lines().skip(1) {
        let v: Vec<f64> = line
            .split(',')
            .take(8)
            .map(|x| x.parse().expect(x))
            .collect();
        assert!(
            (v[6] - law(v[0], v[2]) / law(v[0], 0.5)).abs() < 1e-9,
            "{line}"
        );
    }
}

#[test]
fn bad_figure_or_campaign_names_are_explained() {
    let conn = synthetic_db(&[0.0, 1.0]);
    let dir = tempfile::tempdir().expect("tempdir");
    let err = render_figure(&conn, "fig12", None, dir.path()).expect_err("unknown figure");
    let msg = format!("{err:#}");
    assert!(
        msg.contains("fig12") && msg.contains("fig2") && msg.contains("fig11"),
        "{msg}"
    );
    let msg = format!(
        "{:#}",
        render_figure(&conn, "fig3", Some("nope"), dir.path()).expect_err("no campaign")
    );
    assert!(msg.contains("nope") && msg.contains("rotating"), "{msg}");
    let msg = format!(
        "{:#}",
        render_figure(&conn, "silo:fig3", Some("chute_earlier"), dir.path()).expect_err("scene")
    );
    assert!(msg.contains("'chute' campaign"), "{msg}");
    let msg = format!(
        "{:#}",
        render_figure(&conn, "fig6", None, dir.path()).expect_err("no fields")
    );
    assert!(
        msg.contains("no done job with coarse-grained fields") && msg.contains("\"fields\""),
        "{msg}"
    );
    let old = render_figure(&conn, "fig3", Some("old_silo"), dir.path()).expect("old campaign");
    assert!(
        old.missing.is_empty() && old.table.contains("needs >= 3 orifices"),
        "{}",
        old.table
    );
}

#[test]
fn fig3_refuses_a_fit_through_as_many_points_as_parameters() {
    let conn = test_rows::empty_db();
    let id = add_campaign(&conn, "three", "silo", "2025-01-01T00:00:00.000Z");
    for d in [0.015, 0.020, 0.026] {
        let label = format!("orifice_diameter_m={d},rotation_frequency_hz=1,replica=0");
        add_job(&conn, id, &label, "done", d, 1.0, Some((law(d, 1.0), 0.01)));
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let report = render_figure(&conn, "fig3", None, dir.path()).expect("fig3");
    assert!(
        report.table.contains("no fit (3 D for 3 parameters)"),
        "{}",
        report.table
    );
    let svg = std::fs::read_to_string(dir.path().join("fig3.svg")).expect("svg");
    let text = svg_text(&svg);
    assert!(
        text.contains("3 D for 3 parameters, no fit drawn"),
        "the figure itself says why there is no curve: {text}"
    );
    let csv = std::fs::read_to_string(dir.path().join("fig3.csv")).expect("csv");
    for line in csv.lines().skip(1) {
        let cols: Vec<&str> = line.split(',').collect();
        assert!(
            cols[8..].iter().all(|c| c.is_empty()),
            "no fit values: {line}"
        );
    }
}

#[test]
fn fig3_gives_d_min_a_bootstrap_interval_around_the_law() {
    let conn = synthetic_db(&[0.0, 1.0]);
    let dir = tempfile::tempdir().expect("tempdir");
    render_figure(&conn, "fig3", None, dir.path()).expect("fig3");
    let csv = std::fs::read_to_string(dir.path().join("fig3.csv")).expect("csv");
    let header: Vec<&str> = csv.lines().next().expect("header").split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).expect(name);
    let (f, lo, hi) = (
        col("rotation_frequency_hz"),
        col("janda_d_min_ci95_lo_m"),
        col("janda_d_min_ci95_hi_m"),
    );
    let mut seen = 0;
    for line in csv.lines().skip(1) {
        let v: Vec<&str> = line.split(',').collect();
        let f: f64 = v[f].parse().expect("f");
        let (lo, hi): (f64, f64) = (v[lo].parse().expect("lo"), v[hi].parse().expect("hi"));
        let truth = alpha2_m(f) * alpha1(f).ln();
        assert!(lo < hi && lo <= truth && truth <= hi, "{lo} {truth} {hi}");
        seen += 1;
    }
    assert_eq!(seen, 2 * ORIFICES_M.len());
}

/// The text of an SVG's <text> elements joined by spaces (a wrapped note reads as one line).
fn svg_text(svg: &str) -> String {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| {
            let body = &t[t.find('>')? + 1..];
            Some(body[..body.find("</text>")?].trim().to_string())
        })
        .collect::<Vec<_>>()
        .join(" ")
}

#[test]
fn figure_all_writes_every_figure_and_an_index_that_says_what_is_missing() {
    let conn = synthetic_db(&[0.0, 0.5, 1.0]);
    let dir = tempfile::tempdir().expect("tempdir");
    let out = crate::report::Output {
        include_unsteady: false,
        dir: dir.path().to_path_buf(),
        titles: false,
    };
    let all = crate::report::render_all(&conn, None, &out).expect("all");
    assert_eq!(all.campaign, "rotating");
    let names: Vec<&str> = all.figures.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names.len(), 11, "{names:?}");
    let html = std::fs::read_to_string(&all.index).expect("index.html");
    for fig in ["fig2", "fig3", "fig4", "fig5"] {
        assert!(html.contains(&format!("<img src=\"{fig}.png\"")), "{fig}");
    }
    // The synthetic campaign has no fields: fig6 is listed with the reason, not left out.
    assert!(
        html.contains("id=\"fig6\"") && html.contains("not drawn: campaign"),
        "{html}"
    );
    // The accuracy map of this (synthetic, study) campaign cannot be drawn: listed, with why.
    let accuracy = &html[html.find("id=\"accuracy\"").expect("accuracy section")..];
    assert!(accuracy.contains("not drawn: "), "{accuracy}");
    // --no-title: the figure is its panels only, 40 px shorter than with a title.
    let titled = render_figure(&conn, "fig4", None, dir.path()).expect("fig4");
    let (_, h_titled) = png_size(&titled.files[1]);
    let untitled =
        crate::report::render_figure_with(&conn, "fig4", None, &out).expect("fig4 untitled");
    let (_, h) = png_size(&untitled.files[1]);
    assert_eq!(h + 40, h_titled);
    let svg = std::fs::read_to_string(&untitled.files[0]).expect("svg");
    assert!(!svg.contains("Fig. 4:"), "no title line");
}

#[test]
fn an_alpha2_at_its_bound_gives_no_d_min_and_says_so() {
    use super::flow_rate::JandaRow;
    let fit = crate::observe::fits::JandaFit {
        c: 2900.0,
        alpha1: 3.0,
        alpha2_m: 2.6,
        d_min_m: Some(2.6 * 3.0f64.ln()),
        rms_residual_kg_per_s: 1e-4,
        n: 5,
        alpha2_at_bound: true,
    };
    let row = JandaRow {
        f_hz: 1.0,
        points: Vec::new(),
        fit: Some(fit),
        intervals: None,
        weighted: false,
    };
    let why = row.d_min_refused().expect("refused");
    assert!(why.contains("α2 at its search bound (2600 mm)"), "{why}");
    let free = JandaRow {
        fit: Some(crate::observe::fits::JandaFit {
            alpha2_at_bound: false,
            ..fit
        }),
        ..row
    };
    assert_eq!(free.d_min_refused(), None);
}
