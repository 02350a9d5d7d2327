//! Fig. 3 of the silo paper: Q(D) per f with the fit of Eq. (1) (Janda) and D_min(f), with a
//! Beverloo line for reference.

use anyhow::Result;
use rusqlite::Connection;

use crate::observe::fits::{
    beverloo_bootstrap, beverloo_c_at_k, beverloo_fit, janda_bootstrap, janda_fit, BeverlooFit,
    JandaFit, JandaIntervals, JandaPoint, BOOTSTRAP_DRAWS, JANDA_PARAMETERS,
};
use crate::pooled::silo::{
    clogged_points, combine_replicas, distinct, drawable_discharge_rows, gravity_m_per_s2,
    replica_label, same_value, CiSource, CloggedPoint, DischargeRow, FlowPoint, REPLICA_NOTE,
};
use crate::report::campaign::CampaignRef;
use crate::report::drawn::{write_all, Drawn, Output};
use crate::report::plot::{Axis, Figure, Legend, Marker, Panel, Series};
use crate::report::table::{csv_num, fixed, mm, sci, short, Table};

/// Used for Beverloo only when no job parameter gives gravity; the table says so.
const STANDARD_GRAVITY_M_PER_S2: f64 = 9.806_65;

/// One rotation frequency's flow rates and their Eq. (1) fit.
pub(crate) struct JandaRow {
    /// f, Hz.
    pub f_hz: f64,
    /// The combined points at this f, sorted by D.
    pub points: Vec<FlowPoint>,
    /// The fit; None with no more points than the law's 3 parameters (a curve through 3 points
    /// tests nothing of Eq. (1)).
    pub fit: Option<JandaFit>,
    /// 95 % bootstrap intervals of the fit's parameters.
    pub intervals: Option<JandaIntervals>,
    /// Whether the fit weighted points by 1/CI².
    pub weighted: bool,
}

impl JandaRow {
    /// Why the figure draws no D_min for this f, if it draws none: no fit, or α2 at the end of
    /// its search range (D_min = α2 ln α1 then follows the bound, not the data).
    pub fn d_min_refused(&self) -> Option<String> {
        let f = short(self.f_hz);
        match &self.fit {
            None => Some(format!(
                "f = {f} Hz: {} D for {JANDA_PARAMETERS} parameters, no fit drawn",
                self.points.len()
            )),
            Some(fit) if fit.alpha2_at_bound => Some(format!(
                "f = {f} Hz: α2 at its search bound ({:.0} mm), D_min not determined",
                fit.alpha2_m * 1e3
            )),
            Some(fit) if fit.d_min_m.is_none() => Some(format!("f = {f} Hz: α1 ≤ 0, no D_min")),
            Some(_) => None,
        }
    }
}

/// Fits Eq. (1) per f. Points are weighted by 1/CI² when every point at that f has a positive
/// CI (Q spans an order of magnitude over D, so equal weights would ignore the small orifices).
/// No fit with ≤ 3 points; the uncertainty is a bootstrap over replicas (or each point's CI),
/// seeded by f so that a figure redrawn gives the same intervals.
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
            let enough = pts.len() > JANDA_PARAMETERS;
            let fit = enough.then(|| janda_fit(&d, &q, w.as_deref())).flatten();
            let boot: Vec<JandaPoint> = pts.iter().map(fit_point).collect();
            let intervals = fit
                .as_ref()
                .and_then(|_| janda_bootstrap(&boot, f_hz.to_bits() ^ BOOTSTRAP_SEED));
            JandaRow {
                f_hz,
                points: pts,
                fit,
                intervals,
                weighted: w.is_some(),
            }
        })
        .collect()
}

/// Seed of the Janda bootstrap (xor the bits of f): fixed, so figures are reproducible.
const BOOTSTRAP_SEED: u64 = 0x005e_ed0f_7a9d_a000;

/// "[lo, hi]" in mm, or "-".
fn interval_mm(iv: Option<(f64, f64)>) -> String {
    iv.map_or_else(
        || "-".into(),
        |(lo, hi)| format!("[{:.3}, {:.3}]", lo * 1e3, hi * 1e3),
    )
}

/// Fig. 3: Q vs D per f with 95 % CIs and the Eq. (1) fits; second panel D_min = α2 ln α1 vs f.
pub(crate) fn fig3(conn: &Connection, campaign: &CampaignRef, out_dir: &Output) -> Result<Drawn> {
    let rows = drawable_discharge_rows(conn, campaign.id)?;
    let running_on = super::running_on_note(&rows);
    let points = combine_replicas(&rows);
    let clogged = clogged_points(&rows);
    let fits = janda_rows(&points);
    let mut f3 = Fig3::new();
    for (color, row) in fits.iter().enumerate() {
        f3.add(color, row);
    }
    mark_clogged(
        &mut f3.q_panel,
        &clogged,
        &fits,
        &mut f3.q_table,
        &mut f3.csv,
    );
    if points.iter().any(|p| p.replicas > 1) {
        f3.q_panel.notes.push(REPLICA_NOTE.into());
    }
    f3.q_panel
        .notes
        .extend(crate::pooled::silo::target_note(conn, campaign.id)?);
    f3.q_panel.notes.extend(running_on.clone());
    let dmin_label = (!f3.dmin_f.is_empty()).then(|| "D_min, 95 % bootstrap".to_string());
    f3.dmin_panel
        .series
        .push(Series::points(dmin_label, 0, f3.dmin_f, f3.dmin_mm).with_intervals(f3.dmin_iv));
    if !f3.refused_f.is_empty() {
        f3.dmin_panel.series.push(
            Series::axis_marks(Some("no D_min (see notes)".into()), 3, f3.refused_f, 0)
                .with_marker(Marker::Cross),
        );
    }
    let fig = Figure {
        title: Some(format!(
            "Fig. 3: flow rate vs orifice diameter, campaign {}",
            campaign.name
        )),
        panels: vec![f3.q_panel, f3.dmin_panel],
        columns: 2,
        panel_size: (900, 640),
    };
    let mut text = String::from(
        "Janda fit Q = C (1 - alpha1 exp(-D/alpha2)) D^(5/2), per rotation frequency\n",
    );
    if let Some(note) = running_on {
        text.push_str(&format!("{note}\n"));
    }
    text.push_str(&f3.fit_table.to_text());
    text.push_str(
        "\nflow rates over replicas: ci95_from 'pooled blocks' (every replica's blocks pooled, \
         weighted by their count), 'replica spread' (>= 3 replicas that scatter more than their \
         blocks say), 'replicas' (Student t over >= 2 replicas without block counts), 'job' \
         (one run's own); replicas = runs with Q, clogged = runs without\n",
    );
    text.push_str(&f3.q_table.to_text());
    text.push('\n');
    text.push_str(&beverloo_line(&rows, &points));
    Ok(Drawn {
        text,
        files: write_all(&fig, &f3.csv, out_dir, "fig3")?,
    })
}

/// What Fig. 3 gathers over the rotation frequencies: its two panels, the fit and flow-rate
/// tables, the CSV, and the D_min panel's points (and the frequencies without one).
struct Fig3 {
    q_panel: Panel,
    dmin_panel: Panel,
    fit_table: Table,
    q_table: Table,
    csv: Table,
    dmin_f: Vec<f64>,
    dmin_mm: Vec<f64>,
    dmin_iv: Vec<Option<(f64, f64)>>,
    refused_f: Vec<f64>,
}

impl Fig3 {
    fn new() -> Self {
        let mut q_panel = Panel::new(Axis::linear("D (mm)"), Axis::linear("Q (kg/s)"));
        q_panel.title = Some("Q vs D; lines: Q = C (1 − α1 e^(−D/α2)) D^(5/2)".into());
        let mut dmin_panel = Panel::new(
            Axis::linear("f (Hz)"),
            Axis::linear("D_min = α2 ln α1 (mm)"),
        );
        dmin_panel.title = Some("D_min vs f".into());
        dmin_panel.legend = Legend::Outside;
        Fig3 {
            q_panel,
            dmin_panel,
            fit_table: Table::new(&[
                "f_Hz",
                "n_D",
                "C_kg/(s·m^2.5)",
                "alpha1",
                "alpha2_mm",
                "D_min_mm",
                "D_min/d",
                "rms_kg/s",
                "D_min_ci95_mm",
                "alpha2_ci95_mm",
                "weights",
            ]),
            q_table: Table::new(&[
                "f_Hz",
                "D_mm",
                "D/d",
                "Q_kg/s",
                "ci95_kg/s",
                "ci95_from",
                "replicas",
                "clogged",
                "Q_fit_kg/s",
            ]),
            csv: Table::new(&[
                "rotation_frequency_hz",
                "orifice_diameter_m",
                "particle_diameter_m",
                "q_kg_per_s",
                "q_ci95_kg_per_s",
                "q_ci95_source",
                "replicas",
                "clogged_runs",
                "janda_q_kg_per_s",
                "janda_c",
                "janda_alpha1",
                "janda_alpha2_m",
                "janda_d_min_m",
                "janda_d_min_ci95_lo_m",
                "janda_d_min_ci95_hi_m",
            ]),
            dmin_f: Vec::new(),
            dmin_mm: Vec::new(),
            dmin_iv: Vec::new(),
            refused_f: Vec::new(),
        }
    }

    /// One rotation frequency: its Q points and fitted curve, its D_min (or why none), its
    /// fit's row and its points' rows.
    fn add(&mut self, color: usize, row: &JandaRow) {
        let fit = row.fit.as_ref();
        let d_mm: Vec<f64> = row.points.iter().map(|p| p.d_m * 1e3).collect();
        let q: Vec<f64> = row.points.iter().map(|p| p.q).collect();
        let err: Vec<Option<f64>> = row.points.iter().map(|p| p.ci).collect();
        let label = format!("f = {} Hz", short(row.f_hz));
        let counts = row
            .points
            .iter()
            .map(|p| replica_label(p.replicas))
            .collect();
        self.q_panel.series.push(
            Series::points(Some(label), color, d_mm, q)
                .with_errors(err)
                .with_point_labels(counts),
        );
        if let Some(fit) = fit {
            let (lo, hi) = (row.points[0].d_m, row.points[row.points.len() - 1].d_m);
            let curve: Vec<(f64, f64)> = (0..=120)
                .map(|i| lo + (hi - lo) * f64::from(i) / 120.0)
                .map(|d| (d * 1e3, fit.predict(d)))
                .filter(|p| p.1 >= 0.0)
                .collect();
            let (x, y) = curve.into_iter().unzip();
            self.q_panel.series.push(Series::line(None, color, x, y));
        }
        match (row.d_min_refused(), fit.and_then(|f| f.d_min_m)) {
            (None, Some(d_min)) => {
                self.dmin_f.push(row.f_hz);
                self.dmin_mm.push(d_min * 1e3);
                let iv = row.intervals.and_then(|i| i.d_min_m);
                self.dmin_iv.push(iv.map(|(lo, hi)| (lo * 1e3, hi * 1e3)));
            }
            (Some(why), _) => {
                self.refused_f.push(row.f_hz);
                if fit.is_none() {
                    self.q_panel.notes.push(why.clone());
                }
                self.dmin_panel.notes.push(why);
            }
            (None, None) => {}
        }
        self.fit_table.push(fit_row(row));
        for p in &row.points {
            let q_fit = fit.map(|f| f.predict(p.d_m));
            self.q_table.push(vec![
                short(p.f_hz),
                mm(p.d_m),
                fixed(Some(p.d_over_particle()), 2),
                sci(Some(p.q), 4),
                sci(p.ci, 2),
                ci_source_name(p.ci_source).into(),
                p.replicas.to_string(),
                p.clogged_replicas.to_string(),
                sci(q_fit, 4),
            ]);
            self.csv.push(vec![
                csv_num(Some(p.f_hz)),
                csv_num(Some(p.d_m)),
                csv_num(Some(p.particle_d_m)),
                csv_num(Some(p.q)),
                csv_num(p.ci),
                ci_source_name(p.ci_source).into(),
                p.replicas.to_string(),
                p.clogged_replicas.to_string(),
                csv_num(q_fit),
                csv_num(fit.map(|f| f.c)),
                csv_num(fit.map(|f| f.alpha1)),
                csv_num(fit.map(|f| f.alpha2_m)),
                csv_num(fit.and_then(|f| f.d_min_m)),
                csv_num(row.intervals.and_then(|i| i.d_min_m).map(|i| i.0)),
                csv_num(row.intervals.and_then(|i| i.d_min_m).map(|i| i.1)),
            ]);
        }
    }
}

/// The fit table's row of one rotation frequency.
fn fit_row(row: &JandaRow) -> Vec<String> {
    let fit = row.fit.as_ref();
    let particle_d = row.points.first().map(|p| p.particle_d_m);
    vec![
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
        interval_mm(row.intervals.and_then(|i| i.d_min_m)),
        interval_mm(row.intervals.map(|i| i.alpha2_m)),
        match (fit, row.weighted) {
            (None, _) => format!(
                "no fit ({} D for {JANDA_PARAMETERS} parameters)",
                row.points.len()
            ),
            (Some(f), weighted) => {
                let mut w = String::from(if weighted { "1/ci95^2" } else { "equal" });
                // An α2 at the end of its search range is not determined by the data.
                if f.alpha2_at_bound {
                    w += "; alpha2 at its search bound";
                }
                match row.intervals {
                    Some(i) => w += &format!("; bootstrap {}/{BOOTSTRAP_DRAWS}", i.draws),
                    None => w += "; no bootstrap",
                }
                w
            }
        },
    ]
}

/// Crosses on the D axis for the (D, f) where every run clogged (in the colour of its f), a
/// legend entry "clogged", and their rows in the tables (Q empty).
fn mark_clogged(
    panel: &mut Panel,
    clogged: &[CloggedPoint],
    fits: &[JandaRow],
    q_table: &mut Table,
    csv: &mut Table,
) {
    if clogged.is_empty() {
        return;
    }
    let fs = distinct(
        fits.iter()
            .map(|r| r.f_hz)
            .chain(clogged.iter().map(|c| c.f_hz)),
    );
    for (k, &f) in fs.iter().enumerate() {
        // The colour of f's flow-rate series, so a cross says which f clogged.
        let color = fits
            .iter()
            .position(|r| same_value(r.f_hz, f))
            .unwrap_or(fits.len() + k);
        let at: Vec<f64> = clogged
            .iter()
            .filter(|c| same_value(c.f_hz, f))
            .map(|c| c.d_m * 1e3)
            .collect();
        if !at.is_empty() {
            panel.series.push(Series::axis_marks(None, color, at, k));
        }
    }
    panel.series.push(Series::axis_marks(
        Some("clogged (no Q)".into()),
        7,
        Vec::new(),
        0,
    ));
    for c in clogged {
        q_table.push(vec![
            short(c.f_hz),
            mm(c.d_m),
            fixed(Some(c.d_m / c.particle_d_m), 2),
            "clogged".into(),
            "-".into(),
            "-".into(),
            "0".into(),
            c.runs.to_string(),
            "-".into(),
        ]);
        csv.push(vec![
            csv_num(Some(c.f_hz)),
            csv_num(Some(c.d_m)),
            csv_num(Some(c.particle_d_m)),
            String::new(),
            String::new(),
            "clogged".into(),
            "0".into(),
            c.runs.to_string(),
            String::new(),
            String::new(),
            String::new(),
            String::new(),
            String::new(),
            String::new(),
            String::new(),
        ]);
    }
}

/// A flow point as the fits' bootstrap redraws it: its Q, its replicas' Q and its CI.
fn fit_point(p: &FlowPoint) -> JandaPoint {
    JandaPoint {
        d_m: p.d_m,
        q: p.q,
        replica_q: p.replica_q.clone(),
        ci95: p.ci,
    }
}

/// ", 95 % bootstrap: C in [..], k in [..]" for the Beverloo fit over `still`, or why not.
fn beverloo_intervals(still: &[&FlowPoint], pd: f64, rho: f64, g: f64) -> String {
    let points: Vec<JandaPoint> = still.iter().map(|p| fit_point(p)).collect();
    match beverloo_bootstrap(&points, pd, rho, g, BOOTSTRAP_SEED) {
        Some(iv) => format!(
            "; 95 % bootstrap {}/{BOOTSTRAP_DRAWS}: C in [{:.4}, {:.4}], k in [{:.3}, {:.3}]",
            iv.draws, iv.c.0, iv.c.1, iv.k.0, iv.k.1
        ),
        None => "; no bootstrap interval (too few points or fits)".into(),
    }
}

fn ci_source_name(source: CiSource) -> &'static str {
    source.name()
}

/// Beverloo's k for spheres, and the C of his experiments (Beverloo, Leniger & van de Velde
/// 1961 report C = 0.55–0.65); the silo paper gives neither.
const BEVERLOO_K_SPHERES: f64 = 1.5;
const BEVERLOO_C_LITERATURE: f64 = 0.58;

/// The Beverloo law at f = 0 as text: the fit of C and k (≥ 3 orifices), else why there is
/// none; then, with any orifice, C at k = 1.5 and each Q against the law with the literature's
/// C and k.
fn beverloo_line(rows: &[DischargeRow], points: &[FlowPoint]) -> String {
    let still: Vec<&FlowPoint> = points.iter().filter(|p| same_value(p.f_hz, 0.0)).collect();
    let (g, g_note) = match rows.iter().find_map(|r| gravity_m_per_s2(&r.params_json)) {
        Some(g) => (g, "from params_json"),
        None => (
            STANDARD_GRAVITY_M_PER_S2,
            "standard value: no gravity in params_json",
        ),
    };
    let d: Vec<f64> = still.iter().map(|p| p.d_m).collect();
    let q: Vec<f64> = still.iter().map(|p| p.q).collect();
    let (pd, rho) = still.first().map_or((f64::NAN, f64::NAN), |p| {
        (p.particle_d_m, p.bulk_density_kg_per_m3)
    });
    let mut text = if still.len() < 3 {
        format!(
            "Beverloo fit at f = 0 Hz: needs >= 3 orifices with Q at f = 0, have {}\n",
            still.len()
        )
    } else {
        match beverloo_fit(&d, &q, pd, rho, g) {
            Some(b) => format!(
                "Beverloo fit at f = 0 Hz, Q = C rho_b sqrt(g) (D - k d)^(5/2): C = {:.4}, k = {:.3}{} \
                 (n = {}, d = {} mm, rho_b = {:.0} kg/m^3, g = {:.3} m/s^2 {g_note}, rms = {:.2e} kg/s)\n",
                b.c,
                b.k,
                beverloo_intervals(&still, pd, rho, g),
                b.n,
                mm(pd),
                rho,
                g,
                b.rms_residual_kg_per_s
            ),
            None => "Beverloo fit at f = 0 Hz: no fit (Q does not grow with D)\n".into(),
        }
    };
    let k = BEVERLOO_K_SPHERES;
    if let Some(c) = beverloo_c_at_k(&d, &q, pd, rho, g, k) {
        let literature = BeverlooFit {
            c: BEVERLOO_C_LITERATURE,
            k,
            rms_residual_kg_per_s: f64::NAN,
            n: 0,
        };
        let ratios: Vec<String> = still
            .iter()
            .map(|p| {
                let law = literature.predict(p.d_m, pd, rho, g);
                format!("{} mm: {}", mm(p.d_m), fixed(Some(p.q / law), 3))
            })
            .collect();
        text.push_str(&format!(
            "Beverloo at f = 0 Hz with k = {k} held: C = {c:.4} over {} orifice(s) (literature \
             0.55-0.65); Q / Q_Beverloo(C = {BEVERLOO_C_LITERATURE}, k = {k}): {}\n",
            still.len(),
            ratios.join(", ")
        ));
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A point at f = 0 whose Q follows `law`, with the reproduction's d and ρ_b.
    fn point(d_m: f64, law: &BeverlooFit, scale: f64) -> FlowPoint {
        let (pd, rho) = (0.0058, 1637.9);
        let q = scale * law.predict(d_m, pd, rho, STANDARD_GRAVITY_M_PER_S2);
        FlowPoint {
            d_m,
            f_hz: 0.0,
            particle_d_m: pd,
            bulk_density_kg_per_m3: rho,
            q,
            ci: None,
            replicas: 1,
            ci_source: CiSource::SingleJob,
            se: None,
            dof: f64::INFINITY,
            clogged_replicas: 0,
            replica_q: vec![q],
        }
    }

    #[test]
    fn beverloo_with_the_literature_constants_reads_back_c_and_the_ratios() {
        let law = BeverlooFit {
            c: BEVERLOO_C_LITERATURE,
            k: BEVERLOO_K_SPHERES,
            rms_residual_kg_per_s: 0.0,
            n: 0,
        };
        // Two orifices, too few for the fit of C and k: C at k = 1.5 and the ratios still come.
        let two = [point(0.025, &law, 1.0), point(0.032, &law, 1.0)];
        let text = beverloo_line(&[], &two);
        assert!(text.contains("needs >= 3 orifices"), "{text}");
        assert!(text.contains("C = 0.5800 over 2 orifice(s)"), "{text}");
        assert!(text.contains("25 mm: 1.000, 32 mm: 1.000"), "{text}");
        // Flow rates 10 % below the law: C and every ratio fall by 10 %.
        let low = [point(0.025, &law, 0.9), point(0.032, &law, 0.9)];
        let text = beverloo_line(&[], &low);
        assert!(text.contains("C = 0.5220 over 2"), "{text}");
        assert!(text.contains("25 mm: 0.900, 32 mm: 0.900"), "{text}");
        let none = beverloo_line(&[], &[]);
        assert_eq!(
            none,
            "Beverloo fit at f = 0 Hz: needs >= 3 orifices with Q at f = 0, have 0\n"
        );
    }
}
