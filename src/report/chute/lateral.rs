//! The ESI's D_y: (a) D_y/D_y,max (markers) beside γ̇/γ̇_max (lines) against z/L, and (b) D_y
//! against γ̇ d_⊥² in the central bed (0.3 H < z < 0.7 H, as Fig. 6), one series per (ξ, α)
//! point, from `chute_blocks`. D_y is pooled over a point's replicas as D_z is (each one's
//! window error; bars 95 % CI); γ̇ is the block mean over replicas. Both are normalised by
//! their maxima over the full blocks (φ at least half the densest). The table gives, per point,
//! the correlation coefficient of D_y and of D_z with γ̇ over the central blocks: the paper
//! finds D_z ∝ γ̇ d_⊥² and no such relation for D_y.

use std::fmt::Write as _;

use anyhow::Result;
use rusqlite::Connection;

use crate::observe::fits::linear_fit;
use crate::pooled::chute::{combine_point, group_points, PointProfiles, CENTRAL_BED};
use crate::pooled::chute_jobs::drawable_chute_jobs;
use crate::pooled::replica_results::full_blocks;
use crate::pooled::silo::{replica_label, REPLICA_NOTE};
use crate::report::campaign::CampaignRef;
use crate::report::chute::common::{color, empty_panel, preface, two_panel_figure};
use crate::report::drawn::{Drawn, Output};
use crate::report::plot::{Axis, Legend, Panel, Series};
use crate::report::table::{csv_num, fixed, sci, short, Table};

/// One block of a point with a D_y, lengths in units of L.
struct DyBlock {
    block: i64,
    z_over_l: f64,
    central: bool,
    /// D_y/L² and its 95 % CI half-width (None: unknown), 1/s.
    d_y: f64,
    d_y_ci: Option<f64>,
    replicas: usize,
    /// D_z/L² of the same block, 1/s.
    d_z: Option<f64>,
    shear: f64,
    /// γ̇ (d_⊥/L)², 1/s.
    shear_dperp2: f64,
}

/// The blocks of `point` with a D_y.
fn dy_blocks(point: &PointProfiles) -> Vec<DyBlock> {
    let l = point.total_length_m;
    let (lo, hi) = CENTRAL_BED;
    let h = point.bed_height_m;
    let dp2 = (point.d_perp_m / l).powi(2);
    point
        .blocks
        .iter()
        .filter_map(|b| {
            let d = b.diffusion_y?;
            Some(DyBlock {
                block: b.block,
                z_over_l: b.z_m / l,
                central: b.z_m > lo * h && b.z_m < hi * h,
                d_y: d.mean / (l * l),
                d_y_ci: Some(d.ci95 / (l * l)).filter(|c| c.is_finite()),
                replicas: d.replicas,
                d_z: b.diffusion.map(|p| p.mean / (l * l)),
                shear: b.shear_rate.mean,
                shear_dperp2: b.shear_rate.mean * dp2,
            })
        })
        .collect()
}

/// The correlation coefficient of (x, y) over at least 3 pairs.
fn correlation(pairs: impl Iterator<Item = (f64, f64)>) -> Option<f64> {
    let (x, y): (Vec<f64>, Vec<f64>) = pairs.filter(|p| p.0.is_finite() && p.1.is_finite()).unzip();
    (x.len() >= 3)
        .then(|| linear_fit(&x, &y).map(|f| f.r))
        .flatten()
}

/// The largest finite value of `v`, when positive.
fn positive_max(v: impl Iterator<Item = f64>) -> Option<f64> {
    v.filter(|x| x.is_finite())
        .fold(None, |m: Option<f64>, x| Some(m.map_or(x, |m| m.max(x))))
        .filter(|m| *m > 0.0)
}

/// What the figure gathers over the points.
struct Drawing {
    text: String,
    table: Table,
    csv: Table,
    a: Panel,
    b: Panel,
    max_replicas: usize,
}

impl Drawing {
    /// One point (its replicas combined), drawn in colour `i`.
    fn point(&mut self, point: &PointProfiles, i: usize) {
        let (label, job) = (point.label(), point.pooled[0]);
        let rows = dy_blocks(point);
        if rows.is_empty() {
            let _ = writeln!(
                self.text,
                "{label}: no D_y stored (measured before schema 13, resumed from an older \
             checkpoint, or too few particles per block)"
            );
            return;
        }
        self.max_replicas = self.max_replicas.max(point.pooled.len());
        // The maxima over the full blocks, as Figs. 3–4 and the claims take them: the dilute
        // block the surface cuts holds few particles and would set them by chance.
        let full: Vec<i64> = full_blocks(&point.blocks, |b| b.solid_fraction.mean)
            .iter()
            .map(|b| b.block)
            .collect();
        let d_max = positive_max(
            rows.iter()
                .filter(|r| full.contains(&r.block))
                .map(|r| r.d_y),
        );
        let g_max = positive_max(
            point
                .blocks
                .iter()
                .filter(|b| full.contains(&b.block))
                .map(|b| b.shear_rate.mean),
        );
        for r in &rows {
            self.csv.push(vec![
                label.clone(),
                csv_num(Some(job.aspect_ratio)),
                csv_num(Some(job.inclination_deg)),
                r.block.to_string(),
                csv_num(Some(r.z_over_l)),
                u8::from(r.central).to_string(),
                csv_num(Some(r.d_y)),
                csv_num(r.d_y_ci),
                csv_num(d_max.map(|m| r.d_y / m)),
                csv_num(Some(r.shear)),
                csv_num(g_max.map(|m| r.shear / m)),
                csv_num(Some(r.shear_dperp2)),
                csv_num(r.d_z),
                r.replicas.to_string(),
            ]);
        }
        let central: Vec<&DyBlock> = rows.iter().filter(|r| r.central).collect();
        self.table.push(vec![
            short(job.aspect_ratio),
            short(job.inclination_deg),
            rows.len().to_string(),
            sci(d_max, 3),
            central.len().to_string(),
            fixed(correlation(central.iter().map(|r| (r.shear, r.d_y))), 2),
            fixed(
                correlation(central.iter().filter_map(|r| Some((r.shear, r.d_z?)))),
                2,
            ),
            label.clone(),
        ]);
        let c = color(i);
        if let Some(m) = g_max {
            // γ̇ is drawn within the bed (z ≤ H), as Figs. 3 and 4 draw it.
            let (z, g): (Vec<f64>, Vec<f64>) = point
                .blocks
                .iter()
                .filter(|b| b.z_m <= point.bed_height_m)
                .map(|b| (b.z_m / point.total_length_m, b.shear_rate.mean / m))
                .unzip();
            self.a.series.push(Series::line(None, c, z, g));
        }
        if let Some(m) = d_max {
            self.a.series.push(
                Series::points(
                    None,
                    c,
                    rows.iter().map(|r| r.z_over_l).collect(),
                    rows.iter().map(|r| r.d_y / m).collect(),
                )
                .with_errors(rows.iter().map(|r| r.d_y_ci.map(|e| e / m)).collect()),
            );
        }
        let legend = format!(
            "ξ = {}, α = {}°{}",
            short(job.aspect_ratio),
            short(job.inclination_deg),
            if point.steady() { "" } else { " (NOT steady)" }
        );
        self.b.series.push(
            Series::points(
                Some(legend),
                c,
                central.iter().map(|r| r.shear_dperp2).collect(),
                central.iter().map(|r| r.d_y).collect(),
            )
            .with_errors(central.iter().map(|r| r.d_y_ci).collect())
            .with_point_labels(central.iter().map(|r| replica_label(r.replicas)).collect()),
        );
    }
}

/// D_y beside γ̇ per point, and D_y against γ̇ d_⊥².
pub(crate) fn dy(conn: &Connection, campaign: &CampaignRef, out_dir: &Output) -> Result<Drawn> {
    let jobs = drawable_chute_jobs(conn, campaign.id, out_dir.include_unsteady)?;
    let mut text = preface(conn, campaign, &jobs)?;
    let (lo, hi) = CENTRAL_BED;
    let _ = writeln!(
        text,
        "D_y from the MSD of y (unwrapped across the periodic box), fitted as D_z; chute_blocks, \
         steady replicas combined (D_y pooled with its 95 % CI, shear rate their mean); (a) \
         D_y/D_y,max markers and shear/shear_max lines vs z/L; (b) D_y vs shear d_perp^2 over \
         the central blocks {lo} H < z < {hi} H; r: correlation coefficient over those blocks; \
         lengths in L = total_length_m"
    );
    let table = Table::new(&[
        "xi",
        "alpha_deg",
        "blocks_D_y",
        "D_y_max_L2/s",
        "central",
        "r(D_y,shear)",
        "r(D_z,shear)",
        "point",
    ]);
    let csv = Table::new(&[
        "label",
        "xi",
        "alpha_deg",
        "block",
        "z_over_L",
        "central",
        "D_y_L2_per_s",
        "D_y_ci95",
        "D_y_over_max",
        "shear_rate_per_s",
        "shear_over_max",
        "shear_dperp2_L2_per_s",
        "D_z_L2_per_s",
        "replicas",
    ]);
    let mut a = Panel::new(
        Axis::linear("z / L"),
        Axis::linear("D_y/D_y,max (markers), γ̇/γ̇_max (lines)"),
    );
    a.title = Some("(a) D_y and γ̇ profiles".into());
    let mut b = Panel::new(Axis::linear("γ̇ d_⊥² (L²/s)"), Axis::linear("D_y (L²/s)"));
    b.title = Some(format!("(b) D_y vs γ̇ d_⊥², {lo} H < z < {hi} H"));
    b.legend = Legend::Outside;
    let mut d = Drawing {
        text,
        table,
        csv,
        a,
        b,
        max_replicas: 0,
    };
    for (i, group) in group_points(&jobs).iter().enumerate() {
        d.point(&combine_point(conn, group)?, i);
    }
    let Drawing {
        mut text,
        table,
        csv,
        a,
        mut b,
        max_replicas,
    } = d;
    let panels = if a.series.is_empty() {
        let why = if jobs.is_empty() {
            "no done job with a chute summary"
        } else {
            "no block with D_y stored: jobs measured before schema 13 (or resumed from a \
             checkpoint written before it)"
        };
        let _ = writeln!(text, "{why}");
        vec![
            empty_panel(Axis::linear("z / L"), Axis::linear("D_y/D_y,max"), why),
            empty_panel(
                Axis::linear("γ̇ d_⊥² (L²/s)"),
                Axis::linear("D_y (L²/s)"),
                why,
            ),
        ]
    } else {
        if max_replicas > 1 {
            b.notes.push(REPLICA_NOTE.into());
        }
        vec![a, b]
    };
    two_panel_figure(
        conn,
        campaign,
        &jobs,
        format!("ESI: D_y and the shear rate, campaign {}", campaign.name),
        panels,
        (750, 600),
        text,
        &table,
        &csv,
        out_dir,
        "chute_dy",
    )
}
