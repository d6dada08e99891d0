//! PNG figures of the iteration: the cross-section depth profile of every iterate, from the
//! shallow raw reconstruction to the deep compensated one (the classic figure of Nayar,
//! Ikeuchi & Kanade), and the convergence of the change (log axis, with the tolerance
//! drawn) and of the depth of the concavity.
//!
//! Drawn with `plotters` (bitmap backend). Text is set in DejaVu Sans, embedded in the
//! library (`assets/fonts/DejaVuSans.ttf`, licence beside it) and rendered through
//! plotters' `ab_glyph` backend, so the plots look the same on every machine. Legends sit
//! to the right of the data area, never over the curves.

use super::nik::NikOutput;
use crate::error::{Error, Result};
use crate::image::{DepthMap, Mask};
use crate::picture::{png_bytes, Deflate};
use plotters::coord::ranged1d::ValueFormatter;
use plotters::prelude::*;
use std::sync::OnceLock;

/// DejaVu Sans (Bitstream Vera licence: `assets/fonts/LICENSE-DejaVu.txt`).
const FONT_TTF: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");
/// Family name the embedded font is registered under.
const FAMILY: &str = "sans-serif";

/// Register the embedded font with plotters once; every later call returns the first result.
fn ensure_font() -> Result<()> {
    static DONE: OnceLock<bool> = OnceLock::new();
    let ok = *DONE.get_or_init(|| {
        plotters::style::register_font(FAMILY, FontStyle::Normal, FONT_TTF).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(Error::invalid(
            "the embedded plot font",
            "rebuild the library (assets/fonts/DejaVuSans.ttf is not a valid TrueType font)",
        ))
    }
}

/// One curve of a line plot.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// (x, y) points in data units; non-finite points (and y ≤ 0 on a log axis) break the line.
    pub points: Vec<(f64, f64)>,
    /// RGB colour.
    pub color: [u8; 3],
    /// Line width in pixels.
    pub width: u32,
}

/// A horizontal reference line (e.g. a tolerance), dashed, with its own legend entry.
#[derive(Clone, Debug)]
pub struct RefLine {
    /// Legend text.
    pub label: String,
    /// Height in data units.
    pub y: f64,
    /// RGB colour.
    pub color: [u8; 3],
}

/// A line plot with axes, ticks, title and a legend to the right of the data.
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
    /// Dashed horizontal reference lines.
    pub ref_lines: Vec<RefLine>,
    /// Logarithmic vertical axis.
    pub y_log: bool,
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;

impl LinePlot {
    /// Render alone to PNG bytes of `size` pixels.
    pub fn to_png(&self, size: (usize, usize)) -> Result<Vec<u8>> {
        render_png(size, |root| self.draw(root))
    }

    /// Draw into an area (a whole figure or one panel of it).
    fn draw(&self, area: &Area<'_>) -> Result<()> {
        let fail = |e: &dyn std::fmt::Debug| {
            Error::invalid(
                format!("plot `{}`", self.title),
                format!("drawing failed: {e:?}"),
            )
        };
        let pts = || {
            self.series
                .iter()
                .flat_map(|s| s.points.iter())
                .copied()
                .filter(|p| self.usable(*p))
        };
        if pts().next().is_none() {
            return Err(Error::invalid(
                format!("plot `{}`", self.title),
                "give at least one finite point (positive on a log axis)",
            ));
        }
        let (x0, x1) = padded(pts().map(|p| p.0), false);
        let refs = self.ref_lines.iter().map(|r| r.y).filter(|y| y.is_finite());
        let (y0, y1) = padded(pts().map(|p| p.1).chain(refs), self.y_log);
        let (w, h) = area.dim_in_pixel();
        let legend_w = self.legend_width(area).min(w / 3);
        let (plot_area, legend_area) = area.split_horizontally(w - legend_w);
        let mut chart = ChartBuilder::on(&plot_area);
        chart
            .caption(&self.title, (FAMILY, 18))
            .margin(8)
            .x_label_area_size(40)
            .y_label_area_size(62);
        let _ = h;
        let style = |s: &Series| RGBColor(s.color[0], s.color[1], s.color[2]).stroke_width(s.width);
        if self.y_log {
            let mut c = chart
                .build_cartesian_2d(x0..x1, (y0..y1).log_scale())
                .map_err(|e| fail(&e))?;
            self.mesh(&mut c).map_err(|e| fail(&e))?;
            for s in &self.series {
                for run in s.points.split(|p| !self.usable(*p)).filter(|r| r.len() > 1) {
                    c.draw_series(LineSeries::new(run.iter().copied(), style(s)))
                        .map_err(|e| fail(&e))?;
                }
            }
            self.draw_refs(&mut c, x0, x1).map_err(|e| fail(&e))?;
        } else {
            let mut c = chart
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(|e| fail(&e))?;
            self.mesh(&mut c).map_err(|e| fail(&e))?;
            for s in &self.series {
                for run in s.points.split(|p| !self.usable(*p)).filter(|r| r.len() > 1) {
                    c.draw_series(LineSeries::new(run.iter().copied(), style(s)))
                        .map_err(|e| fail(&e))?;
                }
            }
            self.draw_refs(&mut c, x0, x1).map_err(|e| fail(&e))?;
        }
        self.legend(&legend_area).map_err(|e| fail(&e))
    }

    fn usable(&self, p: (f64, f64)) -> bool {
        p.0.is_finite() && p.1.is_finite() && (!self.y_log || p.1 > 0.0)
    }

    /// Grid, ticks and axis labels; tick labels of one axis share one format.
    fn mesh<'a, Y>(
        &self,
        c: &mut ChartContext<
            'a,
            BitMapBackend<'a>,
            Cartesian2d<plotters::coord::types::RangedCoordf64, Y>,
        >,
    ) -> std::result::Result<(), String>
    where
        Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
    {
        let xr = c.x_range();
        let yr = c.y_range();
        // Whole-number x (iterations): one tick per integer, no decimals.
        let integer_x = self
            .series
            .iter()
            .flat_map(|s| s.points.iter())
            .all(|p| !p.0.is_finite() || p.0.fract() == 0.0)
            && xr.end - xr.start <= 30.0;
        let (x_dec, x_ticks) = if integer_x {
            (0, (xr.end - xr.start).floor() as usize + 1)
        } else {
            (decimals(xr.end - xr.start), 10)
        };
        let y_dec = decimals(yr.end - yr.start);
        let y_log = self.y_log;
        // A log axis spans whole decades: one labelled tick per decade.
        let y_ticks = if y_log {
            (yr.end / yr.start).log10().round() as usize + 1
        } else {
            10
        };
        c.configure_mesh()
            .x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .x_labels(x_ticks)
            .y_labels(y_ticks)
            .axis_desc_style((FAMILY, 15))
            .label_style((FAMILY, 13))
            .light_line_style(TRANSPARENT)
            .bold_line_style(RGBColor(215, 215, 215))
            .x_label_formatter(&|v| format!("{v:.x_dec$}"))
            .y_label_formatter(&|v| {
                if y_log {
                    log_tick(*v)
                } else {
                    format!("{v:.y_dec$}")
                }
            })
            .draw()
            .map_err(|e| format!("{e:?}"))
    }

    fn draw_refs<'a, Y>(
        &self,
        c: &mut ChartContext<
            'a,
            BitMapBackend<'a>,
            Cartesian2d<plotters::coord::types::RangedCoordf64, Y>,
        >,
        x0: f64,
        x1: f64,
    ) -> std::result::Result<(), String>
    where
        Y: Ranged<ValueType = f64>,
    {
        for r in &self.ref_lines {
            let style = RGBColor(r.color[0], r.color[1], r.color[2]).stroke_width(2);
            c.draw_series(DashedLineSeries::new(
                vec![(x0, r.y), (x1, r.y)],
                10,
                6,
                style,
            ))
            .map_err(|e| format!("{e:?}"))?;
        }
        Ok(())
    }

    fn legend_entries(&self) -> Vec<(String, [u8; 3], u32, bool)> {
        let mut v: Vec<_> = self
            .series
            .iter()
            .map(|s| (s.label.clone(), s.color, s.width, false))
            .collect();
        v.extend(
            self.ref_lines
                .iter()
                .map(|r| (r.label.clone(), r.color, 2, true)),
        );
        v
    }

    fn legend_width(&self, area: &Area<'_>) -> u32 {
        let font: TextStyle = (FAMILY, 13).into_font().into();
        let text = self
            .legend_entries()
            .iter()
            .map(|e| area.estimate_text_size(&e.0, &font).map_or(120, |s| s.0))
            .max()
            .unwrap_or(0);
        text + 50
    }

    /// The legend: one line sample and label per entry, top-aligned with the data area.
    fn legend(&self, area: &Area<'_>) -> std::result::Result<(), String> {
        let err = |e: &dyn std::fmt::Debug| format!("{e:?}");
        let font = (FAMILY, 13).into_font().color(&RGBColor(30, 30, 30));
        for (i, (label, color, width, dashed)) in self.legend_entries().into_iter().enumerate() {
            let y = 44 + 20 * i as i32;
            let c = RGBColor(color[0], color[1], color[2]).stroke_width(width.max(2));
            let segs: Vec<((i32, i32), (i32, i32))> = if dashed {
                vec![((4, y), (11, y)), ((16, y), (23, y)), ((28, y), (30, y))]
            } else {
                vec![((4, y), (30, y))]
            };
            for (a, b) in segs {
                area.draw(&PathElement::new(vec![a, b], c))
                    .map_err(|e| err(&e))?;
            }
            area.draw(&Text::new(label, (36, y - 7), font.clone()))
                .map_err(|e| err(&e))?;
        }
        Ok(())
    }
}

/// Draw with `draw` on a white canvas of `size` and encode as PNG.
fn render_png(size: (usize, usize), draw: impl FnOnce(&Area<'_>) -> Result<()>) -> Result<Vec<u8>> {
    let (w, h) = size;
    if w < 200 || h < 150 {
        return Err(Error::invalid(
            format!("plot of {w}×{h} pixels"),
            "give a size of at least 200×150",
        ));
    }
    ensure_font()?;
    let mut buf = vec![255u8; w * h * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w as u32, h as u32)).into_drawing_area();
        draw(&root)?;
        root.present()
            .map_err(|e| Error::invalid("plot", format!("drawing failed: {e:?}")))?;
    }
    encode_png(&buf, w, h)
}

/// Data range with 5 % padding (a factor on a log axis).
fn padded(v: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |a, x| {
        (a.0.min(x), a.1.max(x))
    });
    if log {
        // Whole decades around the data.
        let lo = (lo.log10() - 1e-9).floor();
        let hi = (hi.log10() + 1e-9).ceil().max(lo + 1.0);
        return (10f64.powf(lo), 10f64.powf(hi));
    }
    let pad = ((hi - lo) * 0.05).max(1e-9 + lo.abs() * 1e-6);
    (lo - pad, hi + pad)
}

/// Decimals for the ticks of an axis spanning `span` (about 5 ticks).
fn decimals(span: f64) -> usize {
    let step = (span / 5.0).abs().max(1e-12);
    (-step.log10().floor()).clamp(0.0, 6.0) as usize
}

/// A log-axis tick: plain decimals down to 0.001, scientific below.
fn log_tick(v: f64) -> String {
    if v >= 1.0 {
        format!("{v:.0}")
    } else if v >= 1e-3 {
        let d = (-v.log10()).ceil().max(1.0) as usize;
        format!("{v:.d$}")
    } else {
        format!("{v:.0e}")
    }
}

fn encode_png(rgb: &[u8], w: usize, h: usize) -> Result<Vec<u8>> {
    png_bytes::<image::Rgb<u8>>(w, h, rgb.to_vec(), Deflate::Default)
        .map_err(|e| Error::invalid("plot", e))
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
            label: match t {
                0 => "iteration 0 (raw)".into(),
                t if t == out.best => format!("iteration {t} (kept)"),
                t => format!("iteration {t}"),
            },
            points: profile(&it.shape.depth, mask, row),
            color: iterate_color(t, n),
            width: if t == out.best { 3 } else { 1 },
        })
        .collect();
    if let Some(z) = truth {
        series.push(Series {
            label: "ground truth".into(),
            points: profile(z, mask, row),
            color: [220, 30, 30],
            width: 2,
        });
    }
    LinePlot {
        title: format!("Depth profile along row {row}"),
        x_label: "column (px)".into(),
        y_label: "depth below the rim (px)".into(),
        series,
        ref_lines: Vec::new(),
        y_log: false,
    }
    .to_png((800, 500))
}

/// Convergence, as a PNG of 800×600 in two panels: above, the relative change per iteration
/// on a log axis with the tolerance of the stopping test drawn; below, the depth of the
/// concavity (px) per iteration.
pub fn convergence_plot_png(out: &NikOutput) -> Result<Vec<u8>> {
    let change: Vec<(f64, f64)> = out
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
        .map(|(t, i)| (t as f64, i.depth_range as f64))
        .collect();
    let mut ref_lines = Vec::new();
    if out.tol > 0.0 {
        ref_lines.push(RefLine {
            label: format!("tolerance {}", out.tol),
            y: out.tol as f64,
            color: [200, 30, 30],
        });
    }
    let top = LinePlot {
        title: "Change between iterations".into(),
        x_label: "iteration".into(),
        y_label: "Δz spread / depth range".into(),
        series: vec![Series {
            label: "relative change".into(),
            points: change,
            color: [30, 60, 200],
            width: 2,
        }],
        ref_lines,
        y_log: true,
    };
    let bottom = LinePlot {
        title: "Depth range (the depth of a concavity)".into(),
        x_label: "iteration".into(),
        y_label: "depth range (px)".into(),
        series: vec![Series {
            label: "depth range".into(),
            points: range,
            color: [200, 100, 20],
            width: 2,
        }],
        ref_lines: Vec::new(),
        y_log: false,
    };
    render_png((800, 600), |root| {
        let (a, b) = root.split_vertically(300);
        if top.series[0].points.iter().any(|p| top.usable(*p)) {
            top.draw(&a)?;
        }
        bottom.draw(&b)
    })
}
