//! Fig. 1(b) of the chute paper, as profiles: V_x(z) and φ(z) against z/L (height upwards, as
//! the paper draws its red V_x curve), one curve per (ξ, α) point, from the coarse-grained
//! `chute_fields` (time-averaged, on the observer's fine grid) for 0 ≤ z ≤ 1.2 H. Replicas of
//! a point are combined at each height: the line is their mean, thin lines of the same colour
//! their 95 % interval (Student t over the replicas, from 2 on).

use std::fmt::Write as _;

use anyhow::Result;
use rusqlite::Connection;

use crate::pooled::chute::{combine_point, group_points, OverReplicas};
use crate::pooled::chute_fields::{field_profiles, FieldPoint};
use crate::pooled::chute_jobs::drawable_chute_jobs;
use crate::report::campaign::CampaignRef;
use crate::report::chute::common::{color, empty_panel, preface, two_panel_figure};
use crate::report::drawn::{Drawn, Output};
use crate::report::plot::{Axis, Legend, Panel, Series};
use crate::report::table::{csv_num, fixed, short, Table};

/// Profiles are drawn up to this multiple of the bed height H (the dilute surface above).
const Z_MAX_OVER_H: f64 = 1.2;

/// The bulk φ of a profile: its mean over 0.3 H < z < 0.7 H.
const BULK: (f64, f64) = (0.3, 0.7);

/// A profile's mean line and, where the replicas give an interval, its two bounds, with z/L
/// on the vertical axis.
fn profile_lines(
    label: Option<String>,
    c: usize,
    z_over_l: &[f64],
    v: &[OverReplicas],
) -> Vec<Series> {
    let mean: Vec<f64> = v.iter().map(|o| o.mean).collect();
    let mut out = vec![Series::line(label, c, mean, z_over_l.to_vec())];
    if v.iter().any(|o| o.ci95.is_some()) {
        for sign in [-1.0, 1.0] {
            let x = v
                .iter()
                .map(|o| o.ci95.map_or(f64::NAN, |ci| o.mean + sign * ci))
                .collect();
            out.push(Series::line(None, c, x, z_over_l.to_vec()));
        }
    }
    out
}

/// Fig. 1(b): V_x(z) and φ(z) per point.
pub(crate) fn fig1b(conn: &Connection, campaign: &CampaignRef, out_dir: &Output) -> Result<Drawn> {
    let jobs = drawable_chute_jobs(conn, campaign.id, out_dir.include_unsteady)?;
    let mut text = preface(conn, campaign, &jobs)?;
    let _ = writeln!(
        text,
        "V_x and phi = rho/rho_p from chute_fields (coarse-grained, time-averaged), 0 <= z <= \
         {Z_MAX_OVER_H} H; one curve per (xi, alpha) point, its steady replicas combined at \
         each height (mean; thin lines: 95 % CI over the replicas); z in L = total_length_m"
    );
    let mut table = Table::new(&[
        "xi",
        "alpha_deg",
        "replicas",
        "H/L",
        "V_x_max_m/s",
        "phi_bulk",
        "heights",
        "point",
    ]);
    let mut csv = Table::new(&[
        "label",
        "xi",
        "alpha_deg",
        "quantity",
        "z_over_L",
        "value",
        "ci95",
        "replicas",
    ]);
    let z_axis = || Axis::linear("z / L");
    let mut a = Panel::new(Axis::linear("V_x (m/s)"), z_axis());
    a.title = Some("(a) V_x(z)".into());
    let mut b = Panel::new(Axis::linear("φ"), z_axis());
    b.title = Some("(b) φ(z)".into());
    b.legend = Legend::Outside;
    let mut max_replicas = 0;
    for (i, group) in group_points(&jobs).iter().enumerate() {
        let point = combine_point(conn, group)?;
        let label = point.label();
        let job = point.pooled[0];
        let profile: Vec<FieldPoint> = field_profiles(conn, &point.pooled, Z_MAX_OVER_H)?;
        if profile.is_empty() {
            let _ = writeln!(text, "{label}: no chute_fields rows, not drawn");
            continue;
        }
        let replicas = point.pooled.len();
        max_replicas = max_replicas.max(replicas);
        let l = point.total_length_m;
        let z: Vec<f64> = profile.iter().map(|p| p.z_m / l).collect();
        let vx: Vec<OverReplicas> = profile.iter().map(|p| p.velocity_x).collect();
        let phi: Vec<OverReplicas> = profile.iter().map(|p| p.solid_fraction).collect();
        for (quantity, values) in [("V_x_m_per_s", &vx), ("phi", &phi)] {
            for (zl, v) in z.iter().zip(values.iter()) {
                csv.push(vec![
                    label.clone(),
                    csv_num(Some(job.aspect_ratio)),
                    csv_num(Some(job.inclination_deg)),
                    quantity.into(),
                    csv_num(Some(*zl)),
                    csv_num(Some(v.mean)),
                    csv_num(v.ci95),
                    v.replicas.to_string(),
                ]);
            }
        }
        let h = point.bed_height_m;
        let bulk: Vec<f64> = profile
            .iter()
            .filter(|p| p.z_m > BULK.0 * h && p.z_m < BULK.1 * h)
            .map(|p| p.solid_fraction.mean)
            .collect();
        let vmax = vx.iter().map(|v| v.mean).fold(f64::NEG_INFINITY, f64::max);
        table.push(vec![
            short(job.aspect_ratio),
            short(job.inclination_deg),
            replicas.to_string(),
            fixed(Some(h / l), 2),
            fixed(Some(vmax), 3),
            fixed(
                (!bulk.is_empty()).then(|| bulk.iter().sum::<f64>() / bulk.len() as f64),
                3,
            ),
            profile.len().to_string(),
            label.clone(),
        ]);
        let legend = format!(
            "ξ = {}, α = {}°{}",
            short(job.aspect_ratio),
            short(job.inclination_deg),
            if point.steady() { "" } else { " (NOT steady)" }
        );
        a.series.extend(profile_lines(None, color(i), &z, &vx));
        b.series
            .extend(profile_lines(Some(legend), color(i), &z, &phi));
    }
    let panels = if a.series.is_empty() {
        let why = if jobs.is_empty() {
            "no done job with a chute summary"
        } else {
            "no done job with coarse-grained profiles (chute_fields)"
        };
        text.push_str(why);
        text.push('\n');
        vec![
            empty_panel(Axis::linear("V_x (m/s)"), z_axis(), why),
            empty_panel(Axis::linear("φ"), z_axis(), why),
        ]
    } else {
        if max_replicas > 1 {
            b.notes
                .push("thin lines: 95 % CI over a point's replicas".into());
        }
        vec![a, b]
    };
    two_panel_figure(
        conn,
        campaign,
        &jobs,
        format!(
            "Fig. 1(b): V_x and φ profiles, campaign {}{}",
            campaign.name,
            if max_replicas > 1 {
                format!("; up to {max_replicas} replicas per point, thin lines 95 % CI")
            } else {
                String::new()
            }
        ),
        panels,
        (700, 700),
        text,
        &table,
        &csv,
        out_dir,
        "chute_fig1b",
    )
}
