//! The PNG rasteriser: a plotters backend that draws every shape at `SUPERSAMPLE`× the image's
//! resolution and averages each block of pixels down, so lines, markers and text come out
//! antialiased (plotters' bitmap backend draws hard pixel edges). Text is drawn from the
//! bundled font's outlines with each glyph at its side bearing; plotters' own bitmap text
//! drops the bearing and spaces digits apart ("1 5 mm"). The layout (what plotters asks of
//! `get_size` and text sizes) stays at the image's resolution, so figures keep their geometry.

use std::path::Path;

use ab_glyph::{Font, FontRef, PxScale, ScaleFont};
use plotters::prelude::*;
use plotters_backend::text_anchor::{HPos, VPos};
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingErrorKind,
};

/// Samples per image pixel along each axis.
const SUPERSAMPLE: i32 = 3;

/// Where plotters' text sits: its layout box is size / 1.24 high; the baseline at 0.72 × size
/// centres capitals and digits in that box.
const BASELINE_OVER_SIZE: f32 = 0.72;

/// The fine canvas: RGB, `w × h` samples, white to start.
struct Fine {
    rgb: Vec<u8>,
    w: u32,
    h: u32,
}

impl DrawingBackend for Fine {
    type ErrorType = std::io::Error;

    fn get_size(&self) -> (u32, u32) {
        (self.w, self.h)
    }

    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        Ok(())
    }

    fn present(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        Ok(())
    }

    fn draw_pixel(
        &mut self,
        (x, y): BackendCoord,
        c: BackendColor,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        if x < 0 || y < 0 || x >= self.w as i32 || y >= self.h as i32 || c.alpha <= 0.0 {
            return Ok(());
        }
        let k = 3 * (y as usize * self.w as usize + x as usize);
        let a = c.alpha.min(1.0);
        for (i, v) in [c.rgb.0, c.rgb.1, c.rgb.2].into_iter().enumerate() {
            let old = f64::from(self.rgb[k + i]);
            self.rgb[k + i] = (old + a * (f64::from(v) - old)).round() as u8;
        }
        Ok(())
    }
}

/// A style whose strokes are `SUPERSAMPLE` times wider (the same width in the image).
struct Wider<'a, S>(&'a S);

impl<S: BackendStyle> BackendStyle for Wider<'_, S> {
    fn color(&self) -> BackendColor {
        self.0.color()
    }

    fn stroke_width(&self) -> u32 {
        self.0.stroke_width() * SUPERSAMPLE as u32
    }
}

/// The backend: image-sized to plotters, fine underneath; `present` writes the PNG.
pub(crate) struct SupersampledPng<'a> {
    path: &'a Path,
    size: (u32, u32),
    fine: Fine,
    font: FontRef<'static>,
}

impl<'a> SupersampledPng<'a> {
    /// A white image of `size` pixels to be written to `path`, with text in `font` (TTF bytes).
    pub(crate) fn new(path: &'a Path, size: (u32, u32), font: &'static [u8]) -> Self {
        let (w, h) = (size.0 * SUPERSAMPLE as u32, size.1 * SUPERSAMPLE as u32);
        Self {
            path,
            size,
            fine: Fine {
                rgb: vec![255; 3 * w as usize * h as usize],
                w,
                h,
            },
            font: FontRef::try_from_slice(font).expect("the bundled font parses"),
        }
    }

    /// The image: each pixel the mean of its SUPERSAMPLE² samples.
    fn downsampled(&self) -> Vec<u8> {
        let (w, h) = self.size;
        let s = SUPERSAMPLE as usize;
        let fw = self.fine.w as usize;
        let mut out = vec![0u8; 3 * w as usize * h as usize];
        for y in 0..h as usize {
            for x in 0..w as usize {
                for c in 0..3 {
                    let mut sum = 0u32;
                    for dy in 0..s {
                        for dx in 0..s {
                            sum +=
                                u32::from(self.fine.rgb[3 * ((y * s + dy) * fw + x * s + dx) + c]);
                        }
                    }
                    out[3 * (y * w as usize + x) + c] =
                        ((sum + (s * s / 2) as u32) / (s * s) as u32) as u8;
                }
            }
        }
        out
    }
}

fn fine((x, y): BackendCoord) -> BackendCoord {
    (
        x * SUPERSAMPLE + SUPERSAMPLE / 2,
        y * SUPERSAMPLE + SUPERSAMPLE / 2,
    )
}

fn io<E: std::fmt::Display>(e: E) -> DrawingErrorKind<std::io::Error> {
    DrawingErrorKind::DrawingError(std::io::Error::other(e.to_string()))
}

impl DrawingBackend for SupersampledPng<'_> {
    type ErrorType = std::io::Error;

    fn get_size(&self) -> (u32, u32) {
        self.size
    }

    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        Ok(())
    }

    fn present(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        let image = self.downsampled();
        let mut png = BitMapBackend::new(self.path, self.size);
        png.blit_bitmap((0, 0), self.size, &image).map_err(io)?;
        png.present().map_err(io)
    }

    fn draw_pixel(
        &mut self,
        (x, y): BackendCoord,
        c: BackendColor,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        for dy in 0..SUPERSAMPLE {
            for dx in 0..SUPERSAMPLE {
                self.fine
                    .draw_pixel((x * SUPERSAMPLE + dx, y * SUPERSAMPLE + dy), c)?;
            }
        }
        Ok(())
    }

    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        // A line of width w is a band of w × SUPERSAMPLE samples: drawn as a path so the fine
        // canvas polygonises it.
        self.fine.draw_path([fine(from), fine(to)], &Wider(style))
    }

    fn draw_rect<S: BackendStyle>(
        &mut self,
        (x0, y0): BackendCoord,
        (x1, y1): BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        let s = SUPERSAMPLE;
        if fill {
            // Cover whole image pixels, as the plain backend does.
            return self.fine.draw_rect(
                (x0 * s, y0 * s),
                (x1 * s + s - 1, y1 * s + s - 1),
                style,
                true,
            );
        }
        let c = [
            fine((x0, y0)),
            fine((x1, y0)),
            fine((x1, y1)),
            fine((x0, y1)),
            fine((x0, y0)),
        ];
        self.fine.draw_path(c, &Wider(style))
    }

    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        let pts: Vec<BackendCoord> = path.into_iter().map(fine).collect();
        self.fine.draw_path(pts, &Wider(style))
    }

    fn draw_circle<S: BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.fine.draw_circle(
            fine(center),
            radius * SUPERSAMPLE as u32,
            &Wider(style),
            fill,
        )
    }

    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        let pts: Vec<BackendCoord> = vert.into_iter().map(fine).collect();
        self.fine.fill_polygon(pts, style)
    }

    fn draw_text<T: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &T,
        pos: BackendCoord,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        // Anchor as plotters does, from its layout box in image pixels.
        let ((min_x, min_y), (max_x, max_y)) = style
            .layout_box(text)
            .map_err(|e| DrawingErrorKind::FontError(Box::new(e)))?;
        let (width, height) = (max_x - min_x, max_y - min_y);
        let dx = match style.anchor().h_pos {
            HPos::Left => 0,
            HPos::Right => -width,
            HPos::Center => -width / 2,
        };
        let dy = match style.anchor().v_pos {
            VPos::Top => 0,
            VPos::Center => -height / 2,
            VPos::Bottom => -height,
        };
        let s = SUPERSAMPLE as f32;
        let size = style.size() as f32 * s;
        let font = self.font.as_scaled(PxScale::from(size));
        let baseline = BASELINE_OVER_SIZE * size;
        let transform = style.transform();
        let origin = (pos.0 * SUPERSAMPLE, pos.1 * SUPERSAMPLE);
        let (off_x, off_y) = ((dx - min_x) * SUPERSAMPLE, (dy - min_y) * SUPERSAMPLE);
        let mut pen = 0.0f32;
        let mut prev = None;
        for ch in text.chars() {
            let id = font.glyph_id(ch);
            if let Some(p) = prev {
                pen += font.kern(p, id);
            }
            prev = Some(id);
            let glyph = id.with_scale_and_position(size, ab_glyph::point(pen, baseline));
            pen += font.h_advance(id);
            let Some(outline) = self.font.outline_glyph(glyph) else {
                continue;
            };
            let bounds = outline.px_bounds();
            let fine = &mut self.fine;
            outline.draw(|gx, gy, coverage| {
                if coverage <= 0.0 {
                    return;
                }
                let tx = bounds.min.x as i32 + gx as i32 + off_x;
                let ty = bounds.min.y as i32 + gy as i32 + off_y;
                let (rx, ry) = transform.transform(tx, ty);
                let c = BackendColor {
                    alpha: color.alpha * f64::from(coverage.min(1.0)),
                    rgb: color.rgb,
                };
                // The fine canvas clips and never fails.
                let _ = fine.draw_pixel((origin.0 + rx, origin.1 + ry), c);
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::font::ensure_font;

    /// The first column (in image pixels) with ink in the fine canvas.
    fn first_ink_column(b: &SupersampledPng) -> Option<usize> {
        let w = b.fine.w as usize;
        (0..w)
            .find(|&x| (0..b.fine.h as usize).any(|y| b.fine.rgb[3 * (y * w + x)] < 128))
            .map(|x| x / SUPERSAMPLE as usize)
    }

    #[test]
    fn text_keeps_each_glyph_at_its_side_bearing() {
        ensure_font().expect("font");
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("t.png");
        let font_bytes: &'static [u8] = include_bytes!(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/assets/DejaVuSans.ttf"
        ));
        let mut b = SupersampledPng::new(&path, (300, 150), font_bytes);
        let style = TextStyle::from(("sans-serif", 100).into_font()).color(&BLACK);
        b.draw_text("1", &style, (0, 0)).expect("draw");
        // DejaVu's "1" starts 0.11 em right of the pen (its left side bearing): at size 100
        // (an em of 86 px) about 9 px; plotters' own bitmap text puts its ink at 0.
        let font = FontRef::try_from_slice(font_bytes).expect("font");
        let scaled = font.as_scaled(PxScale::from(100.0));
        let bearing = scaled.h_side_bearing(font.glyph_id('1'));
        let first = first_ink_column(&b).expect("ink") as f32;
        assert!(bearing > 5.0, "{bearing}");
        assert!(
            (first - bearing).abs() <= 1.5,
            "ink at {first}, bearing {bearing}"
        );
        // What plotters' bitmap backend does with the same text (the bug this file avoids).
        let mut buf = vec![255u8; 3 * 300 * 150];
        {
            let mut plain = BitMapBackend::with_buffer(&mut buf, (300, 150));
            plain.draw_text("1", &style, (0, 0)).expect("draw");
            plain.present().expect("present");
        }
        let plain_first = (0..300usize)
            .find(|&x| (0..150usize).any(|y| buf[3 * (y * 300 + x)] < 128))
            .expect("ink") as f32;
        assert!(
            plain_first < bearing - 4.0,
            "plotters: ink at {plain_first}"
        );
        // Antialiased: the edge of the glyph has grey pixels, not only black and white.
        b.present().expect("png");
        let greys = b
            .downsampled()
            .iter()
            .filter(|&&v| v > 40 && v < 215)
            .count();
        assert!(greys > 20, "{greys} grey samples");
    }
}
