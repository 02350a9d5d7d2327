//! The rods' orientation per block of height L: (a) the nematic order S2(z) (largest
//! eigenvalue of Q = ⟨(3 u⊗u − I)/2⟩, Q averaged over the measurement's snapshots), (b)
//! ⟨|cos θ|⟩(z), θ between a rod's axis and the flow direction x, one series per (ξ, α) point,
//! from `chute_blocks`. Replicas of a point are combined: their mean, bars their 95 % CI
//! (Student t, from 2 replicas on). Spheres (ξ = 1) have no axis and store nothing; neither
//! does a job measured before schema 13 or resumed from a checkpoint written before it.

use std::fmt::Write as _;

use anyhow::Result;
use rusqlite::Connection;

use crate::pooled::chute::{combine_point, group_points, OverReplicas, PointBlock};
use crate::pooled::chute_jobs::drawable_chute_jobs;
use crate::pooled::silo::{replica_label, REPLICA_NOTE};
use crate::report::campaign::CampaignRef;
use crate::report::chute::common::{color, empty_panel, preface, two_panel_figure, GREY};
use crate::report::drawn::{Drawn, Output};
use crate::report::plot::{Axis, Legend, Panel, Series};
use crate::report::table::{csv_num, fixed, short, Table};

/// Why a figure of orientations can be empty.
const NO_ORIENTATION: &str = "no block with S2 or <|cos theta|> stored: spheres only (no axis), \
     or jobs measured before schema 13 (or resumed from a checkpoint written before it)";

/// (z/L, value) markers of one quantity, with bars and replica counts.
fn markers(legend: Option<String>, c: usize, pts: &[(f64, OverReplicas)]) -> Series {
    Series::points(
        legend,
        c,
        pts.iter().map(|p| p.0).collect(),
        pts.iter().map(|p| p.1.mean).collect(),
    )
    .with_errors(pts.iter().map(|p| p.1.ci95).collect())
    .with_point_labels(pts.iter().map(|p| replica_label(p.1.replicas)).collect())
}

/// A horizontal reference line at `y` over [x0, x1].
fn reference(label: &str, y: f64, x0: f64, x1: f64) -> Series {
    Series::line(Some(label.into()), GREY, vec![x0, x1], vec![y, y])
}

/// S2 and ⟨|cos θ|⟩ vs z/L per point.
pub(crate) fn orientation(
    conn: &Connection,
    campaign: &CampaignRef,
    out_dir: &Output,
) -> Result<Drawn> {
    let jobs = drawable_chute_jobs(conn, campaign.id, out_dir.include_unsteady)?;
    let mut text = preface(conn, campaign, &jobs)?;
    text.push_str(
        "S2 = largest eigenvalue of Q = <(3 u u - I)/2> over the rods centred in each block of \
         height L, Q averaged over snapshots; <|cos theta|>: theta between axis and flow (x); \
         chute_blocks, one series per (xi, alpha) point, steady replicas combined (mean, bars \
         95 % CI over replicas); isotropic axes: S2 -> 0, <|cos theta|> = 1/2\n",
    );
    let mut table = Table::new(&[
        "xi",
        "alpha_deg",
        "replicas",
        "blocks",
        "S2_bulk",
        "abs_cos_bulk",
        "point",
    ]);
    let mut csv = Table::new(&[
        "label",
        "xi",
        "alpha_deg",
        "block",
        "z_over_L",
        "S2",
        "S2_ci95",
        "abs_cos_theta",
        "abs_cos_theta_ci95",
        "replicas",
    ]);
    // Each quantity's own range: a dilute block's interval over two replicas would otherwise
    // set the scale and flatten every profile.
    let mut a = Panel::new(
        Axis::linear("z / L"),
        physical(Axis::linear("S2"), -0.5, 1.0),
    );
    a.title = Some("(a) nematic order S2(z)".into());
    let mut b = Panel::new(
        Axis::linear("z / L"),
        physical(Axis::linear("⟨|cos θ|⟩"), 0.0, 1.0),
    );
    b.title = Some("(b) ⟨|cos θ|⟩(z), θ to the flow".into());
    b.legend = Legend::Outside;
    let (mut z_lo, mut z_hi, mut max_replicas) = (f64::INFINITY, f64::NEG_INFINITY, 0);
    for (i, group) in group_points(&jobs).iter().enumerate() {
        let point = combine_point(conn, group)?;
        let (label, job) = (point.label(), point.pooled[0]);
        let l = point.total_length_m;
        let with: Vec<&PointBlock> = point
            .blocks
            .iter()
            .filter(|b| b.nematic_order.is_some() || b.mean_abs_cos_flow.is_some())
            .collect();
        if with.is_empty() {
            let why = if job.aspect_ratio <= 1.0 + 1e-9 {
                "spheres (xi = 1): no axis, no orientation stored"
            } else {
                "no orientation stored (measured before schema 13, or resumed from an older \
                 checkpoint)"
            };
            let _ = writeln!(text, "{label}: {why}");
            continue;
        }
        let s2: Vec<(f64, OverReplicas)> = with
            .iter()
            .filter_map(|b| Some((b.z_m / l, b.nematic_order?)))
            .collect();
        let cos: Vec<(f64, OverReplicas)> = with
            .iter()
            .filter_map(|b| Some((b.z_m / l, b.mean_abs_cos_flow?)))
            .collect();
        for blk in &with {
            csv.push(vec![
                label.clone(),
                csv_num(Some(job.aspect_ratio)),
                csv_num(Some(job.inclination_deg)),
                blk.block.to_string(),
                csv_num(Some(blk.z_m / l)),
                csv_num(blk.nematic_order.map(|o| o.mean)),
                csv_num(blk.nematic_order.and_then(|o| o.ci95)),
                csv_num(blk.mean_abs_cos_flow.map(|o| o.mean)),
                csv_num(blk.mean_abs_cos_flow.and_then(|o| o.ci95)),
                point.pooled.len().to_string(),
            ]);
            z_lo = z_lo.min(blk.z_m / l);
            z_hi = z_hi.max(blk.z_m / l);
        }
        max_replicas = max_replicas.max(point.pooled.len());
        let h = point.bed_height_m / l;
        let bulk = |v: &[(f64, OverReplicas)]| {
            let x: Vec<f64> = v
                .iter()
                .filter(|p| p.0 > 0.3 * h && p.0 < 0.7 * h)
                .map(|p| p.1.mean)
                .collect();
            (!x.is_empty()).then(|| x.iter().sum::<f64>() / x.len() as f64)
        };
        table.push(vec![
            short(job.aspect_ratio),
            short(job.inclination_deg),
            point.pooled.len().to_string(),
            with.len().to_string(),
            fixed(bulk(&s2), 3),
            fixed(bulk(&cos), 3),
            label.clone(),
        ]);
        let legend = format!(
            "ξ = {}, α = {}°{}",
            short(job.aspect_ratio),
            short(job.inclination_deg),
            if point.steady() { "" } else { " (NOT steady)" }
        );
        a.series.push(markers(None, color(i), &s2));
        b.series.push(markers(Some(legend), color(i), &cos));
    }
    let panels = if a.series.is_empty() && b.series.is_empty() {
        let why = if jobs.is_empty() {
            "no done job with a chute summary"
        } else {
            NO_ORIENTATION
        };
        let _ = writeln!(text, "{why}");
        vec![
            empty_panel(Axis::linear("z / L"), Axis::linear("S2"), why),
            empty_panel(Axis::linear("z / L"), Axis::linear("⟨|cos θ|⟩"), why),
        ]
    } else {
        a.series.push(reference("isotropic: 0", 0.0, z_lo, z_hi));
        b.series.push(reference("isotropic: 1/2", 0.5, z_lo, z_hi));
        if max_replicas > 1 {
            b.notes.push(REPLICA_NOTE.into());
        }
        vec![a, b]
    };
    two_panel_figure(
        conn,
        campaign,
        &jobs,
        format!("Rod orientation per block, campaign {}", campaign.name),
        panels,
        (750, 600),
        text,
        &table,
        &csv,
        out_dir,
        "chute_orientation",
    )
}

/// `axis` fixed to a quantity's possible values [lo, hi].
fn physical(mut axis: Axis, lo: f64, hi: f64) -> Axis {
    axis.range = Some((lo, hi));
    axis
}
