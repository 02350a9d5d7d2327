//! Figures 2–5 of the silo paper (PRE 2020, Sec. III.A) redrawn from a campaign's rows in the
//! database: M(t) (Fig. 2), Q(D) per f with the fit of Eq. (1) and D_min(f) (Fig. 3), and
//! Q/Q_{f=1} vs f (Figs. 4 and 5). Every number comes from discharge_summary and
//! discharge_series of the campaign's done jobs; nothing from the paper is hard-coded.

pub(crate) mod data;
pub(crate) mod fields;
mod normalise;

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;
use rusqlite::Connection;

use super::campaign::CampaignRef;
use super::drawn::{write_all, Drawn};
use super::plot::{Axis, Figure, Legend, Panel, Series};
use super::table::{csv_num, fixed, mm, sci, short, Table};
use crate::observe::fits::{beverloo_fit, janda_fit, JandaFit};
use crate::report::silo::data::{
    combine_replicas, distinct, done_discharge_rows, gravity_m_per_s2, mass_series, same_value,
    spread, CiSource, DischargeRow, FlowPoint,
};
use crate::report::silo::normalise::{normalise, NormalisedCurve};

/// At most this many M(t) curves in Fig. 2, so the legend stays readable.
const MAX_FIG2_CURVES: usize = 8;
/// Fig. 5 shows orifices with D/d above this (the paper: no permanent clog at f = 0 above ~4.5 d).
const LARGE_ORIFICE_D_OVER_PARTICLE: f64 = 4.5;
/// Fig. 5 has up to this many panels, as in the paper.
const MAX_FIG5_PANELS: usize = 4;
/// Used for Beverloo only when no job parameter gives gravity; the table says so.
const STANDARD_GRAVITY_M_PER_S2: f64 = 9.806_65;

/// Fig. 2: discharged mass M(t) for up to eight (D, f), spread over the D and f present.
pub(crate) fn fig2(conn: &Connection, campaign: &CampaignRef, out_dir: &Path) -> Result<Drawn> {
    let rows = done_discharge_rows(conn, campaign.id)?;
    let ds = distinct(rows.iter().map(|r| r.orifice_diameter_m));
    let fs = distinct(rows.iter().map(|r| r.rotation_frequency_hz));
    // Two f per D first, then give the remaining budget back to whichever axis has values left.
    let n_f = fs.len().min(2);
    let n_d = ds.len().min(MAX_FIG2_CURVES / n_f.max(1));
    let n_f = fs.len().min(MAX_FIG2_CURVES / n_d.max(1));
    let (ds, fs) = (spread(&ds, n_d), spread(&fs, n_f));

    let mut panel = Panel::new(Axis::linear("t (s)"), Axis::linear("M (kg)"));
    let mut table = Table::new(&[
        "D_mm", "f_Hz", "samples", "t_end_s", "M_end_kg", "Q_kg/s", "job",
    ]);
    let mut csv = Table::new(&[
        "label",
        "orifice_diameter_m",
        "rotation_frequency_hz",
        "t_s",
        "mass_kg",
    ]);
    for &d in &ds {
        for &f in &fs {
            // Replicas of one (D, f) look alike in M(t); the first done one stands for them.
            let Some(row) = rows.iter().find(|r| {
                same_value(r.orifice_diameter_m, d) && same_value(r.rotation_frequency_hz, f)
            }) else {
                continue;
            };
            let series = mass_series(conn, row.job_id)?;
            let last = series.last().copied();
            table.push(vec![
                mm(d),
                short(f),
                series.len().to_string(),
                fixed(last.map(|p| p.0), 2),
                sci(last.map(|p| p.1), 3),
                sci(row.q_kg_per_s, 3),
                row.label.clone(),
            ]);
            for &(t, m) in &series {
                csv.push(vec![
                    row.label.clone(),
                    csv_num(Some(d)),
                    csv_num(Some(f)),
                    csv_num(Some(t)),
                    csv_num(Some(m)),
                ]);
            }
            let label = format!("D = {} mm, f = {} Hz", mm(d), short(f));
            let (t, m): (Vec<f64>, Vec<f64>) = series.into_iter().unzip();
            let color = panel.series.len();
            panel.series.push(Series::line(Some(label), color, t, m));
        }
    }
    let fig = Figure {
        title: Some(format!(
            "Fig. 2: discharged mass M(t), campaign {}",
            campaign.name
        )),
        panels: vec![panel],
        columns: 1,
        panel_size: (1000, 700),
    };
    let mut text = String::from("M(t) from discharge_series, one done job per (D, f)\n");
    if table.rows.is_empty() {
        text.push_str("no done job with a discharge summary yet\n");
    } else {
        text.push_str(&table.to_text());
    }
    Ok(Drawn {
        text,
        files: write_all(&fig, &csv, out_dir, "fig2")?,
    })
}

/// One rotation frequency's flow rates and their Eq. (1) fit.
pub(crate) struct JandaRow {
    /// f, Hz.
    pub f_hz: f64,
    /// The combined points at this f, sorted by D.
    pub points: Vec<FlowPoint>,
    /// The fit; None with fewer than 3 orifices.
    pub fit: Option<JandaFit>,
    /// Whether the fit weighted points by 1/CI².
    pub weighted: bool,
}

/// Fits Eq. (1) per f. Points are weighted by 1/CI² when every point at that f has a positive
/// CI (Q spans an order of magnitude over D, so equal weights would ignore the small orifices).
pub(crate) fn janda_rows(points: &[FlowPoint]) -> Vec<JandaRow> {
    distinct(points.iter().map(|p| p.f_hz))
        .into_iter()
        .map(|f_hz| {
            let pts: Vec<FlowPoint> = points
                .iter()
                .filter(|p| same_value(p.f_hz, f_hz))
                .cloned()
                .collect();
            let d: Vec<f64> = pts.iter().map(|p| p.d_m).collect();
            let q: Vec<f64> = pts.iter().map(|p| p.q).collect();
            let w: Option<Vec<f64>> = pts
                .iter()
                .map(|p| {
                    p.ci.filter(|c| c.is_finite() && *c > 0.0)
                        .map(|c| 1.0 / (c * c))
                })
                .collect();
            let fit = janda_fit(&d, &q, w.as_deref());
            JandaRow {
                f_hz,
                points: pts,
                fit,
                weighted: w.is_some(),
            }
        })
        .collect()
}

/// Fig. 3: Q vs D per f with 95 % CIs and the Eq. (1) fits; second panel D_min = α2 ln α1 vs f.
pub(crate) fn fig3(conn: &Connection, campaign: &CampaignRef, out_dir: &Path) -> Result<Drawn> {
    let rows = done_discharge_rows(conn, campaign.id)?;
    let points = combine_replicas(&rows);
    let fits = janda_rows(&points);

    let mut q_panel = Panel::new(Axis::linear("D (mm)"), Axis::linear("Q (kg/s)"));
    q_panel.title = Some("Q vs D; lines: Q = C (1 − α1 e^(−D/α2)) D^(5/2)".into());
    let mut dmin_panel = Panel::new(
        Axis::linear("f (Hz)"),
        Axis::linear("D_min = α2 ln α1 (mm)"),
    );
    dmin_panel.title = Some("D_min vs f".into());
    dmin_panel.legend = Legend::Hidden;
    let mut fit_table = Table::new(&[
        "f_Hz",
        "n_D",
        "C_kg/(s·m^2.5)",
        "alpha1",
        "alpha2_mm",
        "D_min_mm",
        "D_min/d",
        "rms_kg/s",
        "weights",
    ]);
    let mut q_table = Table::new(&[
        "f_Hz",
        "D_mm",
        "D/d",
        "Q_kg/s",
        "ci95_kg/s",
        "ci95_from",
        "replicas",
        "Q_fit_kg/s",
    ]);
    let mut csv = Table::new(&[
        "rotation_frequency_hz",
        "orifice_diameter_m",
        "particle_diameter_m",
        "q_kg_per_s",
        "q_ci95_kg_per_s",
        "q_ci95_source",
        "replicas",
        "janda_q_kg_per_s",
        "janda_c",
        "janda_alpha1",
        "janda_alpha2_m",
        "janda_d_min_m",
    ]);
    let (mut dmin_f, mut dmin_mm) = (Vec::new(), Vec::new());
    for (color, row) in fits.iter().enumerate() {
        let fit = row.fit.as_ref();
        let d_mm: Vec<f64> = row.points.iter().map(|p| p.d_m * 1e3).collect();
        let q: Vec<f64> = row.points.iter().map(|p| p.q).collect();
        let err: Vec<Option<f64>> = row.points.iter().map(|p| p.ci).collect();
        let label = format!("f = {} Hz", short(row.f_hz));
        q_panel
            .series
            .push(Series::points(Some(label), color, d_mm.clone(), q).with_errors(err));
        if let Some(fit) = fit {
            let (lo, hi) = (row.points[0].d_m, row.points[row.points.len() - 1].d_m);
            let curve: Vec<(f64, f64)> = (0..=120)
                .map(|i| lo + (hi - lo) * f64::from(i) / 120.0)
                .map(|d| (d * 1e3, fit.predict(d)))
                .filter(|p| p.1 >= 0.0)
                .collect();
            let (x, y) = curve.into_iter().unzip();
            q_panel.series.push(Series::line(None, color, x, y));
            if let Some(d_min) = fit.d_min_m {
                dmin_f.push(row.f_hz);
                dmin_mm.push(d_min * 1e3);
            }
        }
        let particle_d = row.points.first().map(|p| p.particle_d_m);
        fit_table.push(vec![
            short(row.f_hz),
            row.points.len().to_string(),
            sci(fit.map(|f| f.c), 4),
            fixed(fit.map(|f| f.alpha1), 4),
            fixed(fit.map(|f| f.alpha2_m * 1e3), 4),
            fixed(fit.and_then(|f| f.d_min_m).map(|d| d * 1e3), 3),
            fixed(
                fit.and_then(|f| f.d_min_m)
                    .zip(particle_d)
                    .map(|(a, b)| a / b),
                3,
            ),
            sci(fit.map(|f| f.rms_residual_kg_per_s), 2),
            match (fit, row.weighted) {
                (None, _) => "no fit (< 3 D)".into(),
                (Some(f), weighted) => {
                    let mut w = String::from(if weighted { "1/ci95^2" } else { "equal" });
                    // Three parameters through three points test nothing of Eq. (1); an α2 at
                    // the end of its search range is not determined by the data.
                    if row.points.len() == 3 {
                        w += "; 3 D for 3 parameters";
                    }
                    if f.alpha2_at_bound {
                        w += "; alpha2 at its search bound";
                    }
                    w
                }
            },
        ]);
        for p in &row.points {
            let q_fit = fit.map(|f| f.predict(p.d_m));
            q_table.push(vec![
                short(p.f_hz),
                mm(p.d_m),
                fixed(Some(p.d_over_particle()), 2),
                sci(Some(p.q), 4),
                sci(p.ci, 2),
                ci_source_name(p.ci_source).into(),
                p.replicas.to_string(),
                sci(q_fit, 4),
            ]);
            csv.push(vec![
                csv_num(Some(p.f_hz)),
                csv_num(Some(p.d_m)),
                csv_num(Some(p.particle_d_m)),
                csv_num(Some(p.q)),
                csv_num(p.ci),
                ci_source_name(p.ci_source).into(),
                p.replicas.to_string(),
                csv_num(q_fit),
                csv_num(fit.map(|f| f.c)),
                csv_num(fit.map(|f| f.alpha1)),
                csv_num(fit.map(|f| f.alpha2_m)),
                csv_num(fit.and_then(|f| f.d_min_m)),
            ]);
        }
    }
    dmin_panel
        .series
        .push(Series::points(None, 0, dmin_f, dmin_mm));
    let fig = Figure {
        title: Some(format!(
            "Fig. 3: flow rate vs orifice diameter, campaign {}",
            campaign.name
        )),
        panels: vec![q_panel, dmin_panel],
        columns: 2,
        panel_size: (800, 600),
    };
    let mut text = String::from(
        "Janda fit Q = C (1 - alpha1 exp(-D/alpha2)) D^(5/2), per rotation frequency\n",
    );
    text.push_str(&fit_table.to_text());
    text.push_str(
        "\nflow rates (mean over replicas; ci95 from their spread when >= 2, else the job's own)\n",
    );
    text.push_str(&q_table.to_text());
    text.push('\n');
    text.push_str(&beverloo_line(&rows, &points));
    Ok(Drawn {
        text,
        files: write_all(&fig, &csv, out_dir, "fig3")?,
    })
}

fn ci_source_name(source: CiSource) -> &'static str {
    match source {
        CiSource::ReplicaSpread => "replicas",
        CiSource::SingleJob => "job",
    }
}

/// The Beverloo fit at f = 0 as one line of text, or why there is none.
fn beverloo_line(rows: &[DischargeRow], points: &[FlowPoint]) -> String {
    let still: Vec<&FlowPoint> = points.iter().filter(|p| same_value(p.f_hz, 0.0)).collect();
    if still.len() < 3 {
        return format!(
            "Beverloo fit at f = 0 Hz: needs >= 3 orifices with Q at f = 0, have {}\n",
            still.len()
        );
    }
    let (g, g_note) = match rows.iter().find_map(|r| gravity_m_per_s2(&r.params_json)) {
        Some(g) => (g, "from params_json"),
        None => (
            STANDARD_GRAVITY_M_PER_S2,
            "standard value: no gravity in params_json",
        ),
    };
    let d: Vec<f64> = still.iter().map(|p| p.d_m).collect();
    let q: Vec<f64> = still.iter().map(|p| p.q).collect();
    let (pd, rho) = (still[0].particle_d_m, still[0].bulk_density_kg_per_m3);
    match beverloo_fit(&d, &q, pd, rho, g) {
        Some(b) => format!(
            "Beverloo fit at f = 0 Hz, Q = C rho_b sqrt(g) (D - k d)^(5/2): C = {:.4}, k = {:.3} \
             (n = {}, d = {} mm, rho_b = {:.0} kg/m^3, g = {:.3} m/s^2 {g_note}, rms = {:.2e} kg/s)\n",
            b.c, b.k, b.n, mm(pd), rho, g, b.rms_residual_kg_per_s
        ),
        None => "Beverloo fit at f = 0 Hz: no fit (Q does not grow with D)\n".into(),
    }
}

fn curve_series(c: &NormalisedCurve, label: Option<String>, color: usize) -> Series {
    let f = c.points.iter().map(|p| p.0.f_hz).collect();
    let r = c.points.iter().map(|p| p.1).collect();
    Series::points(label, color, f, r).with_errors(c.points.iter().map(|p| p.2).collect())
}

/// Fig. 4: Q/Q_{f=1} vs f, one series per orifice.
pub(crate) fn fig4(conn: &Connection, campaign: &CampaignRef, out_dir: &Path) -> Result<Drawn> {
    let points = combine_replicas(&done_discharge_rows(conn, campaign.id)?);
    let norm = normalise(&points);
    let mut panel = Panel::new(Axis::linear("f (Hz)"), Axis::linear(norm.y_label()));
    panel.legend = Legend::LowerRight;
    for (i, c) in norm.curves.iter().enumerate() {
        let label = format!("D = {} mm ({:.2} d)", mm(c.d_m), c.d_m / c.particle_d_m);
        let s = curve_series(c, Some(label), i);
        // Lines guide the eye between the points of one orifice, as in the paper.
        panel
            .series
            .push(Series::line(None, i, s.x.clone(), s.y.clone()));
        panel.series.push(s);
    }
    let fig = Figure {
        title: Some(format!(
            "Fig. 4: normalised flow rate vs rotation frequency, campaign {}",
            campaign.name
        )),
        panels: vec![panel],
        columns: 1,
        panel_size: (1000, 700),
    };
    let (table, csv) = norm.tables(norm.curves.iter());
    let text = format!("{}{}", norm.note(), table.to_text());
    Ok(Drawn {
        text,
        files: write_all(&fig, &csv, out_dir, "fig4")?,
    })
}

/// Fig. 5: the normalised Q vs f, one panel per large orifice (D/d > 4.5), up to four.
pub(crate) fn fig5(conn: &Connection, campaign: &CampaignRef, out_dir: &Path) -> Result<Drawn> {
    let points = combine_replicas(&done_discharge_rows(conn, campaign.id)?);
    let norm = normalise(&points);
    let large: Vec<&NormalisedCurve> = norm
        .curves
        .iter()
        .filter(|c| c.d_m / c.particle_d_m > LARGE_ORIFICE_D_OVER_PARTICLE)
        .collect();
    let shown = spread(&large, MAX_FIG5_PANELS);
    let mut panels: Vec<Panel> = shown
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let mut p = Panel::new(Axis::linear("f (Hz)"), Axis::linear(norm.y_label()));
            p.title = Some(format!(
                "D = {} mm (D/d = {:.2})",
                mm(c.d_m),
                c.d_m / c.particle_d_m
            ));
            p.legend = Legend::Hidden;
            let s = curve_series(c, None, i);
            p.series
                .push(Series::line(None, i, s.x.clone(), s.y.clone()));
            p.series.push(s);
            p
        })
        .collect();
    if panels.is_empty() {
        let mut p = Panel::new(Axis::linear("f (Hz)"), Axis::linear(norm.y_label()));
        p.title = Some(format!(
            "no done orifice with D/d > {LARGE_ORIFICE_D_OVER_PARTICLE}"
        ));
        panels.push(p);
    }
    let fig = Figure {
        title: Some(format!(
            "Fig. 5: normalised flow rate, large orifices, campaign {}",
            campaign.name
        )),
        columns: panels.len().min(2),
        panels,
        panel_size: (700, 520),
    };
    let (table, csv) = norm.tables(shown.iter().copied());
    let mut text = norm.note();
    let _ = writeln!(
        text,
        "orifices with D/d > {LARGE_ORIFICE_D_OVER_PARTICLE}: {} found, {} shown",
        large.len(),
        shown.len()
    );
    text.push_str(&table.to_text());
    Ok(Drawn {
        text,
        files: write_all(&fig, &csv, out_dir, "fig5")?,
    })
}

#[cfg(test)]
mod tests {
    //! A synthetic campaign whose flow rates follow Eq. (1) exactly, with α1 and α2 varying
    //! linearly with f and C constant (as the paper reports), two replicas at some points, and
    //! one pending and one failed job. Each figure must draw, and Fig. 3 must give back the law.

    use std::path::Path;

    use rusqlite::{params, Connection};

    use crate::report::render_figure;

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
        conn.execute(
            "INSERT INTO campaigns (name, file, scene, spec_json, created_at) VALUES (?1, ?2, ?3, '{}', ?4)",
            params![name, format!("{name}.json"), scene, created_at],
        )
        .expect("insert campaign");
        conn.last_insert_rowid()
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
        let params_json = format!(
            r#"{{"orifice_diameter_m": {d}, "rotation_frequency_hz": {f}, "gravity_m_per_s2": 9.81}}"#
        );
        conn.execute(
            "INSERT INTO jobs (hash, scene, params_json, seed, status, target_time_s) \
             VALUES (?1, 'silo', ?2, 1, ?3, 3.0)",
            params![label, params_json, status],
        )
        .expect("insert job");
        let job = conn.last_insert_rowid();
        conn.execute(
            "INSERT INTO campaign_jobs (campaign_id, job_id, label) VALUES (?1, ?2, ?3)",
            params![campaign, job, label],
        )
        .expect("insert campaign_job");
        let Some((q, ci)) = q else { return };
        conn.execute(
            "INSERT INTO discharge_summary (job_id, orifice_diameter_m, rotation_frequency_hz, \
             particle_diameter_m, bulk_density_kg_per_m3, q_kg_per_s, q_ci95_kg_per_s, q_method, \
             flowing_time_s, discharged_mass_kg, discharged_count, clogs, clogged_time_s, \
             permanently_clogged) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, 'synthetic', 3.0, ?8, 100, 0, 0.0, 0)",
            params![job, d, f, PARTICLE_D_M, BULK_DENSITY, q, ci, 3.0 * q],
        )
        .expect("insert summary");
        for i in 0..=150 {
            let t = f64::from(i) * 0.02;
            conn.execute(
                "INSERT INTO discharge_series (job_id, t_s, mass_kg, count) VALUES (?1, ?2, ?3, ?4)",
                params![job, t, q * t, i],
            )
            .expect("insert series");
        }
    }

    /// The synthetic silo campaign 'rotating' over `freqs`, the most recent campaign (so the
    /// default), plus an older silo campaign and an older chute campaign.
    fn synthetic_db(freqs: &[f64]) -> Connection {
        let conn = Connection::open_in_memory().expect("in-memory db");
        conn.execute_batch(include_str!("../../../schema.sql"))
            .expect("schema");
        let old = add_campaign(&conn, "old_silo", "silo", "2020-01-01T00:00:00.000Z");
        add_job(&conn, old, "old", "done", 0.03, 0.5, Some((9.0, 0.1)));
        let id = add_campaign(&conn, "rotating", "silo", "2025-01-01T00:00:00.000Z");
        add_campaign(&conn, "chute_earlier", "chute", "2024-01-01T00:00:00.000Z");
        for (i, &d) in ORIFICES_M.iter().enumerate() {
            for &f in freqs {
                let q = law(d, f);
                let label = |r: u32| {
                    format!("orifice_diameter_m={d},rotation_frequency_hz={f},replica={r}")
                };
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
        let be =
            |i: usize| u32::from_be_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
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
            ("fig3", (1600, 640)),
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
            let v: Vec<f64> = line.split(',').map(|x| x.parse().expect(x)).collect();
            let (d, f, q, ci, ratio, err) = (v[0], v[2], v[3], v[4], v[6], v[7]);
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
            let v: Vec<f64> = line.split(',').map(|x| x.parse().expect(x)).collect();
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
            render_figure(&conn, "silo:fig3", Some("chute_earlier"), dir.path())
                .expect_err("scene")
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
}
