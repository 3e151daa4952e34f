//! Curves drawn without plotters' rounding: SVG polylines in fractional pixels, PNG lines
//! segment by segment.
//!
//! plotters maps every point to a whole pixel, so its SVG polylines climb in stair steps,
//! and its wide bitmap paths join segments by intersecting their offset edges, which
//! folds over where a curve turns back on itself (a narrow specular peak): a detached
//! sliver is filled above the peak. Here the chart coordinates are mapped to fractional
//! pixels as plotters maps them, the SVG gets its own polylines (inserted where a
//! placeholder was drawn, so the drawing order is kept), and the PNG draws each segment
//! alone (no join to fold).

use plotters::coord::Shift;
use plotters::prelude::*;

/// The fill colour of the placeholder drawn where the SVG's curves go.
const PLACEHOLDER: RGBColor = RGBColor(1, 2, 3);

/// How a curve is stroked: colour, width in pixels and, for a dashed one, the dash and
/// gap lengths in pixels.
#[derive(Debug, Clone, Copy)]
pub(super) struct Pen {
    pub(super) color: RGBColor,
    pub(super) width: u32,
    pub(super) dash: Option<(u32, u32)>,
}

/// Chart coordinates (theta_r in degrees, a value on a log axis) to fractional backend
/// pixels: plotters' own linear map between the plotting area's corners, unrounded.
#[derive(Debug, Clone, Copy)]
pub(super) struct PixelMap {
    x: (f64, f64),
    ln_y: (f64, f64),
    px: (f64, f64),
    py: (f64, f64),
}

impl PixelMap {
    /// The map whose chart corners (x0, y0) and (x1, y1) land on the backend pixels
    /// `p0` and `p1` (as plotters places them).
    pub(super) fn new(
        (x0, y0): (f64, f64),
        (x1, y1): (f64, f64),
        p0: (i32, i32),
        p1: (i32, i32),
    ) -> Self {
        Self {
            x: (x0, x1),
            ln_y: (y0.ln(), y1.ln()),
            px: (f64::from(p0.0), f64::from(p1.0)),
            py: (f64::from(p0.1), f64::from(p1.1)),
        }
    }

    /// The backend pixel of the chart point `(x, y)` (y > 0).
    pub(super) fn at(&self, (x, y): (f64, f64)) -> (f64, f64) {
        let lerp =
            |v: f64, (a, b): (f64, f64), (pa, pb): (f64, f64)| pa + (v - a) / (b - a) * (pb - pa);
        (lerp(x, self.x, self.px), lerp(y.ln(), self.ln_y, self.py))
    }
}

/// Where the curves of a figure go: SVG elements collected as text, or drawn at once on
/// a bitmap's root area.
pub(super) enum Canvas<'a> {
    /// SVG: the polylines, inserted at the placeholder by [`insert_svg`].
    Svg(&'a mut String),
    /// PNG: drawn segment by segment on the root area.
    Bitmap,
}

/// Strokes the polyline `px` (backend pixels) with `pen`.
pub(super) fn stroke<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    canvas: &mut Canvas<'_>,
    px: &[(f64, f64)],
    pen: Pen,
) -> Result<(), String> {
    if px.len() < 2 {
        return Ok(());
    }
    match canvas {
        Canvas::Svg(out) => {
            let c = pen.color;
            out.push_str(&format!(
                "<polyline fill=\"none\" stroke=\"#{:02X}{:02X}{:02X}\" stroke-width=\"{}\" \
stroke-linejoin=\"round\"",
                c.0, c.1, c.2, pen.width
            ));
            if let Some((on, off)) = pen.dash {
                out.push_str(&format!(" stroke-dasharray=\"{on} {off}\""));
            }
            out.push_str(" points=\"");
            for (k, (x, y)) in px.iter().enumerate() {
                if k > 0 {
                    out.push(' ');
                }
                out.push_str(&format!("{},{}", round2(*x), round2(*y)));
            }
            out.push_str("\"/>\n");
            Ok(())
        }
        Canvas::Bitmap => {
            let pieces = match pen.dash {
                Some((on, off)) => dashes(px, f64::from(on), f64::from(off)),
                None => vec![px.to_vec()],
            };
            let style = pen.color.stroke_width(pen.width);
            for piece in pieces {
                for seg in segments(&piece) {
                    root.draw(&PathElement::new(seg.to_vec(), style))
                        .map_err(|e| e.to_string())?;
                }
            }
            Ok(())
        }
    }
}

/// A pixel coordinate to two decimals (a hundredth of a pixel is below any display's
/// resolution), without trailing zeros.
fn round2(v: f64) -> f64 {
    (v * 100.0).round() / 100.0
}

/// The whole-pixel segments of a polyline: points closer than a pixel to the last kept
/// one are passed over (the last point is always kept), and segments that round to a
/// single pixel are dropped.
pub(super) fn segments(px: &[(f64, f64)]) -> Vec<[(i32, i32); 2]> {
    let round = |p: (f64, f64)| (p.0.round() as i32, p.1.round() as i32);
    let mut out = Vec::new();
    let Some(&first) = px.first() else {
        return out;
    };
    let mut last = first;
    for (k, &p) in px.iter().enumerate().skip(1) {
        let end = k + 1 == px.len();
        if !end && (p.0 - last.0).hypot(p.1 - last.1) < 1.0 {
            continue;
        }
        let (a, b) = (round(last), round(p));
        if a != b {
            out.push([a, b]);
        }
        last = p;
    }
    out
}

/// The dashes of a polyline: pieces `on` pixels long (measured along it) separated by
/// gaps `off` pixels long, starting with a dash, as SVG's stroke-dasharray.
pub(super) fn dashes(px: &[(f64, f64)], on: f64, off: f64) -> Vec<Vec<(f64, f64)>> {
    let mut out = Vec::new();
    if px.len() < 2 || on <= 0.0 {
        return out;
    }
    let period = on + off.max(0.0);
    // Position within the pattern, in pixels from the start of a dash.
    let mut phase = 0.0f64;
    let mut piece = vec![px[0]];
    for w in px.windows(2) {
        let (a, b) = (w[0], w[1]);
        let len = (b.0 - a.0).hypot(b.1 - a.1);
        let mut t = 0.0f64;
        while t < len {
            let drawing = phase < on;
            let left = if drawing { on - phase } else { period - phase };
            let step = left.min(len - t);
            t += step;
            phase += step;
            let p = (a.0 + (b.0 - a.0) * t / len, a.1 + (b.1 - a.1) * t / len);
            if drawing {
                piece.push(p);
            }
            if phase >= on && drawing {
                // A dash ends here.
                out.push(std::mem::take(&mut piece));
            }
            if phase >= period {
                phase = 0.0;
                piece = vec![p];
            }
        }
    }
    if piece.len() > 1 {
        out.push(piece);
    }
    out.retain(|p| p.len() > 1);
    out
}

/// Draws the placeholder that [`insert_svg`] replaces with the SVG's curves.
pub(super) fn placeholder<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>) -> Result<(), String> {
    root.draw(&Rectangle::new([(0, 0), (1, 1)], PLACEHOLDER.filled()))
        .map_err(|e| e.to_string())
}

/// The SVG text `svg` with its placeholder element replaced by `curves`.
pub(super) fn insert_svg(svg: &str, curves: &str) -> Result<String, String> {
    let missing = || "the SVG has no place for its curves".to_string();
    let mark = svg.find("fill=\"#010203\"").ok_or_else(missing)?;
    let start = svg[..mark].rfind("<rect").ok_or_else(missing)?;
    let end = mark + svg[mark..].find("/>").ok_or_else(missing)? + 2;
    let end = end + usize::from(svg[end..].starts_with('\n'));
    Ok(format!("{}{}{}", &svg[..start], curves, &svg[end..]))
}
