//! Figures 2–5 of the silo paper (PRE 2020, Sec. III.A) redrawn from a campaign's rows in the
//! database: M(t) (Fig. 2), Q(D) per f with the fit of Eq. (1) and D_min(f) (Fig. 3), and
//! Q/Q_{f=1} vs f (Figs. 4 and 5). Every number comes from discharge_summary and
//! discharge_series of the campaign's done jobs (and the earlier end of a job a round runs on,
//! noted as such); nothing from the paper is hard-coded.

pub(crate) mod fields;
mod flow_rate;
mod normalise;
mod normalised_q;
pub(crate) mod orifice_pressure;
#[cfg(test)]
mod tests;

pub(crate) use flow_rate::fig3;
pub(crate) use normalised_q::{fig4, fig5};

use anyhow::Result;
use rusqlite::Connection;

use super::campaign::CampaignRef;
use super::drawn::{write_all, Drawn, Output};
use super::plot::{Axis, Figure, Panel, Series};
use super::table::{csv_num, fixed, mm, sci, short, Table};
use super::thin::thinned;
use crate::pooled::silo::{
    distinct, drawable_discharge_rows, mass_series, same_value, spread, DischargeRow,
};

/// The note for the rows a round is running on ([`DischargeRow::running_on_to_s`]): which jobs
/// are drawn from their earlier end, and how far each now runs; None when none is.
pub(crate) fn running_on_note<'a>(
    rows: impl IntoIterator<Item = &'a DischargeRow>,
) -> Option<String> {
    let jobs: Vec<String> = rows
        .into_iter()
        .filter_map(|r| {
            let to = r.running_on_to_s?;
            Some(format!(
                "job {} ({} mm, {} Hz, to {} s)",
                r.job_id,
                mm(r.orifice_diameter_m),
                short(r.rotation_frequency_hz),
                short(to)
            ))
        })
        .collect();
    (!jobs.is_empty()).then(|| {
        format!(
            "drawn from the earlier end of job(s) a round runs on: {}",
            jobs.join(", ")
        )
    })
}

/// At most this many M(t) curves in Fig. 2, so the legend stays readable.
const MAX_FIG2_CURVES: usize = 8;

/// At most this many samples of each M(t) curve drawn and written to the CSV (the figure is
/// 1000 pixels wide).
const MAX_FIG2_SAMPLES: usize = 1000;

/// Fig. 2: discharged mass M(t) for up to eight (D, f), spread over the D and f present.
pub(crate) fn fig2(conn: &Connection, campaign: &CampaignRef, out_dir: &Output) -> Result<Drawn> {
    let rows = drawable_discharge_rows(conn, campaign.id)?;
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
    let mut drawn_running_on = Vec::new();
    for &d in &ds {
        for &f in &fs {
            // Replicas of one (D, f) look alike in M(t); the first done one stands for them, and
            // a job a round runs on (its earlier end) only when none has ended.
            let Some(row) = rows
                .iter()
                .filter(|r| {
                    same_value(r.orifice_diameter_m, d) && same_value(r.rotation_frequency_hz, f)
                })
                .min_by_key(|r| r.running_on_to_s.is_some())
            else {
                continue;
            };
            if row.running_on_to_s.is_some() {
                drawn_running_on.push(row);
            }
            let stored = mass_series(conn, row.job_id)?;
            let last = stored.last().copied();
            let series = thinned(&stored, MAX_FIG2_SAMPLES);
            table.push(vec![
                mm(d),
                short(f),
                stored.len().to_string(),
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
            // A run without Q clogged: its flat M(t) is drawn, and named so.
            let clogged = if row.q_kg_per_s.is_none() {
                ", clogged"
            } else {
                ""
            };
            let label = format!("D = {} mm, f = {} Hz{clogged}", mm(d), short(f));
            let (t, m): (Vec<f64>, Vec<f64>) = series.into_iter().unzip();
            let color = panel.series.len();
            panel.series.push(Series::line(Some(label), color, t, m));
        }
    }
    let running_on = running_on_note(drawn_running_on);
    panel.notes.extend(running_on.clone());
    let fig = Figure {
        title: Some(format!(
            "Fig. 2: discharged mass M(t), campaign {}",
            campaign.name
        )),
        panels: vec![panel],
        columns: 1,
        panel_size: (1000, 700),
    };
    let mut text = format!(
        "M(t) from discharge_series, one done job per (D, f), drawn and written at most \
         {MAX_FIG2_SAMPLES} evenly spaced samples per curve (`samples`: how many are stored)\n"
    );
    if let Some(note) = running_on {
        text.push_str(&format!("{note}\n"));
    }
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
