//! Figures 2–7 of the chute paper (Soft Matter 2022, spherocylinders on an incline) redrawn from
//! a campaign's rows: MSD_z(τ) per block (Fig. 2, here), the D and γ̇ profiles (Figs. 3 and 4,
//! `profiles`), v_z PDFs and skewness (Fig. 5) and velocity correlations (Fig. 7,
//! `velocity`), and the scaling D ~ γ̇ d_⊥² (Fig. 6, `scaling`). Every number comes
//! from the chute tables of the campaign's done jobs. Lengths are in units of the particle length
//! L = chute_summary.total_length_m of each job, so D is in L²/s, as the paper plots.
//!
//! Figs. 2, 5 and 7 show the paper's two showcase cases: the done job with ξ closest to 1.3 (then
//! α closest to 27°) and the one with ξ closest to 2.5 (then α closest to 30°); their curves are
//! that one job's, the text says how many replicas its point has. Figs. 3, 4, 6 and Fig. 5's
//! skewness combine the steady replicas of a point (`replicas`): D pooled with its 95 % CI, the
//! other block values their mean.

mod profiles;
#[cfg(test)]
mod replica_tests;
mod scaling;
mod velocity;

use std::fmt::Write as _;

use anyhow::Result;
use rusqlite::Connection;

use super::campaign::CampaignRef;
use super::drawn::{write_all, Drawn, Output};
use super::plot::{Axis, Figure, Panel, Series};
use super::table::{csv_num, fixed, sci, short, Table};
use crate::observe::chute::FlowState;
use crate::pooled::chute::{combine_point, replicas_of};
use crate::pooled::chute_jobs::{
    block_curves, blocks, closest_job, done_chute_jobs, done_without_summary, left_out_chute_jobs,
    ChuteJob, CurveTable,
};
use crate::pooled::silo::spread;

pub(crate) use crate::report::chute::profiles::{fig3, fig4};
pub(crate) use crate::report::chute::scaling::fig6;
pub(crate) use crate::report::chute::velocity::{fig5, fig7};

/// The paper's showcase cases (ξ, α in degrees): Figs. 2, 5 and 7 (a) and (b).
pub(crate) const SHOWCASES: [(f64, f64); 2] = [(1.3, 27.0), (2.5, 30.0)];
/// At most this many block curves per panel, spread over the bed, so the legend stays readable.
pub(crate) const MAX_BLOCK_CURVES: usize = 8;
/// Palette index of the grey used for references (Gaussian, power laws, fits).
pub(crate) const GREY: usize = 7;

/// Palette index of the i-th data series, skipping the reference grey.
pub(crate) fn color(i: usize) -> usize {
    if i % 9 >= GREY {
        i % 9 + 1
    } else {
        i % 9
    }
}

/// "ξ = 1.3, α = 27°"
pub(crate) fn case_name(job: &ChuteJob) -> String {
    format!(
        "ξ = {}, α = {}°{}",
        short(job.aspect_ratio),
        short(job.inclination_deg),
        if job.steady { "" } else { " (NOT steady)" }
    )
}

/// The showcase jobs present, without repeats (one when both cases pick the same job).
pub(crate) fn showcase_jobs(jobs: &[ChuteJob]) -> Vec<&ChuteJob> {
    let mut out: Vec<&ChuteJob> = Vec::new();
    for (xi, alpha) in SHOWCASES {
        if let Some(j) = closest_job(jobs, xi, alpha) {
            if out.iter().all(|o| o.job_id != j.job_id) {
                out.push(j);
            }
        }
    }
    out
}

/// Text naming the showcase jobs that a figure draws and, for a point with replicas among
/// `jobs`, that the curves are this one replica's.
pub(crate) fn showcase_note(shown: &[&ChuteJob], jobs: &[ChuteJob]) -> String {
    let mut text = String::from(
        "showcase jobs (done job with xi closest to 1.3 then alpha closest to 27 deg; \
         xi closest to 2.5 then alpha closest to 30 deg):",
    );
    if shown.is_empty() {
        text.push_str(" none\n");
    }
    for j in shown {
        let _ = write!(
            text,
            "\n  xi = {}, alpha = {} deg: job '{}'",
            short(j.aspect_ratio),
            short(j.inclination_deg),
            j.label
        );
        let n = replicas_of(jobs, j).len();
        if n > 1 {
            let _ = write!(
                text,
                " (1 of its point's {n} replicas: its curves; block values over replicas in \
                 fig3/fig4/fig6 and the skewness of fig5)"
            );
        }
    }
    if !shown.is_empty() {
        text.push('\n');
    }
    text
}

/// Notes every chute figure starts with: done jobs without a summary (not drawn) and jobs whose
/// flow was not steady (left out: drifted while measured, not steady by steady_max_time_s, or
/// not flowing).
pub(crate) fn preface(
    conn: &Connection,
    campaign: &CampaignRef,
    jobs: &[ChuteJob],
) -> Result<String> {
    let unsteady = jobs.iter().filter(|j| !j.steady).count();
    let mut text = format!(
        "{} done job(s) drawn{}\n",
        jobs.len(),
        if unsteady > 0 {
            format!(", {unsteady} of them NOT steady (--include-unsteady), marked")
        } else {
            String::new()
        }
    );
    let orphans = done_without_summary(conn, campaign.id)?;
    if !orphans.is_empty() {
        let _ = writeln!(
            text,
            "{} done job(s) without a chute_summary row, not drawn: {}",
            orphans.len(),
            orphans.join("; ")
        );
    }
    let left = left_out_chute_jobs(conn, campaign.id)?;
    if !left.is_empty() {
        let list: Vec<String> = left
            .iter()
            .map(|j| {
                let words = FlowState::parse(&j.state).map_or(j.state.as_str(), |f| f.words());
                let measured = if j.measured { "" } else { ", nothing measured" };
                format!("{} ({words}{measured})", j.label)
            })
            .collect();
        let _ = writeln!(
            text,
            "{} done job(s) not steady{}: {}",
            left.len(),
            if unsteady > 0 {
                ", those measured drawn and marked"
            } else {
                ", left out of the figure"
            },
            list.join("; ")
        );
    }
    Ok(text)
}

/// The figure's caption with, when jobs were left out as not steady, how many.
pub(crate) fn caption(conn: &Connection, campaign: &CampaignRef, title: String) -> Result<String> {
    let left = left_out_chute_jobs(conn, campaign.id)?;
    if left.is_empty() {
        return Ok(title);
    }
    let count = |s: FlowState| left.iter().filter(|j| j.state == s.as_str()).count();
    let parts: Vec<String> = [
        FlowState::Drifted,
        FlowState::NotSteady,
        FlowState::NotFlowing,
    ]
    .into_iter()
    .filter(|&s| count(s) > 0)
    .map(|s| format!("{} {}", count(s), s.words()))
    .collect();
    Ok(format!("{title} — left out: {}", parts.join(", ")))
}

/// A panel that only says why it is empty.
pub(crate) fn empty_panel(x: Axis, y: Axis, why: &str) -> Panel {
    let mut p = Panel::new(x, y);
    p.title = Some(why.to_string());
    p
}

/// Indices of up to [`MAX_BLOCK_CURVES`] of `n` curves, spread evenly, both ends kept.
pub(crate) fn shown_indices(n: usize) -> Vec<usize> {
    spread(&(0..n).collect::<Vec<usize>>(), MAX_BLOCK_CURVES)
}

/// Fig. 2: MSD_z(τ)/L² per block, log-log, one panel per showcase job, with grey power laws of
/// slope 2 (ballistic) and 1 (diffusive). Curves are not shifted in y (the paper shifts them).
pub(crate) fn fig2(conn: &Connection, campaign: &CampaignRef, out_dir: &Output) -> Result<Drawn> {
    let jobs = done_chute_jobs(conn, campaign.id, out_dir.include_unsteady)?;
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
    fn colors_skip_the_reference_grey() {
        let c: Vec<usize> = (0..10).map(color).collect();
        assert_eq!(c, vec![0, 1, 2, 3, 4, 5, 6, 8, 9, 0]);
    }

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
