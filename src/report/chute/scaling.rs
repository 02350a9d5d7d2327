//! Fig. 6 of the chute paper, the scaling D ~ γ̇ d_⊥²: (a) D/γ̇ vs d_⊥² for every block of the
//! central part of the bed of every done job, with the mean ± standard deviation per ξ and the
//! least-squares line through all points; (b) D vs γ̇ d_⊥² with its regression, slope and R.
//! Lengths are in units of each job's L; fits use [`crate::observe::fits::linear_fit`].

use std::fmt::Write as _;

use anyhow::Result;
use rusqlite::Connection;

use crate::observe::fits::{linear_fit, LinearFit};
use crate::pooled::chute::CENTRAL_BED;
use crate::pooled::chute::{combine_point, group_points, replicas_caption};
use crate::pooled::chute_jobs::{drawable_chute_jobs, ChuteJob};
use crate::pooled::silo::{distinct, same_value};
use crate::report::campaign::CampaignRef;
use crate::report::chute::common::{caption, color, preface, GREY};
use crate::report::drawn::{write_all, Drawn, Output};
use crate::report::plot::{Axis, Figure, Legend, Panel, Series};
use crate::report::table::{csv_num, fixed, sci, short, Table};

/// One block of the central bed of one point (its replicas combined), lengths in units of L.
struct ScalingPoint<'a> {
    /// The point's first pooled replica (ξ, α).
    job: &'a ChuteJob,
    /// The point's label (without `replica=K`).
    label: String,
    block: i64,
    z_over_l: f64,
    z_over_h: f64,
    /// (d_⊥/L)², d_⊥ the replicas' mean.
    d_perp_sq: f64,
    /// D/L², 1/s, pooled over the replicas.
    d: f64,
    /// Half-width of D/L²'s 95 % CI; None when unknown.
    d_ci: Option<f64>,
    /// γ̇, 1/s, mean over the replicas.
    shear: f64,
    /// Replicas with a D in this block.
    replicas: usize,
}

/// Mean and sample standard deviation (None for fewer than 2 values).
fn mean_std(v: &[f64]) -> (f64, Option<f64>) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let std = (v.len() > 1).then(|| {
        let ss: f64 = v.iter().map(|x| (x - mean).powi(2)).sum();
        (ss / (n - 1.0)).sqrt()
    });
    (mean, std)
}

/// The fitted straight line over [x0, x1], or nothing.
fn fit_line(fit: Option<&LinearFit>, x: &[f64], label: String, color: usize) -> Option<Series> {
    let fit = fit?;
    let x0 = x.iter().copied().fold(f64::INFINITY, f64::min);
    let x1 = x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let y = |x: f64| fit.slope * x + fit.intercept;
    Some(Series::line(
        Some(label),
        color,
        vec![x0, x1],
        vec![y(x0), y(x1)],
    ))
}

/// Fig. 6: (a) D/γ̇ vs d_⊥², (b) D vs γ̇ d_⊥², central blocks of all drawn jobs.
pub(crate) fn fig6(conn: &Connection, campaign: &CampaignRef, out_dir: &Output) -> Result<Drawn> {
    let jobs = drawable_chute_jobs(conn, campaign.id, out_dir.include_unsteady)?;
    let mut text = preface(conn, campaign, &jobs)?;
    let (lo, hi) = CENTRAL_BED;
    let groups = group_points(&jobs);
    let (points, left_out) = central_points(conn, &groups)?;
    let max_replicas = points.iter().map(|p| p.replicas).max().unwrap_or(0);
    let h_over_l = jobs.iter().map(|j| j.bed_height_m / j.total_length_m);
    let (h_min, h_max) = h_over_l.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    let _ = writeln!(
        text,
        "central blocks only: {lo} H < z < {hi} H, H = chute_summary.bed_height_m of each job \
         (the paper's 6 L < z < 14 L when H = 20 L; here H/L = {} to {}); D and shear rate from \
         chute_blocks, replicas of a point combined (D pooled with its 95 % CI, shear rate and \
         d_perp their mean: one value per point and block); lengths in L = total_length_m\n{} \
         block(s) used, {left_out} central block(s) left out (no D or shear rate <= 0)",
        fixed(Some(h_min), 2),
        fixed(Some(h_max), 2),
        points.len()
    );

    let x_a: Vec<f64> = points.iter().map(|p| p.d_perp_sq).collect();
    let y_a: Vec<f64> = points.iter().map(|p| p.d / p.shear).collect();
    let x_b: Vec<f64> = points.iter().map(|p| p.shear * p.d_perp_sq).collect();
    let y_b: Vec<f64> = points.iter().map(|p| p.d).collect();
    let e_b: Vec<Option<f64>> = points.iter().map(|p| p.d_ci).collect();
    let fit_a = linear_fit(&x_a, &y_a);
    let fit_b = linear_fit(&x_b, &y_b);

    let mut a = Panel::new(Axis::linear("d_⊥² / L²"), Axis::linear("D / γ̇ (L²)"));
    a.title = Some("(a) D/γ̇ vs d_⊥²".into());
    let mut b = Panel::new(Axis::linear("γ̇ d_⊥² (L²/s)"), Axis::linear("D (L²/s)"));
    b.title = Some("(b) D vs γ̇ d_⊥²".into());
    b.legend = Legend::Outside;
    let blocks_label = format!("blocks, {lo} H < z < {hi} H");
    a.series.push(Series::points(
        Some(blocks_label),
        GREY,
        x_a.clone(),
        y_a.clone(),
    ));

    let mut per_xi = Table::new(&[
        "xi",
        "d_perp/L",
        "d_perp^2_L2",
        "jobs",
        "points",
        "blocks",
        "mean_D/shear_L2",
        "std_L2",
    ]);
    let (mut mx, mut my, mut me) = (Vec::new(), Vec::new(), Vec::new());
    for (i, xi) in distinct(jobs.iter().map(|j| j.aspect_ratio))
        .into_iter()
        .enumerate()
    {
        let idx: Vec<usize> = (0..points.len())
            .filter(|&k| same_value(points[k].job.aspect_ratio, xi))
            .collect();
        let n_jobs = jobs
            .iter()
            .filter(|j| same_value(j.aspect_ratio, xi))
            .count();
        let stats = (!idx.is_empty()).then(|| {
            let (x, _) = mean_std(&idx.iter().map(|&k| x_a[k]).collect::<Vec<_>>());
            let (y, s) = mean_std(&idx.iter().map(|&k| y_a[k]).collect::<Vec<_>>());
            (x, y, s)
        });
        per_xi.push(vec![
            short(xi),
            fixed(stats.map(|s| s.0.sqrt()), 4),
            fixed(stats.map(|s| s.0), 4),
            n_jobs.to_string(),
            groups
                .iter()
                .filter(|g| same_value(g[0].aspect_ratio, xi))
                .count()
                .to_string(),
            idx.len().to_string(),
            sci(stats.map(|s| s.1), 4),
            sci(stats.and_then(|s| s.2), 2),
        ]);
        if let Some((x, y, s)) = stats {
            mx.push(x);
            my.push(y);
            me.push(s);
        }
        let (xb, yb) = idx.iter().map(|&k| (x_b[k], y_b[k])).unzip();
        let eb = idx.iter().map(|&k| e_b[k]).collect();
        let label = format!("ξ = {}", short(xi));
        b.series
            .push(Series::points(Some(label), color(i), xb, yb).with_errors(eb));
    }
    let mean_label = "mean ± std per ξ".to_string();
    a.series
        .push(Series::points(Some(mean_label), 3, mx, my).with_errors(me));
    let label_a = |f: &LinearFit| format!("fit: slope {:.4}", f.slope);
    let label_b = |f: &LinearFit| format!("fit: slope {:.4}, R = {:.3}", f.slope, f.r);
    a.series.extend(fit_line(
        fit_a.as_ref(),
        &x_a,
        fit_a.as_ref().map(label_a).unwrap_or_default(),
        0,
    ));
    b.series.extend(fit_line(
        fit_b.as_ref(),
        &x_b,
        fit_b.as_ref().map(label_b).unwrap_or_default(),
        GREY,
    ));

    let fits = fits_table(&fit_a, &fit_b);
    let csv = points_csv(&points, &y_a, &x_b);
    let fig = Figure {
        title: Some(caption(
            conn,
            campaign,
            &jobs,
            format!(
                "Fig. 6: D ~ γ̇ d_⊥², central bed, campaign {}{}",
                campaign.name,
                replicas_caption(max_replicas)
            ),
        )?),
        panels: vec![a, b],
        columns: 2,
        panel_size: (800, 640),
    };
    text.push_str(&per_xi.to_text());
    text.push_str("\nleast-squares lines y = slope x + intercept (no fit with < 2 distinct x)\n");
    text.push_str(&fits.to_text());
    Ok(Drawn {
        text,
        files: write_all(&fig, &csv, out_dir, "chute_fig6")?,
    })
}

/// The central blocks (0.3 H < z < 0.7 H) of every point with a D and a positive shear rate,
/// lengths in L; and how many central blocks lacked them.
fn central_points<'a>(
    conn: &Connection,
    groups: &[Vec<&'a ChuteJob>],
) -> Result<(Vec<ScalingPoint<'a>>, usize)> {
    let (lo, hi) = CENTRAL_BED;
    let mut points = Vec::new();
    let mut left_out = 0usize;
    for group in groups {
        let point = combine_point(conn, group)?;
        let (l, h) = (point.total_length_m, point.bed_height_m);
        let label = point.label();
        for b in &point.blocks {
            if !(b.z_m > lo * h && b.z_m < hi * h) {
                continue;
            }
            let shear = b.shear_rate.mean;
            match b.diffusion {
                Some(d) if shear > 0.0 && d.mean.is_finite() => points.push(ScalingPoint {
                    job: point.pooled[0],
                    label: label.clone(),
                    block: b.block,
                    z_over_l: b.z_m / l,
                    z_over_h: b.z_m / h,
                    d_perp_sq: (point.d_perp_m / l).powi(2),
                    d: d.mean / (l * l),
                    d_ci: Some(d.ci95 / (l * l)).filter(|c| c.is_finite()),
                    shear,
                    replicas: d.replicas,
                }),
                _ => left_out += 1,
            }
        }
    }
    Ok((points, left_out))
}

/// The two panels' least-squares lines.
fn fits_table(fit_a: &Option<LinearFit>, fit_b: &Option<LinearFit>) -> Table {
    let mut fits = Table::new(&["panel", "y", "x", "slope", "intercept", "R", "n"]);
    for (name, y, x, fit) in [
        ("a", "D/shear_L2", "d_perp^2_L2", &fit_a),
        ("b", "D_L2/s", "shear*d_perp^2_L2/s", &fit_b),
    ] {
        fits.push(vec![
            name.into(),
            y.into(),
            x.into(),
            sci(fit.map(|f| f.slope), 10),
            sci(fit.map(|f| f.intercept), 3),
            fixed(fit.map(|f| f.r), 6),
            fit.map_or(0, |f| f.n).to_string(),
        ]);
    }
    fits
}

/// One CSV row per central block: (a)'s y and (b)'s x as drawn.
fn points_csv(points: &[ScalingPoint], y_a: &[f64], x_b: &[f64]) -> Table {
    let mut csv = Table::new(&[
        "label",
        "xi",
        "alpha_deg",
        "block",
        "z_over_L",
        "z_over_H",
        "d_perp_sq_over_L2",
        "D_L2_per_s",
        "shear_rate_per_s",
        "D_over_shear_L2",
        "shear_d_perp_sq_L2_per_s",
        "D_ci95_L2_per_s",
        "replicas",
    ]);
    for (k, p) in points.iter().enumerate() {
        csv.push(vec![
            p.label.clone(),
            csv_num(Some(p.job.aspect_ratio)),
            csv_num(Some(p.job.inclination_deg)),
            p.block.to_string(),
            csv_num(Some(p.z_over_l)),
            csv_num(Some(p.z_over_h)),
            csv_num(Some(p.d_perp_sq)),
            csv_num(Some(p.d)),
            csv_num(Some(p.shear)),
            csv_num(Some(y_a[k])),
            csv_num(Some(x_b[k])),
            csv_num(p.d_ci),
            p.replicas.to_string(),
        ]);
    }
    csv
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_std_is_the_sample_std() {
        let (m, s) = mean_std(&[1.0, 2.0, 3.0]);
        assert_eq!(m, 2.0);
        assert_eq!(s, Some(1.0));
        assert_eq!(mean_std(&[4.0]), (4.0, None));
    }
}
