//! A small figure description (panels, axes, series) drawn with plotters into an SVG and a PNG
//! of the same figure. It owns layout, styling and the bundled font; it knows nothing about the
//! database or about any paper.

use std::path::{Path, PathBuf};

use anyhow::{anyhow, Context, Result};
use plotters::coord::Shift;
use plotters::prelude::*;

mod draw;

use draw::{draw_panel, plot_err};

pub(crate) use super::font::ensure_font;
use super::font::{FONT, FONT_BYTES};
use super::output::Output;
use super::raster::SupersampledPng;

/// Categorical colours (Tableau 10): distinguishable and readable on white.
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// How an axis maps values to positions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scale {
    /// Evenly spaced values.
    Linear,
    /// Evenly spaced decades; non-positive values are not drawn.
    Log,
}

/// Draws a figure of `size` pixels twice, into `<dir>/<stem>.svg` and `<dir>/<stem>.png` (one
/// drawing function per backend: plotters' backends are types), and returns the two paths.
///
/// # Errors
/// When the font cannot be loaded or a file cannot be drawn or written.
pub(super) fn write_svg_and_png(
    dir: &Path,
    stem: &str,
    size: (u32, u32),
    draw_svg: impl FnOnce(&DrawingArea<SVGBackend, Shift>) -> Result<()>,
    draw_png: impl FnOnce(&DrawingArea<SupersampledPng, Shift>) -> Result<()>,
) -> Result<Vec<PathBuf>> {
    ensure_font()?;
    let svg = dir.join(format!("{stem}.svg"));
    {
        let root = SVGBackend::new(&svg, size).into_drawing_area();
        draw_svg(&root).with_context(|| format!("drawing {}", svg.display()))?;
        root.present()
            .map_err(|e| anyhow!("writing {}: {e}", svg.display()))?;
    }
    let png = dir.join(format!("{stem}.png"));
    {
        let root = SupersampledPng::new(&png, size, FONT_BYTES).into_drawing_area();
        draw_png(&root).with_context(|| format!("drawing {}", png.display()))?;
        root.present()
            .map_err(|e| anyhow!("writing {}: {e}", png.display()))?;
    }
    Ok(vec![svg, png])
}

/// One axis of a panel.
#[derive(Debug, Clone)]
pub struct Axis {
    /// Text under (x) or beside (y) the axis, with the unit in parentheses.
    pub label: String,
    /// Linear or logarithmic.
    pub scale: Scale,
    /// Fixed (min, max); None fits the data with a margin.
    pub range: Option<(f64, f64)>,
}

impl Axis {
    /// A linear axis fitted to the data.
    pub fn linear(label: impl Into<String>) -> Self {
        Self {
            label: label.into(),
            scale: Scale::Linear,
            range: None,
        }
    }

    /// A logarithmic axis fitted to the positive data.
    pub fn log(label: impl Into<String>) -> Self {
        Self {
            label: label.into(),
            scale: Scale::Log,
            range: None,
        }
    }
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SeriesKind {
    /// Filled markers, with error bars when given.
    Points,
    /// A solid polyline through the points in order.
    Line,
    /// Crosses on the bottom edge of the plot at each x, for runs that have no value (a clogged
    /// run): seen, and never confused with a measured value. `y` is ignored.
    AxisMarks,
}

/// Marker shapes, so that series differ by more than colour (print in grey, colour blindness).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Marker {
    Circle,
    Square,
    TriangleUp,
    Diamond,
    TriangleDown,
    Cross,
}

impl Marker {
    /// The k-th shape of the cycle (series k of a panel gets shape k).
    pub fn nth(k: usize) -> Self {
        const CYCLE: [Marker; 5] = [
            Marker::Circle,
            Marker::Square,
            Marker::TriangleUp,
            Marker::Diamond,
            Marker::TriangleDown,
        ];
        CYCLE[k % CYCLE.len()]
    }

    /// The outline in pixels around (0, 0) for a marker of half-size `r`; None for the circle
    /// and the cross, which are drawn as such.
    fn polygon(self, r: i32) -> Option<Vec<(i32, i32)>> {
        Some(match self {
            Marker::Square => vec![(-r, -r), (r, -r), (r, r), (-r, r)],
            Marker::TriangleUp => vec![(0, -r - 1), (r + 1, r), (-r - 1, r)],
            Marker::TriangleDown => vec![(0, r + 1), (r + 1, -r), (-r - 1, -r)],
            Marker::Diamond => vec![(0, -r - 1), (r + 1, 0), (0, r + 1), (-r - 1, 0)],
            Marker::Circle | Marker::Cross => return None,
        })
    }
}

/// Half-size of a marker in pixels.
const MARKER_R: i32 = 5;

/// One marker of `shape` at pixel offset (0, 0), as an element placed with `EmptyElement::at`.
/// `dy` moves it down by that many pixels (up when negative).
fn marker_element<'a, DB: DrawingBackend + 'a, C: Clone + 'a>(
    at: C,
    shape: Marker,
    color: RGBColor,
    dy: i32,
) -> DynElement<'a, DB, C> {
    let r = MARKER_R;
    let o = |(x, y): (i32, i32)| (x, y + dy);
    match shape {
        Marker::Circle => {
            (EmptyElement::at(at) + Circle::new(o((0, 0)), r, color.filled())).into_dyn()
        }
        Marker::Cross => (EmptyElement::at(at)
            + PathElement::new(vec![o((-r, -r)), o((r, r))], color.stroke_width(3))
            + PathElement::new(vec![o((-r, r)), o((r, -r))], color.stroke_width(3)))
        .into_dyn(),
        s => {
            let pts: Vec<(i32, i32)> = s
                .polygon(r)
                .expect("a polygon")
                .into_iter()
                .map(o)
                .collect();
            (EmptyElement::at(at) + Polygon::new(pts, color.filled())).into_dyn()
        }
    }
}

/// A set of (x, y) points drawn in one style and colour.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text; None keeps the series out of the legend.
    pub label: Option<String>,
    /// Points or line.
    pub kind: SeriesKind,
    /// Index into the palette (wraps around).
    pub color: usize,
    /// Marker shape of `Points` (and of the legend entry of `AxisMarks`).
    pub marker: Marker,
    /// Abscissae.
    pub x: Vec<f64>,
    /// Ordinates, same length as `x`.
    pub y: Vec<f64>,
    /// Lengths of vertical error bars below and above each point, same length as `x`; None for
    /// no bars.
    pub y_err: Option<Vec<Option<(f64, f64)>>>,
    /// A short text beside each point of `Points` (e.g. "n=3", how many replicas it pools), same
    /// length as `x`; None (or a None entry) for no text.
    pub point_labels: Option<Vec<Option<String>>>,
}

impl Series {
    /// Markers at (x, y), shaped by the colour index (series k: colour k, shape k).
    pub fn points(label: Option<String>, color: usize, x: Vec<f64>, y: Vec<f64>) -> Self {
        Self {
            label,
            kind: SeriesKind::Points,
            color,
            marker: Marker::nth(color),
            x,
            y,
            y_err: None,
            point_labels: None,
        }
    }

    /// A line through (x, y).
    pub fn line(label: Option<String>, color: usize, x: Vec<f64>, y: Vec<f64>) -> Self {
        Self {
            label,
            kind: SeriesKind::Line,
            color,
            marker: Marker::nth(color),
            x,
            y,
            y_err: None,
            point_labels: None,
        }
    }

    /// Crosses at the bottom edge at each x, for runs without a value (see `SeriesKind`).
    /// `lane` lifts the crosses by that many marker heights so that several series sharing an
    /// x stay apart.
    pub fn axis_marks(label: Option<String>, color: usize, x: Vec<f64>, lane: usize) -> Self {
        let y = vec![lane as f64; x.len()];
        Self {
            label,
            kind: SeriesKind::AxisMarks,
            color,
            marker: Marker::Cross,
            x,
            y,
            y_err: None,
            point_labels: None,
        }
    }

    /// The same series with another marker shape.
    pub fn with_marker(mut self, marker: Marker) -> Self {
        self.marker = marker;
        self
    }

    /// Adds a short text beside each point (None: no text for that point).
    pub fn with_point_labels(mut self, labels: Vec<Option<String>>) -> Self {
        self.point_labels = Some(labels);
        self
    }

    /// Adds vertical error bars (half-widths; None for a point without one).
    pub fn with_errors(mut self, y_err: Vec<Option<f64>>) -> Self {
        self.y_err = Some(y_err.into_iter().map(|e| e.map(|e| (e, e))).collect());
        self
    }

    /// Adds vertical error bars from intervals (lo, hi) around each y (None: no bar), e.g. a
    /// bootstrap's percentiles, which need not be symmetric.
    pub fn with_intervals(mut self, intervals: Vec<Option<(f64, f64)>>) -> Self {
        let bars = intervals
            .into_iter()
            .zip(&self.y)
            .map(|(iv, &y)| iv.map(|(lo, hi)| ((y - lo).max(0.0), (hi - y).max(0.0))))
            .collect();
        self.y_err = Some(bars);
        self
    }

    /// The drawable points: finite, and positive on log axes. (x, y, bar below, bar above)
    fn visible(
        &self,
        x_scale: Scale,
        y_scale: Scale,
    ) -> impl Iterator<Item = (f64, f64, f64, f64)> + '_ {
        let n = if self.kind == SeriesKind::AxisMarks {
            0
        } else {
            self.x.len().min(self.y.len())
        };
        (0..n).filter_map(move |i| {
            let (x, y) = (self.x[i], self.y[i]);
            let (below, above) = self
                .y_err
                .as_ref()
                .and_then(|e| e.get(i).copied().flatten())
                .unwrap_or((0.0, 0.0));
            let ok = x.is_finite()
                && y.is_finite()
                && below.is_finite()
                && above.is_finite()
                && (x_scale == Scale::Linear || x > 0.0)
                && (y_scale == Scale::Linear || y > 0.0);
            ok.then_some((x, y, below.abs(), above.abs()))
        })
    }
}

/// Whether a panel shows its legend. A legend sits in a column right of the plot, never over
/// the data; the panel's notes follow it there.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Legend {
    /// No legend (notes are still shown).
    Hidden,
    /// Right of the plot.
    Outside,
}

/// One plot: two axes and the series drawn against them.
#[derive(Debug, Clone)]
pub struct Panel {
    /// Caption above the plot.
    pub title: Option<String>,
    /// Horizontal axis.
    pub x: Axis,
    /// Vertical axis.
    pub y: Axis,
    /// Drawn in order (later on top).
    pub series: Vec<Series>,
    /// Legend shown or not.
    pub legend: Legend,
    /// Lines of text beside the plot, under the legend: what the panel averages, a fit it
    /// refused, a parameter at its bound. Said in the figure, not only in the table.
    pub notes: Vec<String>,
}

impl Panel {
    /// An empty panel with the given axes and its legend beside it.
    pub fn new(x: Axis, y: Axis) -> Self {
        Self {
            title: None,
            x,
            y,
            series: Vec::new(),
            legend: Legend::Outside,
            notes: Vec::new(),
        }
    }

    fn legend_entries(&self) -> impl Iterator<Item = (&str, &Series)> {
        let shown = self.legend != Legend::Hidden;
        self.series
            .iter()
            .filter(move |_| shown)
            .filter_map(|s| s.label.as_deref().map(|l| (l, s)))
    }

    /// Width in pixels of the column beside the plot (0 when it has nothing to show), at most
    /// 45 % of the panel's `width`.
    fn side_width(&self, width: u32) -> u32 {
        let longest = self
            .legend_entries()
            .map(|(l, _)| l.chars().count() as u32 * SIDE_CHAR_PX + 56)
            .max();
        let w = match (longest, self.notes.is_empty()) {
            (None, true) => return 0,
            (Some(w), true) => w,
            (l, false) => l.unwrap_or(0).max(230),
        };
        w.clamp(120, width * 45 / 100)
    }
}

/// Font size of the legend and notes, and the width of one of their characters, in pixels.
/// plotters' font sizes are 1.24 em (the font's ascent to descent): every text of a figure is
/// at least 18, an em of 14.5 px.
const SIDE_FONT_PX: u32 = 18;
const SIDE_CHAR_PX: u32 = 10;

/// A grid of panels written as `<stem>.svg` and `<stem>.png`.
#[derive(Debug, Clone)]
pub struct Figure {
    /// Caption above all panels.
    pub title: Option<String>,
    /// Panels in reading order, filling rows of `columns`.
    pub panels: Vec<Panel>,
    /// Panels per row (at least 1).
    pub columns: usize,
    /// Size of one panel in pixels (width, height); the image is the grid of them.
    pub panel_size: (u32, u32),
}

impl Figure {
    /// Size of the whole image in pixels (width, height).
    pub fn size(&self) -> (u32, u32) {
        let cols = self.columns.clamp(1, self.panels.len().max(1));
        let rows = self.panels.len().max(1).div_ceil(cols);
        let title = if self.title.is_some() {
            TITLE_HEIGHT
        } else {
            0
        };
        // At least as wide as the title line (a single narrow panel would cut it off).
        let title_w = self
            .title
            .as_ref()
            .map_or(0, |t| t.chars().count() as u32 * TITLE_CHAR_PX + 40);
        (
            (self.panel_size.0 * cols as u32).max(title_w),
            self.panel_size.1 * rows as u32 + title,
        )
    }

    /// Writes `<dir>/<stem>.svg` and `<dir>/<stem>.png` and returns their paths.
    ///
    /// # Errors
    /// When the font cannot be loaded or a file cannot be written.
    pub fn write(&self, out: &Output, stem: &str) -> Result<Vec<PathBuf>> {
        if !out.titles && self.title.is_some() {
            let untitled = Figure {
                title: None,
                ..self.clone()
            };
            return untitled.write(out, stem);
        }
        write_svg_and_png(out, stem, self.size(), |r| self.draw(r), |r| self.draw(r))
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        root.fill(&WHITE).map_err(plot_err)?;
        let area = match &self.title {
            Some(t) => root
                .titled(t, (FONT, 26).into_font().color(&BLACK))
                .map_err(plot_err)?,
            None => root.clone(),
        };
        let cols = self.columns.clamp(1, self.panels.len().max(1));
        let rows = self.panels.len().max(1).div_ceil(cols);
        for (panel, cell) in self.panels.iter().zip(area.split_evenly((rows, cols))) {
            draw_panel(&cell, panel)?;
        }
        Ok(())
    }
}

const TITLE_HEIGHT: u32 = 40;
/// Width of one character of the title (size 26, an em of 21 px), with a margin, in pixels.
const TITLE_CHAR_PX: u32 = 13;
