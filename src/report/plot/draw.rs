//! Drawing a figure's panels with plotters: axis ranges and tick labels, the side column of
//! legends and notes, and the panel itself (`Figure` in `mod.rs` lays the panels out).

use anyhow::{anyhow, Result};
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::coord::Shift;
use plotters::prelude::*;

use super::*;

pub(super) fn plot_err<E: std::fmt::Display>(e: E) -> anyhow::Error {
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
            if hi - lo <= 1e-9 * lo.abs().max(hi.abs()) {
                // One value (a single frequency, say): centre it in a range of its own size,
                // or of 1 around zero, rather than in a sliver of round-off.
                let half = if lo == 0.0 { 0.5 } else { 0.5 * lo.abs() };
                return (lo - half, hi + half);
            }
            let span = hi - lo;
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

pub(super) fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    panel: &Panel,
) -> Result<()> {
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

/// Font size of the texts beside points (see `Series::point_labels`).
const POINT_LABEL_PX: u32 = 18;

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
                // Texts beside the markers (up and right, clear of the error bar).
                let font = (FONT, POINT_LABEL_PX).into_font().color(&color);
                let texts =
                    series
                        .point_labels
                        .iter()
                        .flatten()
                        .enumerate()
                        .filter_map(|(i, label)| {
                            let (x, y) = (*series.x.get(i)?, *series.y.get(i)?);
                            let ok = x.is_finite()
                                && y.is_finite()
                                && (xs == Scale::Linear || x > 0.0)
                                && (ys == Scale::Linear || y > 0.0);
                            let label = label.as_deref().filter(|_| ok)?;
                            Some(
                                EmptyElement::at((x, y))
                                    + Text::new(
                                        label.to_string(),
                                        (MARKER_R + 3, -22),
                                        font.clone(),
                                    ),
                            )
                        });
                chart.draw_series(texts).map_err(plot_err)?;
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
        let one_at_zero = axis_range(&Axis::linear("f"), [(0.0, 0.0)].into_iter());
        assert_eq!(one_at_zero, (-0.5, 0.5));
        let one_at_five = axis_range(&Axis::linear("f"), [(5.0, 5.0)].into_iter());
        assert_eq!(one_at_five, (2.5, 7.5));
        let round_off = axis_range(
            &Axis::linear("f"),
            [(0.3, 0.3), (0.1 + 0.2, 0.1 + 0.2)].into_iter(),
        );
        assert!(round_off.1 - round_off.0 > 0.2, "{round_off:?}");
    }
}
