//! Figs. 5 and 7 of the chute paper, for the two showcase jobs: the standardised v_z PDF per
//! block against the standard Gaussian, with the skewness vs z/L (Fig. 5), and the spatial
//! correlation C(r)/C(0) of v_z per block, linear and log y, with a line of slope −1/l from the
//! fitted correlation length l (Fig. 7).

use std::f64::consts::PI;
use std::fmt::Write as _;

use anyhow::Result;
use rusqlite::Connection;

use crate::pooled::chute::{combine_point, replicas_caption, replicas_of};
use crate::pooled::chute_jobs::{
    block_curves, blocks, drawable_chute_jobs, BlockRow, ChuteJob, CurveTable,
};
use crate::pooled::silo::{replica_label, REPLICA_NOTE};
use crate::report::campaign::CampaignRef;
use crate::report::chute::common::{
    caption, case_name, color, empty_panel, preface, showcase_jobs, showcase_note, shown_indices,
    GREY,
};
use crate::report::drawn::{write_all, Drawn, Output};
use crate::report::plot::{Axis, Figure, Legend, Panel, Series};
use crate::report::table::{csv_num, fixed, sci, short, Table};

/// "z = 2.5 L", or the block index when the block has no chute_blocks row.
fn block_label(row: Option<&BlockRow>, block: i64, l: f64) -> String {
    match row {
        Some(r) => format!("z = {} L", short(r.z_m / l)),
        None => format!("block {block}"),
    }
}

/// ∫ density dx by the trapezoid rule (1 for a PDF normalised to unit area on its bins).
fn area(points: &[(f64, f64)]) -> f64 {
    points
        .windows(2)
        .map(|w| 0.5 * (w[0].1 + w[1].1) * (w[1].0 - w[0].0))
        .sum()
}

/// Fig. 5: (a), (b) standardised v_z PDFs per block, log y, with the standard Gaussian;
/// (c) the skewness of v_z vs z/L for both jobs.
pub(crate) fn fig5(conn: &Connection, campaign: &CampaignRef, out_dir: &Output) -> Result<Drawn> {
    let jobs = drawable_chute_jobs(conn, campaign.id, out_dir.include_unsteady)?;
    let shown = showcase_jobs(&jobs);
    let mut text = preface(conn, campaign, &jobs)?;
    text.push_str(&showcase_note(&shown, &jobs));
    text.push_str(
        "PDF of (v_z - <v_z>)/std per block from chute_vz_pdf (up to 8 blocks per panel), grey: \
         the standard Gaussian; std from chute_blocks of the showcase job; skewness vs height: \
         the mean over the steady replicas of its point (95 % Student-t bars from 2 replicas \
         on, n=K beside a point); pdf_area = trapezoid integral over the bins\n",
    );
    let mut table = Table::new(&[
        "xi",
        "alpha_deg",
        "block",
        "z/L",
        "bins",
        "pdf_area",
        "vz_std_L/s",
        "skewness",
        "drawn",
    ]);
    let mut csv = Table::new(&[
        "label",
        "xi",
        "alpha_deg",
        "block",
        "z_over_L",
        "vz_standardised",
        "pdf_density",
        "vz_skewness",
    ]);
    let mut panels = Vec::new();
    let mut skew = Panel::new(Axis::linear("z / L"), Axis::linear("skewness of v_z"));
    skew.title = Some("skewness vs height".into());
    skew.legend = Legend::Outside;
    let mut max_replicas = 0;
    for (k, job) in shown.iter().enumerate() {
        panels.push(pdf_panel(conn, job, &mut table, &mut csv)?);
        let replicas = skewness_series(conn, &jobs, job, color(k), &mut skew, &mut csv)?;
        max_replicas = max_replicas.max(replicas);
    }
    if let Some(z) = skew
        .series
        .iter()
        .flat_map(|s| s.x.iter().copied())
        .reduce(f64::max)
    {
        let z0 = skew
            .series
            .iter()
            .flat_map(|s| s.x.iter().copied())
            .fold(z, f64::min);
        skew.series
            .push(Series::line(None, GREY, vec![z0, z], vec![0.0, 0.0]));
    }
    if panels.is_empty() {
        panels.push(empty_panel(
            Axis::linear("(v_z − ⟨v_z⟩) / σ"),
            Axis::log("PDF"),
            "no done job with a chute summary",
        ));
    }
    if max_replicas > 1 {
        skew.notes.push(REPLICA_NOTE.into());
    }
    panels.push(skew);
    let fig = Figure {
        title: Some(caption(
            conn,
            campaign,
            &jobs,
            format!(
                "Fig. 5: standardised v_z PDFs and their skewness, campaign {}{}",
                campaign.name,
                replicas_caption(max_replicas)
            ),
        )?),
        columns: panels.len(),
        panels,
        panel_size: (640, 580),
    };
    text.push_str(&table.to_text());
    Ok(Drawn {
        text,
        files: write_all(&fig, &csv, out_dir, "chute_fig5")?,
    })
}

/// One showcase job's panel: its standardised v_z PDFs (up to 8 blocks) and the Gaussian; every
/// block listed in `table`, the drawn ones' bins in `csv`.
fn pdf_panel(
    conn: &Connection,
    job: &ChuteJob,
    table: &mut Table,
    csv: &mut Table,
) -> Result<Panel> {
    let l = job.total_length_m;
    let rows = blocks(conn, job.job_id)?;
    let curves = block_curves(conn, job.job_id, CurveTable::VzPdf)?;
    let picked = shown_indices(curves.len());
    let mut panel = Panel::new(Axis::linear("(v_z − ⟨v_z⟩) / σ"), Axis::log("PDF"));
    panel.title = Some(case_name(job));
    panel.legend = Legend::Outside;
    let mut x_extent: f64 = 0.0;
    for (i, c) in curves.iter().enumerate() {
        let row = rows.iter().find(|r| r.block == c.block);
        let drawn = picked.contains(&i);
        table.push(vec![
            short(job.aspect_ratio),
            short(job.inclination_deg),
            c.block.to_string(),
            fixed(row.map(|r| r.z_m / l), 2),
            c.points.len().to_string(),
            fixed(Some(area(&c.points)), 3),
            sci(row.and_then(|r| r.vz_std_m_per_s).map(|s| s / l), 3),
            fixed(row.and_then(|r| r.vz_skewness), 3),
            if drawn { "yes" } else { "no" }.into(),
        ]);
        if !drawn {
            continue;
        }
        for &(x, p) in &c.points {
            csv.push(vec![
                job.label.clone(),
                csv_num(Some(job.aspect_ratio)),
                csv_num(Some(job.inclination_deg)),
                c.block.to_string(),
                csv_num(row.map(|r| r.z_m / l)),
                csv_num(Some(x)),
                csv_num(Some(p)),
                String::new(),
            ]);
            x_extent = x_extent.max(x.abs());
        }
        let (x, p) = c.points.iter().copied().unzip();
        let n = panel.series.len();
        let label = block_label(row, c.block, l);
        panel.series.push(Series::line(Some(label), color(n), x, p));
    }
    if panel.series.is_empty() {
        panel.title = Some(format!("{}: no v_z PDF rows", case_name(job)));
    } else {
        panel.series.push(gaussian(x_extent.max(1.0)));
    }
    Ok(panel)
}

/// The skewness vs height of `job`'s point (its steady replicas), drawn in colour `c` on `skew`
/// and listed in `csv`; returns how many replicas were pooled.
fn skewness_series(
    conn: &Connection,
    jobs: &[ChuteJob],
    job: &ChuteJob,
    c: usize,
    skew: &mut Panel,
    csv: &mut Table,
) -> Result<usize> {
    // The skewness over the replicas of the job's point (its steady ones).
    let point = combine_point(conn, &replicas_of(jobs, job))?;
    let pts: Vec<(f64, f64, Option<f64>, usize)> = point
        .blocks
        .iter()
        .filter_map(|b| {
            let s = b.vz_skewness?;
            Some((b.z_m / point.total_length_m, s.mean, s.ci95, s.replicas))
        })
        .collect();
    for &(z, s, _, _) in &pts {
        csv.push(vec![
            job.label.clone(),
            csv_num(Some(job.aspect_ratio)),
            csv_num(Some(job.inclination_deg)),
            String::new(),
            csv_num(Some(z)),
            String::new(),
            String::new(),
            csv_num(Some(s)),
        ]);
    }
    let z: Vec<f64> = pts.iter().map(|p| p.0).collect();
    let s: Vec<f64> = pts.iter().map(|p| p.1).collect();
    skew.series
        .push(Series::line(None, c, z.clone(), s.clone()));
    skew.series.push(
        Series::points(Some(case_name(job)), c, z, s)
            .with_errors(pts.iter().map(|p| p.2).collect())
            .with_point_labels(pts.iter().map(|p| replica_label(p.3)).collect()),
    );
    Ok(point.pooled.len())
}

/// The standard normal density on [−extent, extent].
fn gaussian(extent: f64) -> Series {
    let x: Vec<f64> = (0..=200)
        .map(|i| -extent + 2.0 * extent * f64::from(i) / 200.0)
        .collect();
    let y = x
        .iter()
        .map(|x| (-0.5 * x * x).exp() / (2.0 * PI).sqrt())
        .collect();
    Series::line(Some("Gaussian".into()), GREY, x, y)
}

/// Fig. 7: C(r)/C(0) vs r/L per block, one row per showcase job: linear y on the left; log y on
/// the right with exp(−(r − r₀)/l), l = chute_blocks.correlation_length_m. C(0) is the value of
/// the smallest-r bin, at r₀ (centre L/8), as the paper's Eq. (3) bins start at r = 0; the line
/// goes through that bin so that its slope −1/l compares with the data's.
pub(crate) fn fig7(conn: &Connection, campaign: &CampaignRef, out_dir: &Output) -> Result<Drawn> {
    let jobs = drawable_chute_jobs(conn, campaign.id, out_dir.include_unsteady)?;
    let shown = showcase_jobs(&jobs);
    let mut text = preface(conn, campaign, &jobs)?;
    text.push_str(&showcase_note(&shown, &jobs));
    text.push_str(
        "C(r) of v_z fluctuations per block from chute_correlation (up to 8 blocks), divided by \
         C(0) = the smallest-r bin (at r0); right: log y (non-positive values not drawn) with \
         exp(-(r - r0)/l), l from chute_blocks.correlation_length_m\n",
    );
    let mut table = Table::new(&[
        "xi",
        "alpha_deg",
        "block",
        "z/L",
        "bins",
        "r0/L",
        "C0_m2/s2",
        "l/L",
        "drawn",
    ]);
    let mut csv = Table::new(&[
        "label",
        "xi",
        "alpha_deg",
        "block",
        "z_over_L",
        "r_over_L",
        "c_m2_per_s2",
        "c_over_c0",
        "correlation_length_over_L",
    ]);
    let y_label = "C(r) / C(0)";
    let mut panels = Vec::new();
    for job in &shown {
        let l = job.total_length_m;
        let rows = blocks(conn, job.job_id)?;
        let curves = block_curves(conn, job.job_id, CurveTable::Correlation)?;
        let picked = shown_indices(curves.len());
        let mut lin = Panel::new(Axis::linear("r / L"), Axis::linear(y_label));
        lin.title = Some(case_name(job));
        lin.legend = Legend::Outside;
        let mut log = Panel::new(Axis::linear("r / L"), Axis::log(y_label));
        log.title = Some(format!(
            "{}, log y; lines: exp(−(r − r₀)/l)",
            case_name(job)
        ));
        log.legend = Legend::Hidden;
        for (i, c) in curves.iter().enumerate() {
            let row = rows.iter().find(|r| r.block == c.block);
            let l_corr = row.and_then(|r| r.correlation_length_m);
            let first = c.points.first().copied();
            let c0 = first.map(|p| p.1).filter(|v| *v > 0.0);
            let drawn = picked.contains(&i) && c0.is_some();
            table.push(vec![
                short(job.aspect_ratio),
                short(job.inclination_deg),
                c.block.to_string(),
                fixed(row.map(|r| r.z_m / l), 2),
                c.points.len().to_string(),
                fixed(first.map(|p| p.0 / l), 3),
                sci(first.map(|p| p.1), 3),
                fixed(l_corr.map(|v| v / l), 3),
                match (picked.contains(&i), c0) {
                    (_, None) => "no (C0 <= 0)".into(),
                    (true, Some(_)) => "yes".into(),
                    (false, Some(_)) => "no".into(),
                },
            ]);
            let Some(c0) = c0.filter(|_| drawn) else {
                continue;
            };
            let pts: Vec<(f64, f64)> = c.points.iter().map(|&(r, v)| (r / l, v / c0)).collect();
            for (&(r, v), &(_, raw)) in pts.iter().zip(&c.points) {
                csv.push(vec![
                    job.label.clone(),
                    csv_num(Some(job.aspect_ratio)),
                    csv_num(Some(job.inclination_deg)),
                    c.block.to_string(),
                    csv_num(row.map(|r| r.z_m / l)),
                    csv_num(Some(r)),
                    csv_num(Some(raw)),
                    csv_num(Some(v)),
                    csv_num(l_corr.map(|v| v / l)),
                ]);
            }
            let k = lin.series.len();
            let label = match l_corr {
                Some(lc) => format!("{}, l = {} L", block_label(row, c.block, l), short(lc / l)),
                None => block_label(row, c.block, l),
            };
            let (r, v): (Vec<f64>, Vec<f64>) = pts.into_iter().unzip();
            lin.series
                .push(Series::line(Some(label), color(k), r.clone(), v.clone()));
            log.series
                .push(Series::points(None, color(k), r.clone(), v));
            if let Some(lc) = l_corr.filter(|v| *v > 0.0) {
                // Through the first bin, where C/C(0) = 1 by construction: the slope is −1/l.
                let r0 = r[0];
                let r_max = r.iter().copied().fold(r0, f64::max);
                let x: Vec<f64> = (0..=50)
                    .map(|j| r0 + (r_max - r0) * f64::from(j) / 50.0)
                    .collect();
                let y = x.iter().map(|x| (-(x - r0) * l / lc).exp()).collect();
                log.series.push(Series::line(None, color(k), x, y));
            }
        }
        if lin.series.is_empty() {
            lin.title = Some(format!("{}: no correlation rows", case_name(job)));
        }
        panels.push(lin);
        panels.push(log);
    }
    if panels.is_empty() {
        panels.push(empty_panel(
            Axis::linear("r / L"),
            Axis::linear(y_label),
            "no done job with a chute summary",
        ));
    }
    let fig = Figure {
        title: Some(caption(
            conn,
            campaign,
            &jobs,
            format!(
                "Fig. 7: spatial correlation of v_z per block, campaign {}",
                campaign.name
            ),
        )?),
        columns: panels.len().min(2),
        panels,
        panel_size: (760, 560),
    };
    let _ = writeln!(text, "{} job(s) drawn", shown.len());
    text.push_str(&table.to_text());
    Ok(Drawn {
        text,
        files: write_all(&fig, &csv, out_dir, "chute_fig7")?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaussian_has_unit_area_and_trapezoid_is_exact_on_lines() {
        let g = gaussian(8.0);
        let pts: Vec<(f64, f64)> = g.x.iter().copied().zip(g.y.iter().copied()).collect();
        assert!((area(&pts) - 1.0).abs() < 1e-6);
        assert!((area(&[(0.0, 0.0), (2.0, 1.0)]) - 1.0).abs() < 1e-15);
    }
}
