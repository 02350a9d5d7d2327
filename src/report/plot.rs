//! A small figure description (panels, axes, series) drawn with plotters into an SVG and a PNG
//! of the same figure. It owns layout, styling and the bundled font; it knows nothing about the
//! database or about any paper.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use anyhow::{anyhow, Context, Result};
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::coord::Shift;
use plotters::prelude::*;

use super::drawn::Output;
use super::raster::SupersampledPng;

/// The font used for every text of a figure, bundled so PNGs need no system font.
const FONT_BYTES: &[u8] = include_bytes!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/DejaVuSans.ttf"
));
const FONT: &str = "sans-serif";

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
        }
    }

    /// The same series with another marker shape.
    pub fn with_marker(mut self, marker: Marker) -> Self {
        self.marker = marker;
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

/// Registers the bundled font with plotters once per process.
pub(crate) fn ensure_font() -> Result<()> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(FONT, FontStyle::Normal, FONT_BYTES).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(anyhow!(
            "the bundled font assets/DejaVuSans.ttf could not be loaded"
        ))
    }
}

fn plot_err<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow!("plotting failed: {e}")
}

/// The range of one axis: the fixed one, or the data's extent (with error bars) plus a margin.
fn axis_range(axis: &Axis, values: impl Iterator<Item = (f64, f64)>) -> (f64, f64) {
    if let Some((lo, hi)) = axis.range {
        return (lo, hi);
    }
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (a, b)| {
        (lo.min(a), hi.max(b))
    });
    match axis.scale {
        Scale::Linear => {
            if !lo.is_finite() {
                return (0.0, 1.0);
            }
            let span = if hi > lo {
                hi - lo
            } else {
                lo.abs().max(1e-12)
            };
            (lo - 0.05 * span, hi + 0.05 * span)
        }
        Scale::Log => {
            let lo = if lo.is_finite() && lo > 0.0 {
                lo
            } else {
                hi / 10.0
            };
            if !(lo.is_finite() && hi.is_finite() && lo > 0.0) {
                return (0.1, 10.0);
            }
            let ratio = if hi > lo { (hi / lo).powf(0.05) } else { 2.0 };
            (lo / ratio, hi * ratio)
        }
    }
}

/// Tick labels with about four significant digits, without trailing zeros.
fn tick_label(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return "0".into();
    }
    let mag = v.abs().log10().floor();
    if !(-3.0..5.0).contains(&mag) {
        return format!("{v:.1e}");
    }
    let decimals = (3.0 - mag).clamp(0.0, 7.0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// A linear-axis tick that is zero up to rounding (plotters may place one at −2.8e-17) as 0.
fn snap_zero(v: f64, scale: Scale, lo: f64, hi: f64) -> f64 {
    if scale == Scale::Linear && v.abs() <= 1e-9 * lo.abs().max(hi.abs()) {
        0.0
    } else {
        v
    }
}

/// Splits `text` into lines of at most `chars` characters at spaces.
fn wrap(text: &str, chars: usize) -> Vec<String> {
    let mut lines = Vec::new();
    let mut line = String::new();
    for word in text.split(' ') {
        if !line.is_empty() && line.chars().count() + 1 + word.chars().count() > chars {
            lines.push(std::mem::take(&mut line));
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(word);
    }
    if !line.is_empty() {
        lines.push(line);
    }
    lines
}

/// The legend (a sample of each labelled series and its text) and the notes, top down.
fn draw_side<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, panel: &Panel) -> Result<()> {
    let font = (FONT, SIDE_FONT_PX).into_font().color(&BLACK);
    let mut y = 48;
    for (label, s) in panel.legend_entries() {
        let color = PALETTE[s.color % PALETTE.len()];
        let c = (22, y);
        match s.kind {
            SeriesKind::Line => area
                .draw(&PathElement::new(
                    vec![(6, y), (38, y)],
                    color.stroke_width(3),
                ))
                .map_err(plot_err)?,
            SeriesKind::Points | SeriesKind::AxisMarks => area
                .draw(&marker_element::<DB, (i32, i32)>(c, s.marker, color, 0))
                .map_err(plot_err)?,
        }
        area.draw_text(label, &font, (46, y - SIDE_FONT_PX as i32 / 2 - 1))
            .map_err(plot_err)?;
        y += SIDE_FONT_PX as i32 + 10;
    }
    y += 8;
    let chars = (area.dim_in_pixel().0.saturating_sub(12) / SIDE_CHAR_PX).max(8) as usize;
    for note in &panel.notes {
        for line in wrap(note, chars) {
            area.draw_text(&line, &font, (8, y)).map_err(plot_err)?;
            y += SIDE_FONT_PX as i32 + 5;
        }
        y += 6;
    }
    Ok(())
}

fn draw_panel<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, panel: &Panel) -> Result<()> {
    let (w, _) = area.dim_in_pixel();
    let side = panel.side_width(w);
    let plot_area = if side > 0 {
        let (plot, beside) = area.split_horizontally(w - side);
        draw_side(&beside, panel)?;
        plot
    } else {
        area.clone()
    };
    let area = &plot_area;
    let (xs, ys) = (panel.x.scale, panel.y.scale);
    let pts = || panel.series.iter().flat_map(move |s| s.visible(xs, ys));
    // Runs without a value still widen the x axis: their crosses must be inside the plot.
    let marks = panel
        .series
        .iter()
        .filter(|s| s.kind == SeriesKind::AxisMarks)
        .flat_map(|s| s.x.iter().copied())
        .filter(|x| x.is_finite() && (xs == Scale::Linear || *x > 0.0));
    let (x0, x1) = axis_range(
        &panel.x,
        pts()
            .map(|(x, _, _, _)| (x, x))
            .chain(marks.map(|x| (x, x))),
    );
    let y_ext = |(_, y, below, above): (f64, f64, f64, f64)| {
        // On a log axis a bar reaching zero or below would stretch the axis without end.
        let lo = if ys == Scale::Log && y - below <= 0.0 {
            y
        } else {
            y - below
        };
        (lo, y + above)
    };
    let (y0, y1) = axis_range(&panel.y, pts().map(y_ext));
    match (xs, ys) {
        (Scale::Linear, Scale::Linear) => draw_in(area, panel, x0..x1, y0..y1),
        (Scale::Log, Scale::Linear) => draw_in(area, panel, (x0..x1).log_scale(), y0..y1),
        (Scale::Linear, Scale::Log) => draw_in(area, panel, x0..x1, (y0..y1).log_scale()),
        (Scale::Log, Scale::Log) => {
            draw_in(area, panel, (x0..x1).log_scale(), (y0..y1).log_scale())
        }
    }
}

/// Draws markers of one shape at `(coordinate, dy in pixels)` on a chart (one `draw_series` per
/// shape: plotters needs one element type per call).
macro_rules! draw_markers {
    ($chart:expr, $at:expr, $shape:expr, $color:expr) => {{
        let r = MARKER_R;
        let (color, at) = ($color, $at);
        match $shape {
            Marker::Circle => {
                $chart
                    .draw_series(at.iter().map(|&(c, dy)| {
                        EmptyElement::at(c) + Circle::new((0, dy), r, color.filled())
                    }))
                    .map_err(plot_err)?
            }
            Marker::Cross => $chart
                .draw_series(at.iter().map(|&(c, dy)| {
                    EmptyElement::at(c)
                        + PathElement::new(vec![(-r, dy - r), (r, dy + r)], color.stroke_width(3))
                        + PathElement::new(vec![(-r, dy + r), (r, dy - r)], color.stroke_width(3))
                }))
                .map_err(plot_err)?,
            shape => $chart
                .draw_series(at.iter().map(|&(c, dy)| {
                    let pts: Vec<(i32, i32)> = shape
                        .polygon(r)
                        .expect("a polygon")
                        .into_iter()
                        .map(|(x, y)| (x, y + dy))
                        .collect();
                    EmptyElement::at(c) + Polygon::new(pts, color.filled())
                }))
                .map_err(plot_err)?,
        };
    }};
}

fn draw_in<DB, X, Y>(area: &DrawingArea<DB, Shift>, panel: &Panel, x: X, y: Y) -> Result<()>
where
    DB: DrawingBackend,
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let mut builder = ChartBuilder::on(area);
    builder
        .margin(14)
        .x_label_area_size(64)
        .y_label_area_size(100);
    if let Some(t) = &panel.title {
        builder.caption(t, (FONT, 22));
    }
    let mut chart = builder.build_cartesian_2d(x, y).map_err(plot_err)?;
    let y_bottom = chart.y_range().start;
    let (xr, yr) = (chart.x_range(), chart.y_range());
    let x_fmt = |v: &f64| tick_label(snap_zero(*v, panel.x.scale, xr.start, xr.end));
    let y_fmt = |v: &f64| tick_label(snap_zero(*v, panel.y.scale, yr.start, yr.end));
    chart
        .configure_mesh()
        .x_desc(panel.x.label.as_str())
        .y_desc(panel.y.label.as_str())
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .label_style((FONT, 18))
        .axis_desc_style((FONT, 20))
        .light_line_style(RGBColor(235, 235, 235))
        .bold_line_style(RGBColor(205, 205, 205))
        .draw()
        .map_err(plot_err)?;

    let (xs, ys) = (panel.x.scale, panel.y.scale);
    for series in &panel.series {
        let color = PALETTE[series.color % PALETTE.len()];
        let pts: Vec<(f64, f64, f64, f64)> = series.visible(xs, ys).collect();
        match series.kind {
            SeriesKind::Line => {
                chart
                    .draw_series(LineSeries::new(
                        pts.iter().map(|&(x, y, _, _)| (x, y)),
                        color.stroke_width(3),
                    ))
                    .map_err(plot_err)?;
            }
            SeriesKind::AxisMarks => {
                let r = MARKER_R;
                let marks = series
                    .x
                    .iter()
                    .zip(&series.y)
                    .filter(|(x, _)| x.is_finite() && (xs == Scale::Linear || **x > 0.0));
                let at: Vec<((f64, f64), i32)> = marks
                    .map(|(&x, &lane)| ((x, y_bottom), -(r + 3) - lane as i32 * (2 * r + 4)))
                    .collect();
                draw_markers!(chart, at, series.marker, color);
            }
            SeriesKind::Points => {
                let has_bar = |p: &&(f64, f64, f64, f64)| p.2 > 0.0 || p.3 > 0.0;
                let bars = pts.iter().filter(has_bar).map(|&(x, y, below, above)| {
                    let lo = if ys == Scale::Log && y - below <= 0.0 {
                        y_bottom
                    } else {
                        y - below
                    };
                    PathElement::new(vec![(x, lo), (x, y + above)], color.stroke_width(2))
                });
                chart.draw_series(bars).map_err(plot_err)?;
                let caps = pts
                    .iter()
                    .filter(has_bar)
                    .flat_map(|&(x, y, below, above)| {
                        [y - below, y + above]
                            .into_iter()
                            .filter(|&v| ys == Scale::Linear || v > 0.0)
                            .map(move |v| {
                                EmptyElement::at((x, v))
                                    + PathElement::new(vec![(-5, 0), (5, 0)], color.stroke_width(2))
                            })
                    });
                chart.draw_series(caps).map_err(plot_err)?;
                let at: Vec<((f64, f64), i32)> =
                    pts.iter().map(|&(x, y, _, _)| ((x, y), 0)).collect();
                draw_markers!(chart, at, series.marker, color);
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(tick_label(0.30000000000000004), "0.3");
        assert_eq!(tick_label(12.5), "12.5");
        assert_eq!(tick_label(40.0), "40");
        assert_eq!(tick_label(0.0125), "0.0125");
        assert_eq!(tick_label(0.0), "0");
        assert_eq!(tick_label(2.5e-5), "2.5e-5");
        assert_eq!(snap_zero(-2.8e-17, Scale::Linear, -0.15, 0.15), 0.0);
        assert_eq!(snap_zero(1e-12, Scale::Log, 1e-13, 1.0), 1e-12);
        assert_eq!(snap_zero(2.5e-5, Scale::Linear, 0.0, 1e-4), 2.5e-5);
    }

    #[test]
    fn auto_range_includes_error_bars_and_margin() {
        let axis = Axis::linear("y");
        let (lo, hi) = axis_range(&axis, [(1.0, 3.0), (2.0, 5.0)].into_iter());
        assert!(lo < 1.0 && lo > 0.7 && hi > 5.0 && hi < 5.3, "{lo} {hi}");
        let (lo, hi) = axis_range(&Axis::log("y"), [(1e-3, 1e-3), (1.0, 1.0)].into_iter());
        assert!(lo < 1e-3 && lo > 5e-4 && hi > 1.0 && hi < 2.0, "{lo} {hi}");
        assert_eq!(
            axis_range(&Axis::linear("y"), std::iter::empty()),
            (0.0, 1.0)
        );
    }
}
