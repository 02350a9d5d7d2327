//! Fig. 2 of the chute paper: MSD_z(τ) per block of the two showcase cases, with the ballistic
//! and diffusive power laws.

use std::fmt::Write as _;

use anyhow::Result;
use rusqlite::Connection;

use super::common::{
    caption, case_name, color, empty_panel, preface, showcase_jobs, showcase_note, shown_indices,
    GREY,
};
use crate::pooled::chute::{combine_point, replicas_of};
use crate::pooled::chute_jobs::{block_curves, blocks, drawable_chute_jobs, CurveTable};
use crate::report::campaign::CampaignRef;
use crate::report::drawn::{write_all, Drawn, Output};
use crate::report::plot::{Axis, Figure, Panel, Series};
use crate::report::table::{csv_num, fixed, sci, short, Table};

/// Fig. 2: MSD_z(τ)/L² per block, log-log, one panel per showcase job, with grey power laws of
/// slope 2 (ballistic) and 1 (diffusive). Curves are not shifted in y (the paper shifts them).
pub(crate) fn fig2(conn: &Connection, campaign: &CampaignRef, out_dir: &Output) -> Result<Drawn> {
    let jobs = drawable_chute_jobs(conn, campaign.id, out_dir.include_unsteady)?;
    let shown = showcase_jobs(&jobs);
    let mut text = preface(conn, campaign, &jobs)?;
    text.push_str(&showcase_note(&shown, &jobs));
    text.push_str(
        "MSD_z(tau) per block from chute_msd, up to 8 blocks per panel spread over the bed; \
         D and its fit R from chute_blocks (fit lag range per job below); D_point: D of the \
         block pooled over the steady replicas of the job's point, with its 95 % CI\n",
    );
    let mut table = Table::new(&[
        "xi",
        "alpha_deg",
        "block",
        "z/L",
        "lags",
        "tau_max_s",
        "MSD_end_L2",
        "D_L2/s",
        "fit_R",
        "D_point_L2/s",
        "D_point_ci95_L2/s",
        "replicas",
        "drawn",
    ]);
    let mut csv = Table::new(&[
        "label",
        "xi",
        "alpha_deg",
        "block",
        "z_over_L",
        "lag_s",
        "msd_over_L2",
    ]);
    let mut panels = Vec::new();
    for job in &shown {
        let l = job.total_length_m;
        let rows = blocks(conn, job.job_id)?;
        // D of the block over the steady replicas of the job's point, with its 95 % CI.
        let point = combine_point(conn, &replicas_of(&jobs, job))?;
        let curves = block_curves(conn, job.job_id, CurveTable::Msd)?;
        let picked = shown_indices(curves.len());
        let mut panel = Panel::new(Axis::log("τ (s)"), Axis::log("MSD_z / L²"));
        panel.title = Some(case_name(job));
        let (mut first, mut last) = (Vec::new(), Vec::new());
        for (i, c) in curves.iter().enumerate() {
            let row = rows.iter().find(|r| r.block == c.block);
            let pooled = point
                .blocks
                .iter()
                .find(|b| b.block == c.block)
                .and_then(|b| b.diffusion);
            let z_l = row.map(|r| r.z_m / l);
            let end = c.points.last().copied();
            let drawn = picked.contains(&i);
            table.push(vec![
                short(job.aspect_ratio),
                short(job.inclination_deg),
                c.block.to_string(),
                fixed(z_l, 2),
                c.points.len().to_string(),
                fixed(end.map(|p| p.0), 2),
                sci(end.map(|p| p.1 / (l * l)), 3),
                sci(
                    row.and_then(|r| r.diffusion_m2_per_s).map(|d| d / (l * l)),
                    3,
                ),
                fixed(row.and_then(|r| r.msd_fit_r), 4),
                sci(pooled.map(|p| p.mean / (l * l)), 3),
                sci(
                    pooled.map(|p| p.ci95 / (l * l)).filter(|c| c.is_finite()),
                    2,
                ),
                pooled.map_or(0, |p| p.replicas).to_string(),
                if drawn { "yes" } else { "no" }.into(),
            ]);
            if !drawn {
                continue;
            }
            let pts: Vec<(f64, f64)> = c
                .points
                .iter()
                .map(|&(t, m)| (t, m / (l * l)))
                .filter(|&(t, m)| t > 0.0 && m > 0.0)
                .collect();
            for &(t, m) in &pts {
                csv.push(vec![
                    job.label.clone(),
                    csv_num(Some(job.aspect_ratio)),
                    csv_num(Some(job.inclination_deg)),
                    c.block.to_string(),
                    csv_num(z_l),
                    csv_num(Some(t)),
                    csv_num(Some(m)),
                ]);
            }
            first.extend(pts.first().copied());
            last.extend(pts.last().copied());
            let label = match z_l {
                Some(z) => format!("z = {} L", short(z)),
                None => format!("block {}", c.block),
            };
            let (t, m) = pts.into_iter().unzip();
            let k = panel.series.len();
            panel.series.push(Series::line(Some(label), color(k), t, m));
        }
        panel.series.extend(power_laws(&first, &last));
        if panel.series.is_empty() {
            panel.title = Some(format!("{}: no MSD rows", case_name(job)));
        }
        let _ = writeln!(
            text,
            "  {}: D fitted on lags {} s to {} s",
            case_name(job),
            short(job.msd_fit_lags_s.0),
            short(job.msd_fit_lags_s.1)
        );
        panels.push(panel);
    }
    if panels.is_empty() {
        panels.push(empty_panel(
            Axis::log("τ (s)"),
            Axis::log("MSD_z / L²"),
            "no done job with a chute summary",
        ));
    }
    let fig = Figure {
        title: Some(caption(
            conn,
            campaign,
            &jobs,
            format!(
                "Fig. 2: MSD_z(τ) per block of height L, campaign {}",
                campaign.name
            ),
        )?),
        columns: panels.len().min(2),
        panels,
        panel_size: (800, 640),
    };
    text.push_str(&table.to_text());
    Ok(Drawn {
        text,
        files: write_all(&fig, &csv, out_dir, "chute_fig2")?,
    })
}

/// Grey reference lines ∝ τ² over the first half (in log τ) of the curves and ∝ τ over the
/// second half, anchored at a third of the lowest drawn curve's first and last points so that
/// they run just below the data.
fn power_laws(first: &[(f64, f64)], last: &[(f64, f64)]) -> Vec<Series> {
    let lowest = |v: &[(f64, f64)]| v.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
    if first.is_empty() || last.is_empty() {
        return Vec::new();
    }
    let t0 = first.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
    let t1 = last.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max);
    if !(t1 > t0) {
        return Vec::new();
    }
    let tm = (t0 * t1).sqrt();
    let (m0, m1) = (lowest(first) / 3.0, lowest(last) / 3.0);
    let ballistic = Series::line(
        Some("∝ τ² (ballistic)".into()),
        GREY,
        vec![t0, tm],
        vec![m0, m0 * (tm / t0).powi(2)],
    );
    let diffusive = Series::line(
        Some("∝ τ (diffusive)".into()),
        GREY,
        vec![tm, t1],
        vec![m1 * tm / t1, m1],
    );
    vec![ballistic, diffusive]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn power_laws_have_slopes_two_and_one() {
        let s = power_laws(&[(0.01, 1e-4)], &[(100.0, 10.0)]);
        let slope = |s: &Series| (s.y[1] / s.y[0]).ln() / (s.x[1] / s.x[0]).ln();
        assert!((slope(&s[0]) - 2.0).abs() < 1e-12);
        assert!((slope(&s[1]) - 1.0).abs() < 1e-12);
        assert!((s[1].y[1] - 10.0 / 3.0).abs() < 1e-12);
        assert!(power_laws(&[], &[(1.0, 1.0)]).is_empty());
    }
}
