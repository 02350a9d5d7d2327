//! Figs. 4 and 5 of the silo paper: Q/Q_{f=1} vs f, per orifice (Fig. 4) and for the large
//! orifices one panel each (Fig. 5).

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;
use rusqlite::Connection;

use crate::report::campaign::CampaignRef;
use crate::report::drawn::{write_all, Drawn};
use crate::report::plot::{Axis, Figure, Legend, Panel, Series};
use crate::report::silo::data::{combine_replicas, done_discharge_rows, spread};
use crate::report::silo::normalise::{normalise, NormalisedCurve};
use crate::report::table::mm;

/// Fig. 5 shows orifices with D/d above this (the paper: no permanent clog at f = 0 above ~4.5 d).
const LARGE_ORIFICE_D_OVER_PARTICLE: f64 = 4.5;
/// Fig. 5 has up to this many panels, as in the paper.
const MAX_FIG5_PANELS: usize = 4;

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
