//! PNG figures of the iteration: the cross-section depth profile of every iterate, from the
//! shallow raw reconstruction to the deep compensated one (the classic figure of Nayar,
//! Ikeuchi & Kanade), and the convergence of the change and the depth of the concavity.
//!
//! Lines are drawn with `plotters` (bitmap backend); labels with a built-in 5×7 font
//! ([`font`]); the RGB buffer is encoded as PNG in memory.

pub mod font;

use super::nik::NikOutput;
use crate::error::{Error, Result};
use crate::image::{DepthMap, Mask};
use plotters::prelude::*;

/// One curve of a line plot.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// (x, y) points in data units; non-finite points break the line.
    pub points: Vec<(f64, f64)>,
    /// RGB colour.
    pub color: [u8; 3],
    /// Line width in pixels.
    pub width: u32,
}

/// A line plot with axes, ticks, title and legend, encoded as PNG.
#[derive(Clone, Debug)]
pub struct LinePlot {
    /// Title above the plot.
    pub title: String,
    /// Label of the horizontal axis.
    pub x_label: String,
    /// Label of the vertical axis.
    pub y_label: String,
    /// The curves.
    pub series: Vec<Series>,
    /// Image size in pixels.
    pub size: (usize, usize),
}

const LEFT: usize = 80;
const BOTTOM: usize = 50;
const TOP: usize = 40;
const RIGHT: usize = 20;

impl LinePlot {
    /// Render to PNG bytes.
    pub fn to_png(&self) -> Result<Vec<u8>> {
        let (w, h) = self.size;
        let pts = self.series.iter().flat_map(|s| s.points.iter());
        let finite: Vec<(f64, f64)> = pts
            .filter(|p| p.0.is_finite() && p.1.is_finite())
            .copied()
            .collect();
        if finite.is_empty() || w < LEFT + RIGHT + 50 || h < TOP + BOTTOM + 50 {
            return Err(Error::invalid(
                format!("plot `{}`", self.title),
                "give at least one finite point and a size of at least 200×150",
            ));
        }
        let (x0, x1) = padded(finite.iter().map(|p| p.0));
        let (y0, y1) = padded(finite.iter().map(|p| p.1));
        let mut buf = vec![255u8; w * h * 3];
        let mut texts: Vec<((i64, i64), String, usize)> = Vec::new();
        draw_lines(self, &mut buf, (x0, x1, y0, y1), &mut texts).map_err(|e| {
            Error::invalid(
                format!("plot `{}`", self.title),
                format!("drawing failed: {e}"),
            )
        })?;
        for ((x, y), t, scale) in texts {
            font::draw_text(&mut buf, (w, h), (x, y), &t, scale, [20, 20, 20]);
        }
        encode_png(&buf, w, h)
    }
}

fn draw_lines(
    plot: &LinePlot,
    buf: &mut [u8],
    (x0, x1, y0, y1): (f64, f64, f64, f64),
    texts: &mut Vec<((i64, i64), String, usize)>,
) -> std::result::Result<(), String> {
    let (w, h) = plot.size;
    let err = |e: &dyn std::fmt::Debug| format!("{e:?}");
    let root = BitMapBackend::with_buffer(buf, (w as u32, h as u32)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let mut chart = ChartBuilder::on(&root)
        .margin_top(TOP as u32)
        .margin_right(RIGHT as u32)
        .set_label_area_size(LabelAreaPosition::Left, LEFT as u32)
        .set_label_area_size(LabelAreaPosition::Bottom, BOTTOM as u32)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| err(&e))?;
    let grey = RGBColor(200, 200, 200);
    let black = RGBColor(0, 0, 0);
    for t in nice_ticks(x0, x1) {
        let (px, py) = chart.backend_coord(&(t, y0));
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(t, y0), (t, y1)],
                grey,
            )))
            .map_err(|e| err(&e))?;
        let s = fmt_tick(t);
        texts.push((
            (
                px as i64 - font::text_width(&s, 2) as i64 / 2,
                py as i64 + 8,
            ),
            s,
            2,
        ));
    }
    for t in nice_ticks(y0, y1) {
        let (px, py) = chart.backend_coord(&(x0, t));
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(x0, t), (x1, t)],
                grey,
            )))
            .map_err(|e| err(&e))?;
        let s = fmt_tick(t);
        texts.push((
            (
                px as i64 - font::text_width(&s, 2) as i64 - 6,
                py as i64 - 7,
            ),
            s,
            2,
        ));
    }
    let frame = vec![(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)];
    chart
        .draw_series(std::iter::once(PathElement::new(frame, black)))
        .map_err(|e| err(&e))?;
    for s in &plot.series {
        let style = RGBColor(s.color[0], s.color[1], s.color[2]).stroke_width(s.width);
        for run in s.points.split(|p| !(p.0.is_finite() && p.1.is_finite())) {
            if run.len() > 1 {
                chart
                    .draw_series(LineSeries::new(run.iter().copied(), style))
                    .map_err(|e| err(&e))?;
            }
        }
    }
    legend(plot, &root, texts)?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;

fn legend(
    plot: &LinePlot,
    root: &Area<'_>,
    texts: &mut Vec<((i64, i64), String, usize)>,
) -> std::result::Result<(), String> {
    let (w, h) = plot.size;
    texts.push(((LEFT as i64, 10), plot.title.clone(), 2));
    let xl = &plot.x_label;
    let xw = font::text_width(xl, 2) as i64;
    texts.push((
        ((LEFT + w) as i64 / 2 - xw / 2, h as i64 - 20),
        xl.clone(),
        2,
    ));
    texts.push(((4, TOP as i64 - 14), plot.y_label.clone(), 1));
    let lw = plot
        .series
        .iter()
        .map(|s| font::text_width(&s.label, 1))
        .max()
        .unwrap_or(0);
    let x = (w - RIGHT - lw - 40) as i32;
    for (i, s) in plot.series.iter().enumerate() {
        let y = (TOP + 12 + 12 * i) as i32;
        let c = RGBColor(s.color[0], s.color[1], s.color[2]).stroke_width(s.width.max(2));
        root.draw(&PathElement::new(vec![(x, y), (x + 24, y)], c))
            .map_err(|e| format!("{e:?}"))?;
        texts.push((((x + 30) as i64, y as i64 - 3), s.label.clone(), 1));
    }
    Ok(())
}

fn padded(v: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |a, x| {
        (a.0.min(x), a.1.max(x))
    });
    let pad = ((hi - lo) * 0.05).max(1e-9);
    (lo - pad, hi + pad)
}

/// About five round tick values in [lo, hi].
pub fn nice_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let span = (hi - lo).max(1e-12);
    let raw = span / 5.0;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| span / s <= 6.0)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last).map(|i| i as f64 * step).collect()
}

fn fmt_tick(t: f64) -> String {
    let a = t.abs();
    if a == 0.0 {
        "0".into()
    } else if !(0.01..1000.0).contains(&a) {
        format!("{t:.0e}")
    } else if (t - t.round()).abs() < 1e-9 {
        format!("{t:.0}")
    } else if a >= 1.0 {
        format!("{t:.1}")
    } else {
        format!("{t:.2}")
    }
}

fn encode_png(rgb: &[u8], w: usize, h: usize) -> Result<Vec<u8>> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(rgb, w as u32, h as u32, image::ExtendedColorType::Rgb8)
        .map_err(|e| Error::invalid("profile plot", format!("PNG encoding failed: {e}")))?;
    Ok(out)
}

/// Colour of iterate `t` of `n`: light blue (shallow, raw) to dark blue (last).
fn iterate_color(t: usize, n: usize) -> [u8; 3] {
    let s = if n <= 1 {
        1.0
    } else {
        t as f64 / (n - 1) as f64
    };
    let lerp = |a: f64, b: f64| (a + (b - a) * s).round() as u8;
    [lerp(150.0, 10.0), lerp(200.0, 40.0), lerp(250.0, 140.0)]
}

/// The row through the middle of the mask's bounding box (None when the mask is empty).
pub fn middle_row(mask: &Mask) -> Option<usize> {
    let rows: Vec<usize> = (0..mask.height)
        .filter(|&r| (0..mask.width).any(|c| *mask.get(r, c)))
        .collect();
    Some((rows.first()? + rows.last()?) / 2)
}

fn profile(depth: &DepthMap, mask: &Mask, row: usize) -> Vec<(f64, f64)> {
    let pts: Vec<(f64, f64)> = (0..depth.width)
        .map(|c| {
            let z = *depth.get(row, c);
            let ok = *mask.get(row, c) && z.is_finite();
            (c as f64, if ok { z as f64 } else { f64::NAN })
        })
        .collect();
    // Align the rims: the highest point of the section at 0.
    let top = pts
        .iter()
        .map(|p| p.1)
        .filter(|z| z.is_finite())
        .fold(f64::NEG_INFINITY, f64::max);
    pts.into_iter().map(|(x, z)| (x, z - top)).collect()
}

/// Cross-section of every iterate's depth along image row `row` (each aligned so that its
/// highest point is 0), plus the truth when given, as a PNG of 800×500.
pub fn profile_plot_png(
    out: &NikOutput,
    mask: &Mask,
    row: usize,
    truth: Option<&DepthMap>,
) -> Result<Vec<u8>> {
    if row >= mask.height {
        return Err(Error::invalid(
            format!("profile row {row} of a {}-row image", mask.height),
            "choose a row inside the image",
        ));
    }
    let n = out.iterations.len();
    let mut series: Vec<Series> = out
        .iterations
        .iter()
        .enumerate()
        .map(|(t, it)| Series {
            label: if t == 0 {
                "iter 0 (raw)".into()
            } else {
                format!("iter {t}")
            },
            points: profile(&it.shape.depth, mask, row),
            color: iterate_color(t, n),
            width: if t == out.best { 3 } else { 1 },
        })
        .collect();
    if let Some(z) = truth {
        series.push(Series {
            label: "truth".into(),
            points: profile(z, mask, row),
            color: [220, 30, 30],
            width: 2,
        });
    }
    LinePlot {
        title: format!("Depth profile, row {row}: shallow (raw) to deep"),
        x_label: "column (px)".into(),
        y_label: "depth (px)".into(),
        series,
        size: (800, 500),
    }
    .to_png()
}

/// Convergence: the relative change per iteration and the depth of the concavity relative to
/// the last iterate's, as a PNG of 800×400.
pub fn convergence_plot_png(out: &NikOutput) -> Result<Vec<u8>> {
    let last = out
        .iterations
        .last()
        .map_or(1.0, |i| i.depth_range as f64)
        .max(1e-9);
    let change = out
        .iterations
        .iter()
        .enumerate()
        .skip(1)
        .map(|(t, i)| (t as f64, i.relative_change as f64))
        .collect();
    let range = out
        .iterations
        .iter()
        .enumerate()
        .map(|(t, i)| (t as f64, i.depth_range as f64 / last))
        .collect();
    LinePlot {
        title: "Convergence".into(),
        x_label: "iteration".into(),
        y_label: "relative value".into(),
        series: vec![
            Series {
                label: "mean change / depth range".into(),
                points: change,
                color: [30, 60, 200],
                width: 2,
            },
            Series {
                label: "depth range / final".into(),
                points: range,
                color: [200, 100, 20],
                width: 2,
            },
        ],
        size: (800, 400),
    }
    .to_png()
}
