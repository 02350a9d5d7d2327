//! Fig. 11 of the silo paper: ⟨p^k⟩ in the cylinder of radius and height D/2 above the orifice
//! vs f per D, over each job's flowing samples (clogged intervals left out).

use anyhow::Result;
use rusqlite::Connection;

use crate::pooled::orifice_pressure::{point_pk, PkJob};
use crate::pooled::silo::{distinct, replica_label, same_value};
use crate::report::campaign::CampaignRef;
use crate::report::drawn::{write_all, Drawn, Output};
use crate::report::plot::{Axis, Figure, Legend, Panel, Series};
use crate::report::table::{csv_num, mm, short, Table};

use super::fields::{field_jobs, FieldJob};

/// Fig. 11: ⟨p^k⟩ in the orifice cylinder vs f per D, (a) in Pa, (b) normalised by its value at
/// f = 1 Hz (or at the lowest f present when 1 Hz is absent, as the caption then says); error
/// bars are 95 % CIs (replicas combined: their mean, CI from the replica spread when there are
/// several). A (D, f) whose runs all clogged is a cross on the f axis, never a value; an
/// orifice without a grid point in its cylinder is named in a note.
pub(crate) fn fig11(conn: &Connection, c: &CampaignRef, out: &Output) -> Result<Drawn> {
    let jobs = field_jobs(conn, c)?;
    let ds = distinct(jobs.iter().map(|j| j.d_m));
    let fs_all = distinct(jobs.iter().map(|j| j.f_hz));
    let one_hz = fs_all.iter().any(|f| same_value(*f, 1.0));
    let f_ref = if one_hz { 1.0 } else { fs_all[0] };
    let mut abs = Panel::new(Axis::linear("f (Hz)"), Axis::linear("⟨p^k⟩ (Pa)"));
    let mut rel = Panel::new(
        Axis::linear("f (Hz)"),
        Axis::linear(format!("⟨p^k⟩ / ⟨p^k⟩(f = {} Hz)", short(f_ref))),
    );
    let mut csv = Table::new(&[
        "d_m",
        "f_hz",
        "pk_pa",
        "pk_ci95_pa",
        "jobs",
        "samples",
        "pk_over_ref",
        "pk_over_ref_ci95",
        "clogged_runs",
    ]);
    let mut any_clogged = false;
    for (k, &d) in ds.iter().enumerate() {
        let fs = distinct(jobs.iter().filter(|j| same_value(j.d_m, d)).map(|j| j.f_hz));
        let OrificePoints {
            pts,
            clogged,
            no_grid,
        } = orifice_points(conn, &jobs, d, &fs)?;
        let mut clogged_fs = Vec::new();
        for (f, runs) in clogged {
            clogged_fs.push(f);
            csv.push(vec![
                csv_num(Some(d)),
                short(f),
                String::new(),
                String::new(),
                "0".into(),
                "0".into(),
                String::new(),
                String::new(),
                runs.to_string(),
            ]);
        }
        if no_grid {
            let note = format!(
                "D = {} mm: no grid point inside the orifice cylinder (finer spacing_m needed)",
                mm(d)
            );
            rel.notes.push(note);
        }
        let reference = pts
            .iter()
            .find(|p| same_value(p.0, f_ref))
            .map(|p| (p.1, p.2));
        let label = Some(format!("D = {} mm", mm(d)));
        abs.series.push(
            Series::points(
                label.clone(),
                k,
                pts.iter().map(|p| p.0).collect(),
                pts.iter().map(|p| p.1).collect(),
            )
            .with_errors(pts.iter().map(|p| p.2).collect())
            .with_point_labels(pts.iter().map(|p| replica_label(p.3)).collect()),
        );
        let mut rx = Vec::new();
        let mut ry = Vec::new();
        let mut re = Vec::new();
        for p in &pts {
            let (ratio, err) = ratio_to(p, reference, f_ref);
            if let Some(r) = ratio {
                rx.push(p.0);
                ry.push(r);
                re.push(err);
            }
            csv.push(vec![
                csv_num(Some(d)),
                short(p.0),
                csv_num(Some(p.1)),
                csv_num(p.2),
                p.3.to_string(),
                p.4.to_string(),
                csv_num(ratio),
                csv_num(err),
                p.5.to_string(),
            ]);
        }
        if reference.is_none() && !pts.is_empty() {
            rel.notes.push(format!(
                "D = {} mm: no value at f = {} Hz, not normalised",
                mm(d),
                short(f_ref)
            ));
        }
        rel.series
            .push(Series::points(label, k, rx, ry).with_errors(re));
        if !clogged_fs.is_empty() {
            any_clogged = true;
            abs.series
                .push(Series::axis_marks(None, k, clogged_fs.clone(), k));
            rel.series.push(Series::axis_marks(None, k, clogged_fs, k));
        }
    }
    if any_clogged {
        rel.series
            .push(Series::axis_marks(Some("clogged".into()), 7, Vec::new(), 0));
    }
    abs.title = Some("(a) ⟨p^k⟩ in the cylinder r ≤ R, |z| ≤ R/2".into());
    abs.legend = Legend::Hidden; // the colours are (b)'s legend
    rel.title = Some(if one_hz {
        "(b) normalised by f = 1 Hz".into()
    } else {
        format!(
            "(b) normalised by the lowest f present, {} Hz (no 1 Hz job)",
            short(f_ref)
        )
    });
    let fig = Figure {
        title: Some(format!(
            "fig11: mean kinetic pressure at the orifice vs f, 95 % CI (flowing samples){}",
            super::fields::running_on_suffix(&jobs)
        )),
        panels: vec![abs, rel],
        columns: 2,
        panel_size: (760, 520),
    };
    let files = write_all(&fig, &csv, out, "fig11")?;
    Ok(Drawn {
        text: csv.to_text(),
        files,
    })
}

/// One (D, f) with a value: (f, ⟨p^k⟩ over its replicas, its 95 % CI, replicas, samples,
/// clogged runs).
type PkPoint = (f64, f64, Option<f64>, usize, usize, usize);

/// An orifice's frequencies: those with a value, those whose runs all clogged (with how many
/// runs), and whether a job had no grid point in the orifice cylinder.
struct OrificePoints {
    pts: Vec<PkPoint>,
    clogged: Vec<(f64, usize)>,
    no_grid: bool,
}

/// The ⟨p^k⟩ of orifice `d` at each of `fs`, its replicas combined (their mean, the CI of their
/// spread when there are several, else the one job's own: `pooled::orifice_pressure`).
fn orifice_points(
    conn: &Connection,
    jobs: &[FieldJob],
    d: f64,
    fs: &[f64],
) -> Result<OrificePoints> {
    let mut out = OrificePoints {
        pts: Vec::new(),
        clogged: Vec::new(),
        no_grid: false,
    };
    for &f in fs {
        let of_point: Vec<PkJob> = jobs
            .iter()
            .filter(|j| same_value(j.d_m, d) && same_value(j.f_hz, f))
            .map(FieldJob::pk_job)
            .collect();
        let refs: Vec<&PkJob> = of_point.iter().collect();
        let (point, clogged_runs, no_grid) = point_pk(conn, &refs)?;
        out.no_grid |= no_grid;
        match point {
            Some(p) => out
                .pts
                .push((f, p.mean, p.ci95, p.jobs, p.samples, clogged_runs)),
            None if clogged_runs > 0 => out.clogged.push((f, clogged_runs)),
            None => {}
        }
    }
    Ok(out)
}

/// `p` over the reference (the value at `f_ref` and its CI) and the ratio's CI: relative CIs
/// in quadrature, the reference point itself 1 by construction; None without a positive
/// reference.
fn ratio_to(
    p: &PkPoint,
    reference: Option<(f64, Option<f64>)>,
    f_ref: f64,
) -> (Option<f64>, Option<f64>) {
    match reference {
        Some((r, rci)) if r > 0.0 => {
            let ratio = p.1 / r;
            let err = if same_value(p.0, f_ref) {
                Some(0.0)
            } else {
                match (p.2, rci) {
                    (Some(e), Some(er)) => {
                        Some(ratio * ((e / p.1).powi(2) + (er / r).powi(2)).sqrt())
                    }
                    _ => None,
                }
            };
            (Some(ratio), err)
        }
        _ => (None, None),
    }
}
