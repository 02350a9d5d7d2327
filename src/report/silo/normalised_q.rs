//! Figs. 4 and 5 of the silo paper: Q/Q_{f=1} vs f, per orifice (Fig. 4) and for the large
//! orifices one panel each (Fig. 5).

use std::fmt::Write as _;

use anyhow::Result;
use rusqlite::Connection;

use crate::pooled::silo::{
    clogged_points, combine_replicas, distinct, drawable_discharge_rows, replica_label, same_value,
    spread, target_note, CloggedPoint, REPLICA_NOTE,
};
use crate::report::campaign::CampaignRef;
use crate::report::drawn::{write_all, Drawn, Output};
use crate::report::plot::{Axis, Figure, Legend, Panel, Series};
use crate::report::silo::normalise::{normalise, Normalised, NormalisedCurve};
use crate::report::table::mm;

/// Fig. 5 shows orifices with D/d above this (the paper: no permanent clog at f = 0 above ~4.5 d).
const LARGE_ORIFICE_D_OVER_PARTICLE: f64 = 4.5;
/// Fig. 5 has up to this many panels, as in the paper.
const MAX_FIG5_PANELS: usize = 4;

fn curve_series(c: &NormalisedCurve, label: Option<String>, color: usize) -> Series {
    let f = c.points.iter().map(|p| p.0.f_hz).collect();
    let r = c.points.iter().map(|p| p.1).collect();
    let counts = c
        .points
        .iter()
        .map(|p| replica_label(p.0.replicas))
        .collect();
    Series::points(label, color, f, r)
        .with_errors(c.points.iter().map(|p| p.2).collect())
        .with_point_labels(counts)
}

/// Whether any point of `curves` combines more than one replica (the figure then explains its
/// "n=K" texts).
fn any_replicas<'a>(mut curves: impl Iterator<Item = &'a NormalisedCurve>) -> bool {
    curves.any(|c| c.points.iter().any(|p| p.0.replicas > 1))
}

/// The colour of orifice `d`: its curve's index, or after the curves for an orifice without one.
fn color_of(norm: &Normalised, d: f64, others: &[f64]) -> usize {
    norm.curves
        .iter()
        .position(|c| same_value(c.d_m, d))
        .or_else(|| {
            others
                .iter()
                .position(|o| same_value(*o, d))
                .map(|k| norm.curves.len() + k)
        })
        .unwrap_or(0)
}

/// Crosses on the f axis where every run of (D, f) clogged, in D's colour, one lane per D, and
/// the legend entry "clogged"; the clogged points as text lines.
fn clogged_marks(norm: &Normalised, clogged: &[CloggedPoint], only_d: Option<f64>) -> Vec<Series> {
    let clogged: Vec<&CloggedPoint> = clogged
        .iter()
        .filter(|c| only_d.is_none_or(|d| same_value(c.d_m, d)))
        .collect();
    if clogged.is_empty() {
        return Vec::new();
    }
    let others: Vec<f64> = distinct(clogged.iter().map(|c| c.d_m))
        .into_iter()
        .filter(|d| !norm.curves.iter().any(|c| same_value(c.d_m, *d)))
        .collect();
    let mut out = Vec::new();
    for (lane, d) in distinct(clogged.iter().map(|c| c.d_m))
        .into_iter()
        .enumerate()
    {
        let fs = clogged
            .iter()
            .filter(|c| same_value(c.d_m, d))
            .map(|c| c.f_hz)
            .collect();
        out.push(Series::axis_marks(
            None,
            color_of(norm, d, &others),
            fs,
            lane,
        ));
    }
    out.push(Series::axis_marks(
        Some("clogged (no Q)".into()),
        7,
        Vec::new(),
        0,
    ));
    out
}

/// Text lines naming the clogged points.
fn clogged_note(clogged: &[CloggedPoint]) -> String {
    let mut s = String::new();
    for c in clogged {
        let _ = writeln!(
            s,
            "clogged: D = {} mm ({:.2} d), f = {} Hz: {} run(s), none with Q (a cross on the f axis)",
            mm(c.d_m),
            c.d_m / c.particle_d_m,
            crate::report::table::short(c.f_hz),
            c.runs
        );
    }
    s
}

/// Fig. 4: Q/Q_{f=1} vs f, one series per orifice.
pub(crate) fn fig4(conn: &Connection, campaign: &CampaignRef, out_dir: &Output) -> Result<Drawn> {
    let rows = drawable_discharge_rows(conn, campaign.id)?;
    let running_on = super::running_on_note(&rows);
    let points = combine_replicas(&rows);
    let clogged = clogged_points(&rows);
    let norm = normalise(&points);
    let mut panel = Panel::new(Axis::linear("f (Hz)"), Axis::linear(norm.y_label()));
    panel.legend = Legend::Outside;
    for (i, c) in norm.curves.iter().enumerate() {
        let label = format!("D = {} mm ({:.2} d)", mm(c.d_m), c.d_m / c.particle_d_m);
        let s = curve_series(c, Some(label), i);
        // Lines guide the eye between the points of one orifice, as in the paper.
        panel
            .series
            .push(Series::line(None, i, s.x.clone(), s.y.clone()));
        panel.series.push(s);
    }
    panel.series.extend(clogged_marks(&norm, &clogged, None));
    if any_replicas(norm.curves.iter()) {
        panel.notes.push(REPLICA_NOTE.into());
    }
    let target = target_note(conn, campaign.id)?;
    panel.notes.extend(target.clone());
    panel.notes.extend(running_on.clone());
    for &d in &norm.skipped_d_m {
        panel.notes.push(format!(
            "D = {} mm: no Q at the reference f, not normalised",
            mm(d)
        ));
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
    let all_clogged: Vec<&CloggedPoint> = clogged.iter().collect();
    let (table, csv) = norm.tables(norm.curves.iter(), &all_clogged);
    let text = format!(
        "{}{}{}{}{}",
        norm.note(),
        clogged_note(&clogged),
        target.map_or_else(String::new, |t| format!("{t}\n")),
        running_on.map_or_else(String::new, |t| format!("{t}\n")),
        table.to_text()
    );
    Ok(Drawn {
        text,
        files: write_all(&fig, &csv, out_dir, "fig4")?,
    })
}

/// Fig. 5: the normalised Q vs f, one panel per large orifice (D/d > 4.5), up to four.
pub(crate) fn fig5(conn: &Connection, campaign: &CampaignRef, out_dir: &Output) -> Result<Drawn> {
    let rows = drawable_discharge_rows(conn, campaign.id)?;
    let running_on = super::running_on_note(&rows);
    let points = combine_replicas(&rows);
    let clogged = clogged_points(&rows);
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
            if any_replicas(std::iter::once(*c)) {
                // No side column here (it would narrow the plot): the title says it.
                if let Some(t) = &mut p.title {
                    t.push_str("; n=K: K replicas");
                }
            }
            let s = curve_series(c, None, i);
            p.series
                .push(Series::line(None, i, s.x.clone(), s.y.clone()));
            p.series.push(s);
            let marks = clogged_marks(&norm, &clogged, Some(c.d_m));
            let here = rows
                .iter()
                .filter(|r| same_value(r.orifice_diameter_m, c.d_m));
            p.notes.extend(super::running_on_note(here));
            if !marks.is_empty() || !p.notes.is_empty() {
                p.legend = Legend::Outside;
            }
            p.series.extend(marks);
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
    let shown_clogged: Vec<&CloggedPoint> = clogged
        .iter()
        .filter(|c| shown.iter().any(|s| same_value(s.d_m, c.d_m)))
        .collect();
    let (table, csv) = norm.tables(shown.iter().copied(), &shown_clogged);
    let mut text = norm.note();
    text.push_str(&clogged_note(&clogged));
    if let Some(note) = &running_on {
        let _ = writeln!(text, "{note}");
    }
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
