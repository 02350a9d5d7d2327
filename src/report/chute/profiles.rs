//! Figs. 3 and 4 of the chute paper: D/D_max (markers) and γ̇/γ̇_max (lines) against z/L for
//! every inclination α of one aspect ratio ξ — Fig. 3 the campaign's ξ closest to 1.3, Fig. 4
//! the one closest to 2.5 (the paper's choices). D comes from chute_blocks; γ̇ from the
//! coarse-grained chute_fields profile for 0 ≤ z ≤ H, or from the block averages when a job has
//! no field rows. D_max and γ̇_max are the maxima of what is drawn.

use std::fmt::Write as _;

use anyhow::Result;
use rusqlite::Connection;

use crate::report::campaign::CampaignRef;
use crate::report::chute::data::{blocks, closest, done_chute_jobs, shear_profile, ChuteJob};
use crate::report::chute::{caption, color, empty_panel, preface};
use crate::report::drawn::{write_all, Drawn, Output};
use crate::report::plot::{Axis, Figure, Legend, Panel, Series};
use crate::report::silo::data::{distinct, same_value};
use crate::report::table::{csv_num, fixed, sci, short, Table};

/// Fig. 3: the profiles at the campaign's ξ closest to 1.3.
pub(crate) fn fig3(conn: &Connection, campaign: &CampaignRef, out_dir: &Output) -> Result<Drawn> {
    profiles(conn, campaign, out_dir, 3, 1.3)
}

/// Fig. 4: the profiles at the campaign's ξ closest to 2.5.
pub(crate) fn fig4(conn: &Connection, campaign: &CampaignRef, out_dir: &Output) -> Result<Drawn> {
    profiles(conn, campaign, out_dir, 4, 2.5)
}

/// The largest finite value of `points` (by y) as (x, y); None when there is none.
fn max_point(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    points
        .iter()
        .copied()
        .filter(|p| p.1.is_finite())
        .max_by(|a, b| a.1.total_cmp(&b.1))
}

fn profiles(
    conn: &Connection,
    campaign: &CampaignRef,
    out_dir: &Output,
    number: u32,
    target_xi: f64,
) -> Result<Drawn> {
    let jobs = done_chute_jobs(conn, campaign.id, out_dir.include_unsteady)?;
    let mut text = preface(conn, campaign, &jobs)?;
    let xis = distinct(jobs.iter().map(|j| j.aspect_ratio));
    let xi = closest(xis.iter().copied(), target_xi);
    let x_axis = || Axis::linear("z / L");
    let y_axis = || Axis::linear("D/D_max (markers), γ̇/γ̇_max (lines)");
    let mut table = Table::new(&[
        "alpha_deg",
        "D_max_L2/s",
        "z(D_max)/L",
        "shear_max_1/s",
        "z(shear_max)/L",
        "blocks_D",
        "shear_from",
        "replicas",
        "job",
    ]);
    let mut csv = Table::new(&[
        "label",
        "xi",
        "alpha_deg",
        "quantity",
        "z_over_L",
        "value",
        "value_over_max",
    ]);
    let mut panel = Panel::new(x_axis(), y_axis());
    panel.legend = Legend::Outside;
    match xi {
        None => {
            text.push_str("no done job with a chute summary\n");
            panel = empty_panel(x_axis(), y_axis(), "no done job with a chute summary");
        }
        Some(xi) => {
            let _ = writeln!(
                text,
                "xi = {} (the campaign's xi closest to the paper's {}; present: {}); one done job \
                 per alpha (the lowest job id when there are replicas)\n\
                 markers: D/D_max from chute_blocks; lines: shear rate / its max, from \
                 chute_fields for 0 <= z <= H (block averages when a job has no field rows); \
                 D in L^2/s with L = total_length_m",
                short(xi),
                short(target_xi),
                xis.iter().map(|x| short(*x)).collect::<Vec<_>>().join(", ")
            );
            panel.title = Some(format!("ξ = {}", short(xi)));
            let at_xi: Vec<&ChuteJob> = jobs
                .iter()
                .filter(|j| same_value(j.aspect_ratio, xi))
                .collect();
            let alphas = distinct(at_xi.iter().map(|j| j.inclination_deg));
            for (i, &alpha) in alphas.iter().enumerate() {
                let same: Vec<&&ChuteJob> = at_xi
                    .iter()
                    .filter(|j| same_value(j.inclination_deg, alpha))
                    .collect();
                let job = same[0];
                let l = job.total_length_m;
                let rows = blocks(conn, job.job_id)?;
                let d: Vec<(f64, f64)> = rows
                    .iter()
                    .filter_map(|r| r.diffusion_m2_per_s.map(|d| (r.z_m / l, d / (l * l))))
                    .collect();
                let field = shear_profile(conn, job.job_id, job.bed_height_m)?;
                let (shear, from): (Vec<(f64, f64)>, &str) = if field.is_empty() {
                    let b = rows.iter().map(|r| (r.z_m / l, r.shear_rate_per_s));
                    (b.collect(), "blocks")
                } else {
                    let f = field.iter().map(|&(z, g)| (z / l, g));
                    (f.collect(), "fields")
                };
                let d_max = max_point(&d);
                let g_max = max_point(&shear);
                table.push(vec![
                    short(alpha),
                    sci(d_max.map(|p| p.1), 3),
                    fixed(d_max.map(|p| p.0), 2),
                    sci(g_max.map(|p| p.1), 3),
                    fixed(g_max.map(|p| p.0), 2),
                    d.len().to_string(),
                    from.into(),
                    same.len().to_string(),
                    job.label.clone(),
                ]);
                let c = color(i);
                let mut add = |quantity: &str, pts: &[(f64, f64)], max: Option<(f64, f64)>| {
                    // A non-positive maximum cannot normalise the profile: it is listed, not drawn.
                    let max = max.map(|m| m.1).filter(|m| *m > 0.0);
                    let mut norm = Vec::new();
                    for &(z, v) in pts {
                        let r = max.map(|m| v / m);
                        csv.push(vec![
                            job.label.clone(),
                            csv_num(Some(xi)),
                            csv_num(Some(alpha)),
                            quantity.into(),
                            csv_num(Some(z)),
                            csv_num(Some(v)),
                            csv_num(r),
                        ]);
                        norm.extend(r.map(|r| (z, r)));
                    }
                    norm.into_iter().unzip::<f64, f64, Vec<f64>, Vec<f64>>()
                };
                let (gz, gy) = add("shear_rate_per_s", &shear, g_max);
                let (dz, dy) = add("D_L2_per_s", &d, d_max);
                panel.series.push(Series::line(None, c, gz, gy));
                let label = format!("α = {}°", short(alpha));
                panel.series.push(Series::points(Some(label), c, dz, dy));
            }
        }
    }
    let fig = Figure {
        title: Some(caption(
            conn,
            campaign,
            format!(
                "Fig. {number}: D/D_max and γ̇/γ̇_max vs height, campaign {}",
                campaign.name
            ),
        )?),
        panels: vec![panel],
        columns: 1,
        panel_size: (1000, 700),
    };
    text.push_str(&table.to_text());
    Ok(Drawn {
        text,
        files: write_all(&fig, &csv, out_dir, &format!("chute_fig{number}"))?,
    })
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
