//! Colour maps of axisymmetric (r, z) fields, drawn with plotters into an SVG and a PNG: rows of
//! panels, each row with its own colour scale and bar, the field mirrored to −r so a panel shows
//! the silo's familiar cross-section, optional arrows (a quiver of (V_r, V_z)) and dashed
//! rectangles (the orifice cylinder). Knows nothing of the database or the papers.

use std::path::PathBuf;

use anyhow::{anyhow, Result};
use plotters::coord::Shift;
use plotters::prelude::*;

use super::drawn::Output;
use super::plot::write_svg_and_png;

const FONT: &str = "sans-serif";

/// Viridis at 9 stops, interpolated linearly: perceptually ordered and readable in grey.
const VIRIDIS: [(u8, u8, u8); 9] = [
    (68, 1, 84),
    (71, 44, 122),
    (59, 81, 139),
    (44, 113, 142),
    (33, 144, 141),
    (39, 173, 129),
    (92, 200, 99),
    (170, 220, 50),
    (253, 231, 37),
];

/// The colour of `t` in [0, 1].
fn viridis(t: f64) -> RGBColor {
    let t = t.clamp(0.0, 1.0) * (VIRIDIS.len() - 1) as f64;
    let k = (t.floor() as usize).min(VIRIDIS.len() - 2);
    let f = t - k as f64;
    let (a, b) = (VIRIDIS[k], VIRIDIS[k + 1]);
    let mix = |x: u8, y: u8| (x as f64 + f * (y as f64 - x as f64)).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// One (r, z) field: cell-centred values on nr × nz points (r fastest).
#[derive(Debug, Clone)]
pub struct MapPanel {
    pub title: String,
    /// First point and spacing in r and z (m).
    pub r0_m: f64,
    pub dr_m: f64,
    pub z0_m: f64,
    pub dz_m: f64,
    pub nr: usize,
    pub nz: usize,
    /// nr × nz values; NaN cells are left white (no particles there).
    pub values: Vec<f64>,
    /// Arrows (r, z, u_r, u_z) in m and m/s, drawn on both halves (u_r mirrored).
    pub arrows: Vec<(f64, f64, f64, f64)>,
    /// Streamlines, polylines of (r, z) points (m), drawn on both halves.
    pub streamlines: Vec<Vec<(f64, f64)>>,
    /// Dashed rectangles (r_max, z_lo, z_hi) (m), drawn on both halves.
    pub boxes: Vec<(f64, f64, f64)>,
}

impl MapPanel {
    /// The value at (r, z) (m) interpolated bilinearly between the four grid points around it;
    /// the nearest point's value where one of them is empty (NaN) or outside the grid, so no
    /// colour bleeds into empty cells.
    fn interpolate(&self, r: f64, z: f64) -> f64 {
        let fi = ((r - self.r0_m) / self.dr_m).clamp(0.0, (self.nr - 1) as f64);
        let fj = ((z - self.z0_m) / self.dz_m).clamp(0.0, (self.nz - 1) as f64);
        let (i0, j0) = (fi.floor() as usize, fj.floor() as usize);
        let (i1, j1) = ((i0 + 1).min(self.nr - 1), (j0 + 1).min(self.nz - 1));
        let (ti, tj) = (fi - i0 as f64, fj - j0 as f64);
        let at = |i: usize, j: usize| self.values[j * self.nr + i];
        let corners = [at(i0, j0), at(i1, j0), at(i0, j1), at(i1, j1)];
        if corners.iter().any(|v| !v.is_finite()) {
            return at(fi.round() as usize, fj.round() as usize);
        }
        let bottom = corners[0] + ti * (corners[1] - corners[0]);
        let top = corners[2] + ti * (corners[3] - corners[2]);
        bottom + tj * (top - bottom)
    }
}

/// Pieces per grid cell along r and z in the PNG's interpolated maps.
const PNG_SUBCELLS: usize = 4;

/// A row of panels sharing one colour scale.
#[derive(Debug, Clone)]
pub struct MapRow {
    /// Label at the row's left (e.g. "f = 0.5 Hz").
    pub label: String,
    pub panels: Vec<MapPanel>,
    /// Colour range (lo, hi).
    pub range: (f64, f64),
    /// Text of the colour bar (field and unit).
    pub bar_label: String,
}

/// A figure of map rows, axes in units of `length_m` (the silo radius).
#[derive(Debug, Clone)]
pub struct MapFigure {
    pub title: String,
    pub rows: Vec<MapRow>,
    /// Lengths are drawn divided by this (m), named `length_name` on the axes.
    pub length_m: f64,
    pub length_name: String,
    /// Shown z range (m).
    pub z_range_m: (f64, f64),
    /// Arrow length per m/s (in units of `length_m`).
    pub arrow_scale: f64,
}

// Text is at least plotters' size 18 (an em of 14.5 px) at these sizes.
const PANEL_W: u32 = 380;
const BAR_W: u32 = 150;
const LABEL_W: u32 = 140;
const TITLE_H: u32 = 50;

impl MapFigure {
    fn size(&self, titled: bool) -> (u32, u32) {
        let cols = self.rows.iter().map(|r| r.panels.len()).max().unwrap_or(1) as u32;
        let (lr, (zlo, zhi)) = (self.length_m, self.z_range_m);
        let aspect = ((zhi - zlo) / lr) / 2.0;
        let panel_h = ((PANEL_W as f64 - 80.0) * aspect + 110.0).clamp(200.0, 1000.0) as u32;
        (
            LABEL_W + cols * PANEL_W + BAR_W,
            if titled { TITLE_H } else { 0 } + self.rows.len() as u32 * panel_h,
        )
    }

    /// Writes `<dir>/<stem>.svg` and `.png`; returns their paths.
    ///
    /// # Errors
    /// When the font cannot be loaded or a file cannot be written.
    pub fn write(&self, out: &Output, stem: &str) -> Result<Vec<PathBuf>> {
        let titled = out.titles;
        // The SVG draws one cell per grid point (the data as they are); the PNG interpolates.
        write_svg_and_png(
            out,
            stem,
            self.size(titled),
            |r| self.draw(r, titled, 1),
            |r| self.draw(r, titled, PNG_SUBCELLS),
        )
    }

    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        titled: bool,
        sub: usize,
    ) -> Result<()> {
        root.fill(&WHITE).map_err(err)?;
        let area = if titled {
            root.titled(&self.title, (FONT, 24).into_font().color(&BLACK))
                .map_err(err)?
        } else {
            root.clone()
        };
        let rows = area.split_evenly((self.rows.len().max(1), 1));
        let cols = self.rows.iter().map(|r| r.panels.len()).max().unwrap_or(1);
        for (row, cell) in self.rows.iter().zip(rows) {
            let (label, rest) = cell.split_horizontally(LABEL_W);
            label
                .draw_text(
                    &row.label,
                    &(FONT, 19).into_font().color(&BLACK),
                    (6, cell.dim_in_pixel().1 as i32 / 2),
                )
                .map_err(err)?;
            let (w, _) = rest.dim_in_pixel();
            let (maps, bar) = rest.split_horizontally(w - BAR_W);
            for (panel, pc) in row.panels.iter().zip(maps.split_evenly((1, cols))) {
                self.draw_panel(&pc, panel, row.range, sub)?;
            }
            draw_bar(&bar, row.range, &row.bar_label)?;
        }
        Ok(())
    }

    fn draw_panel<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        p: &MapPanel,
        (lo, hi): (f64, f64),
        sub: usize,
    ) -> Result<()> {
        let l = self.length_m;
        let (zlo, zhi) = (self.z_range_m.0 / l, self.z_range_m.1 / l);
        let rmax = (p.r0_m + (p.nr as f64 - 0.5) * p.dr_m) / l;
        let mut chart = ChartBuilder::on(area)
            .caption(&p.title, (FONT, 18))
            .margin(6)
            .x_label_area_size(50)
            .y_label_area_size(66)
            .build_cartesian_2d(-rmax..rmax, zlo..zhi)
            .map_err(err)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(format!("r / {}", self.length_name))
            .y_desc(format!("z / {}", self.length_name))
            .x_labels(5)
            .y_labels(6)
            .label_style((FONT, 18))
            .axis_desc_style((FONT, 18))
            .draw()
            .map_err(err)?;
        let span = if hi > lo { hi - lo } else { 1.0 };
        let mut cells = Vec::new();
        // Each grid cell as sub × sub pieces, each coloured by the bilinear interpolation of
        // the grid points at its centre (sub = 1: the point's own value).
        let (sdr, sdz) = (p.dr_m / sub as f64, p.dz_m / sub as f64);
        for j in 0..p.nz * sub {
            let z = p.z0_m - 0.5 * p.dz_m + (j as f64 + 0.5) * sdz;
            let (za, zb) = ((z - 0.5 * sdz) / l, (z + 0.5 * sdz) / l);
            if zb < zlo || za > zhi {
                continue;
            }
            for i in 0..p.nr * sub {
                let r = p.r0_m - 0.5 * p.dr_m + (i as f64 + 0.5) * sdr;
                let v = if sub == 1 {
                    p.values[(j / sub) * p.nr + i / sub]
                } else {
                    p.interpolate(r, z)
                };
                if !v.is_finite() {
                    continue;
                }
                let c = viridis((v - lo) / span).filled();
                let (ra, rb) = ((r - 0.5 * sdr) / l, (r + 0.5 * sdr) / l);
                cells.push(Rectangle::new([(ra, za), (rb, zb)], c));
                cells.push(Rectangle::new([(-rb, za), (-ra, zb)], c));
            }
        }
        chart.draw_series(cells).map_err(err)?;
        let k = self.arrow_scale;
        for &(r, z, ur, uz) in &p.arrows {
            for sign in [1.0, -1.0] {
                let a = (sign * r / l, z / l);
                let b = (a.0 + sign * ur * k, a.1 + uz * k);
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        vec![a, b],
                        WHITE.stroke_width(1),
                    )))
                    .map_err(err)?;
                chart
                    .draw_series(std::iter::once(Circle::new(b, 1, WHITE.filled())))
                    .map_err(err)?;
            }
        }
        for line in &p.streamlines {
            for sign in [1.0, -1.0] {
                let pts: Vec<(f64, f64)> =
                    line.iter().map(|&(r, z)| (sign * r / l, z / l)).collect();
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        pts,
                        WHITE.stroke_width(1),
                    )))
                    .map_err(err)?;
            }
        }
        for &(r, za, zb) in &p.boxes {
            let (r, za, zb) = (r / l, za / l, zb / l);
            let corners = [(-r, za), (r, za), (r, zb), (-r, zb), (-r, za)];
            // Dashes: each edge cut into 12 pieces, every other one drawn.
            let mut dashes = Vec::new();
            for e in corners.windows(2) {
                let (a, b) = (e[0], e[1]);
                for k in (0..12).step_by(2) {
                    let (t0, t1) = (k as f64 / 12.0, (k + 1) as f64 / 12.0);
                    let at = |t: f64| (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
                    dashes.push(PathElement::new(vec![at(t0), at(t1)], RED.stroke_width(2)));
                }
            }
            chart.draw_series(dashes).map_err(err)?;
        }
        Ok(())
    }
}

fn draw_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    (lo, hi): (f64, f64),
    label: &str,
) -> Result<()> {
    let hi = if hi > lo { hi } else { lo + 1.0 };
    let mut chart = ChartBuilder::on(area)
        .margin_top(36)
        .margin_bottom(56)
        .margin_right(8)
        .y_label_area_size(0)
        .right_y_label_area_size(84)
        .caption(label, (FONT, 18))
        .build_cartesian_2d(0.0..1.0, lo..hi)
        .map_err(err)?
        .set_secondary_coord(0.0..1.0, lo..hi);
    let n = 64;
    chart
        .draw_series((0..n).map(|k| {
            let a = lo + (hi - lo) * k as f64 / n as f64;
            let b = lo + (hi - lo) * (k + 1) as f64 / n as f64;
            Rectangle::new(
                [(0.0, a), (1.0, b)],
                viridis((k as f64 + 0.5) / n as f64).filled(),
            )
        }))
        .map_err(err)?;
    chart
        .configure_secondary_axes()
        .y_labels(5)
        .label_style((FONT, 18))
        .y_label_formatter(&|v| short_tick(*v))
        .draw()
        .map_err(err)?;
    Ok(())
}

fn short_tick(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let mag = v.abs().log10().floor();
    if !(-2.0..4.0).contains(&mag) {
        format!("{v:.1e}")
    } else {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

fn err<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow!("plotting failed: {e}")
}
