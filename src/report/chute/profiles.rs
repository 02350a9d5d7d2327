//! Figs. 3 and 4 of the chute paper: D/D_max (markers) and γ̇/γ̇_max (lines) against z/L for
//! every inclination α of one aspect ratio ξ — Fig. 3 the campaign's ξ closest to 1.3, Fig. 4
//! the one closest to 2.5 (the paper's choices). D comes from chute_blocks; γ̇ from the
//! coarse-grained chute_fields profile for 0 ≤ z ≤ H, or from the block averages when a job has
//! no field rows. D_max and γ̇_max are the maxima over the full blocks (φ at least half the
//! densest block's), γ̇_max of the block averages: the normalisation the claims use. Replicas
//! of one point are combined (`replicas`): D pooled with its 95 % CI, γ̇ their mean.

use std::fmt::Write as _;

use anyhow::Result;
use rusqlite::Connection;

use crate::pooled::chute::{combine_point, group_points, replicas_caption};
use crate::pooled::chute_jobs::{closest, drawable_chute_jobs, ChuteJob};
use crate::pooled::replica_results::full_blocks;
use crate::pooled::silo::{distinct, replica_label, same_value, REPLICA_NOTE};
use crate::report::campaign::CampaignRef;
use crate::report::chute::common::{caption, color, empty_panel, preface};
use crate::report::drawn::{write_all, Drawn, Output};
use crate::report::plot::{Axis, Figure, Legend, Panel, Series};
use crate::report::table::{csv_num, fixed, sci, short, Table};

/// Fig. 3: the profiles at the campaign's ξ closest to 1.3.
pub(crate) fn fig3(conn: &Connection, campaign: &CampaignRef, out_dir: &Output) -> Result<Drawn> {
    profiles(conn, campaign, out_dir, 3, 1.3)
}

/// Fig. 4: the profiles at the campaign's ξ closest to 2.5.
pub(crate) fn fig4(conn: &Connection, campaign: &CampaignRef, out_dir: &Output) -> Result<Drawn> {
    profiles(conn, campaign, out_dir, 4, 2.5)
}

/// One height of a drawn profile: (z/L, value, half-width of its 95 % CI, replicas).
type ProfilePoint = (f64, f64, Option<f64>, usize);

/// The largest finite value of `points` (by y) as (x, y); None when there is none.
fn max_point(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    points
        .iter()
        .copied()
        .filter(|p| p.1.is_finite())
        .max_by(|a, b| a.1.total_cmp(&b.1))
}

/// What the figure gathers over the inclinations: the text, the summary table (one row per α),
/// the CSV (one row per height and quantity), the panel, and the most replicas of a point.
struct Drawing {
    text: String,
    table: Table,
    csv: Table,
    panel: Panel,
    max_replicas: usize,
}

fn profiles(
    conn: &Connection,
    campaign: &CampaignRef,
    out_dir: &Output,
    number: u32,
    target_xi: f64,
) -> Result<Drawn> {
    let jobs = drawable_chute_jobs(conn, campaign.id, out_dir.include_unsteady)?;
    let xis = distinct(jobs.iter().map(|j| j.aspect_ratio));
    let mut d = Drawing {
        text: preface(conn, campaign, &jobs)?,
        table: Table::new(&[
            "alpha_deg",
            "D_max_L2/s",
            "D_max_ci95_L2/s",
            "z(D_max)/L",
            "shear_max_1/s",
            "z(shear_max)/L",
            "blocks_D",
            "shear_from",
            "replicas",
            "point",
        ]),
        csv: Table::new(&[
            "label",
            "xi",
            "alpha_deg",
            "quantity",
            "z_over_L",
            "value",
            "value_over_max",
            "ci95",
            "ci95_over_max",
            "replicas",
        ]),
        panel: Panel::new(x_axis(), y_axis()),
        max_replicas: 0,
    };
    d.panel.legend = Legend::Outside;
    match closest(xis.iter().copied(), target_xi) {
        None => {
            d.text.push_str("no done job with a chute summary\n");
            d.panel = empty_panel(x_axis(), y_axis(), "no done job with a chute summary");
        }
        Some(xi) => draw_xi(conn, &jobs, &xis, xi, target_xi, &mut d)?,
    }
    let fig = Figure {
        title: Some(caption(
            conn,
            campaign,
            &jobs,
            format!(
                "Fig. {number}: D/D_max and γ̇/γ̇_max vs height, campaign {}{}",
                campaign.name,
                replicas_caption(d.max_replicas)
            ),
        )?),
        panels: vec![d.panel],
        columns: 1,
        panel_size: (1000, 700),
    };
    d.text.push_str(&d.table.to_text());
    Ok(Drawn {
        text: d.text,
        files: write_all(&fig, &d.csv, out_dir, &format!("chute_fig{number}"))?,
    })
}

fn x_axis() -> Axis {
    Axis::linear("z / L")
}

fn y_axis() -> Axis {
    Axis::linear("D/D_max (markers), γ̇/γ̇_max (lines)")
}

/// Every inclination at aspect ratio `xi`: one point per α, its steady replicas combined.
fn draw_xi(
    conn: &Connection,
    jobs: &[ChuteJob],
    xis: &[f64],
    xi: f64,
    target_xi: f64,
    d: &mut Drawing,
) -> Result<()> {
    let _ = writeln!(
        d.text,
        "xi = {} (the campaign's xi closest to the paper's {}; present: {}); one point \
         per alpha (the one with the lowest job id when several differ in another \
         parameter), its steady replicas combined\n\
         markers: D/D_max from chute_blocks, D pooled over the replicas from each one's D \
         and its standard error over msd_error_windows windows (Student t over the \
         replicas when one lacks its error), error bars 95 % CI / D_max; lines: shear \
         rate / its max, replica mean, from chute_fields for 0 <= z <= H (block \
         averages when a job has no field rows); D_max and shear_max over the full blocks \
         (phi >= half the densest block's), shear_max of the block averages, as the claims \
         normalise; D in L^2/s with L = total_length_m",
        short(xi),
        short(target_xi),
        xis.iter().map(|x| short(*x)).collect::<Vec<_>>().join(", ")
    );
    d.panel.title = Some(format!("ξ = {}", short(xi)));
    let at_xi: Vec<ChuteJob> = jobs
        .iter()
        .filter(|j| same_value(j.aspect_ratio, xi))
        .cloned()
        .collect();
    let points = group_points(&at_xi);
    let alphas = distinct(at_xi.iter().map(|j| j.inclination_deg));
    for (i, &alpha) in alphas.iter().enumerate() {
        let same: Vec<&Vec<&ChuteJob>> = points
            .iter()
            .filter(|g| same_value(g[0].inclination_deg, alpha))
            .collect();
        draw_alpha(conn, &same, xi, alpha, color(i), d)?;
    }
    if d.max_replicas > 1 {
        d.panel.notes.push(REPLICA_NOTE.into());
    }
    Ok(())
}

/// One inclination: the first of the `same` points (they differ in another parameter), its
/// D and γ̇ profiles over their maxima, drawn in colour `c` and listed.
fn draw_alpha(
    conn: &Connection,
    same: &[&Vec<&ChuteJob>],
    xi: f64,
    alpha: f64,
    c: usize,
    d: &mut Drawing,
) -> Result<()> {
    let point = combine_point(conn, same[0])?;
    let label = point.label();
    let replicas = point.pooled.len();
    d.max_replicas = d.max_replicas.max(replicas);
    if same.len() > 1 {
        let _ = writeln!(
            d.text,
            "alpha = {}: {} points differ in another parameter; drawn: {label}",
            short(alpha),
            same.len()
        );
    }
    if !point.not_pooled.is_empty() {
        let names: Vec<&str> = point.not_pooled.iter().map(|j| j.label.as_str()).collect();
        let _ = writeln!(
            d.text,
            "alpha = {}: not steady, not pooled: {}",
            short(alpha),
            names.join("; ")
        );
    }
    let l = point.total_length_m;
    let l2 = l * l;
    // (z/L, D/L², CI/L² (finite), replicas with a D)
    let diffusion: Vec<ProfilePoint> = point
        .blocks
        .iter()
        .filter_map(|b| {
            let p = b.diffusion?;
            let ci = Some(p.ci95 / l2).filter(|c| c.is_finite());
            Some((b.z_m / l, p.mean / l2, ci, p.replicas))
        })
        .collect();
    let (shear, from): (Vec<ProfilePoint>, &str) = if point.shear_field.is_empty() {
        let b = point.blocks.iter().map(|b| {
            let g = b.shear_rate;
            (b.z_m / l, g.mean, g.ci95, g.replicas)
        });
        (b.collect(), "blocks")
    } else {
        let f = point
            .shear_field
            .iter()
            .map(|&(z, g)| (z / l, g.mean, g.ci95, g.replicas));
        (f.collect(), "fields")
    };
    // The maxima the claims use: over the full blocks, not the dilute one the surface cuts,
    // and γ̇_max from the block averages even where the finer field is drawn, so that the
    // drawn gap is the one the claims test (the field's wall-layering peaks would set it).
    let full = full_blocks(&point.blocks, |b| b.solid_fraction.mean);
    let full_d: Vec<ProfilePoint> = diffusion
        .iter()
        .copied()
        .filter(|p| full.iter().any(|b| same_value(b.z_m / l, p.0)))
        .collect();
    let xy = |v: &[ProfilePoint]| -> Vec<(f64, f64)> { v.iter().map(|p| (p.0, p.1)).collect() };
    let d_max = max_point(&xy(&full_d));
    let d_max_ci = d_max.and_then(|m| {
        full_d
            .iter()
            .find(|p| p.0 == m.0 && p.1 == m.1)
            .and_then(|p| p.2)
    });
    let g_max = max_point(
        &full
            .iter()
            .map(|b| (b.z_m / l, b.shear_rate.mean))
            .collect::<Vec<_>>(),
    );
    d.table.push(vec![
        short(alpha),
        sci(d_max.map(|p| p.1), 3),
        sci(d_max_ci, 2),
        fixed(d_max.map(|p| p.0), 2),
        sci(g_max.map(|p| p.1), 3),
        fixed(g_max.map(|p| p.0), 2),
        diffusion.len().to_string(),
        from.into(),
        replicas.to_string(),
        label.clone(),
    ]);
    let row = |quantity: &'static str| CsvRow {
        label: &label,
        xi,
        alpha,
        quantity,
    };
    let g = normalised(&mut d.csv, row("shear_rate_per_s"), &shear, g_max);
    let dn = normalised(&mut d.csv, row("D_L2_per_s"), &diffusion, d_max);
    d.panel.series.push(Series::line(
        None,
        c,
        g.iter().map(|p| p.0).collect(),
        g.iter().map(|p| p.1).collect(),
    ));
    let legend = format!("α = {}°", short(alpha));
    d.panel.series.push(
        Series::points(
            Some(legend),
            c,
            dn.iter().map(|p| p.0).collect(),
            dn.iter().map(|p| p.1).collect(),
        )
        .with_errors(dn.iter().map(|p| p.2).collect())
        .with_point_labels(dn.iter().map(|p| replica_label(p.3)).collect()),
    );
    Ok(())
}

/// The CSV columns a profile's rows share.
struct CsvRow<'a> {
    label: &'a str,
    xi: f64,
    alpha: f64,
    quantity: &'static str,
}

/// Lists `pts` in the CSV, and returns them over `max` (a non-positive maximum cannot
/// normalise the profile: it is listed, not drawn).
fn normalised(
    csv: &mut Table,
    row: CsvRow,
    pts: &[ProfilePoint],
    max: Option<(f64, f64)>,
) -> Vec<ProfilePoint> {
    let max = max.map(|m| m.1).filter(|m| *m > 0.0);
    let mut norm = Vec::new();
    for &(z, v, ci, n) in pts {
        let r = max.map(|m| v / m);
        let ci_r = max.zip(ci).map(|(m, c)| c / m);
        csv.push(vec![
            row.label.to_string(),
            csv_num(Some(row.xi)),
            csv_num(Some(row.alpha)),
            row.quantity.into(),
            csv_num(Some(z)),
            csv_num(Some(v)),
            csv_num(r),
            csv_num(ci),
            csv_num(ci_r),
            n.to_string(),
        ]);
        if let Some(r) = r {
            norm.push((z, r, ci_r, n));
        }
    }
    norm
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn max_point_ignores_nan() {
        let p = [(0.0, 1.0), (1.0, f64::NAN), (2.0, 3.0)];
        assert_eq!(max_point(&p), Some((2.0, 3.0)));
        assert_eq!(max_point(&[]), None);
    }
}
