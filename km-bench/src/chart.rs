//! Charts: line charts (linear or logarithmic axes), polar plots of a
//! distribution in the plane of incidence, heat maps and Pareto scatters.
//!
//! Every chart is a plain description (data plus labels) implementing
//! [`Chart`]; [`write_chart`] draws it twice, as `STEM.svg` and `STEM.png`.
//! Logarithmic axes are drawn by plotting `log10` of the data on a linear
//! axis and labelling the ticks with `10^v`, so every chart uses the same
//! coordinate type.
//!
//! Drawing rules every chart follows (and [`ChartLayout`] records, so that a
//! test can check them on the pixels actually drawn):
//! * tick labels carry at most 4 significant digits, one style per axis
//!   (decimal, or `1e-4` powers on wide log axes), and zero is written `0`
//!   ([`format_tick`]);
//! * the legend goes into the first empty corner or edge of the plot whose
//!   box meets no drawn segment, point or label, else outside on the right
//!   ([`Legend`]); each entry shows its series as drawn (dashed, points,
//!   error bar);
//! * lines are clipped to the axis ranges, points outside them dropped;
//! * a series with [`Series::y_err`] gets an error bar with caps at each point.

use std::cell::RefCell;
use std::path::{Path, PathBuf};

use anyhow::{Context, anyhow};
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use crate::font;

/// Pixel size of every chart (width, height).
pub const SIZE: (u32, u32) = (800, 560);

/// A chart that can draw itself on any plotters backend.
pub trait Chart {
    /// Draw on a drawing area (already filled white).
    ///
    /// # Errors
    /// Any plotters drawing error, as text.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> anyhow::Result<()>;

    /// Draw, and return where things went (pixels of the backend). The
    /// default draws with [`Chart::draw`] and returns an empty layout.
    ///
    /// # Errors
    /// Any plotters drawing error, as text.
    fn draw_layout<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> anyhow::Result<ChartLayout> {
        self.draw(root)?;
        Ok(ChartLayout::default())
    }
}

/// A pixel rectangle `[x0, x1] x [y0, y1]` (y down).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PixelRect {
    /// Left edge.
    pub x0: f64,
    /// Top edge.
    pub y0: f64,
    /// Right edge.
    pub x1: f64,
    /// Bottom edge.
    pub y1: f64,
}

impl PixelRect {
    /// The rectangle grown by `d` pixels on every side.
    pub fn grow(&self, d: f64) -> PixelRect {
        PixelRect { x0: self.x0 - d, y0: self.y0 - d, x1: self.x1 + d, y1: self.y1 + d }
    }

    /// Whether two rectangles share any point.
    pub fn meets(&self, o: &PixelRect) -> bool {
        self.x0 <= o.x1 && o.x0 <= self.x1 && self.y0 <= o.y1 && o.y0 <= self.y1
    }

    /// Whether the segment `a`-`b` has a point inside the rectangle
    /// (Liang–Barsky clipping of the segment against it).
    pub fn meets_segment(&self, a: (f64, f64), b: (f64, f64)) -> bool {
        clip_segment(a, b, (self.x0, self.x1), (self.y0, self.y1)).is_some()
    }
}

/// One series as drawn: its legend text, how many points and how many
/// error bars were drawn.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SeriesLayout {
    /// Legend text (empty: not in the legend).
    pub label: String,
    /// Points of the series inside the axes.
    pub points: usize,
    /// Error bars drawn.
    pub error_bars: usize,
}

/// Where a chart's parts were drawn, in pixels of the backend (y down).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ChartLayout {
    /// File stem, set by [`write_chart_layout`].
    pub stem: String,
    /// Kind of chart: `line`, `polar` or `heat` (empty for other charts).
    pub kind: String,
    /// The plotting area.
    pub plot: PixelRect,
    /// The legend box, if any.
    pub legend: Option<PixelRect>,
    /// Every drawn data segment (lines, error bars, spikes, reference lines).
    pub segments: Vec<[(f64, f64); 2]>,
    /// Every drawn marker, as its bounding box.
    pub markers: Vec<PixelRect>,
    /// Boxes of text drawn inside the plotting area (annotations).
    pub texts: Vec<PixelRect>,
    /// Tick labels of the x axis, as drawn.
    pub x_ticks: Vec<String>,
    /// Tick labels of the y axis (or of the colour bar), as drawn.
    pub y_ticks: Vec<String>,
    /// The series, in drawing order.
    pub series: Vec<SeriesLayout>,
}

impl ChartLayout {
    /// Whether the legend box meets a drawn segment, marker or annotation.
    pub fn legend_overlaps_data(&self) -> bool {
        let Some(l) = self.legend else { return false };
        self.segments.iter().any(|s| l.meets_segment(s[0], s[1]))
            || self.markers.iter().any(|m| l.meets(m))
            || self.texts.iter().any(|t| l.meets(t))
    }
}

/// Map a plotters error into `anyhow`.
fn pe<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow!("plotting: {e:?}")
}

/// Draw `chart` into `dir/stem.svg` and `dir/stem.png`; returns both paths.
///
/// # Errors
/// Font registration, drawing or file errors.
pub fn write_chart(dir: &Path, stem: &str, chart: &impl Chart) -> anyhow::Result<[PathBuf; 2]> {
    write_chart_layout(dir, stem, chart).map(|(p, _)| p)
}

/// [`write_chart`], also returning the layout of the PNG (the SVG is drawn
/// with the same layout). Each file is written under a temporary name and
/// renamed, so no half-written chart is left behind.
///
/// # Errors
/// Font registration, drawing or file errors.
pub fn write_chart_layout(
    dir: &Path,
    stem: &str,
    chart: &impl Chart,
) -> anyhow::Result<([PathBuf; 2], ChartLayout)> {
    font::ensure_registered()?;
    let svg = dir.join(format!("{stem}.svg"));
    let png = dir.join(format!("{stem}.png"));
    let svg_tmp = dir.join(format!(".{stem}.tmp.svg"));
    let png_tmp = dir.join(format!(".{stem}.tmp.png"));
    {
        let root = SVGBackend::new(&svg_tmp, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(pe)?;
        chart.draw_layout(&root).with_context(|| format!("drawing {}", svg.display()))?;
        root.present().map_err(pe)?;
    }
    let mut layout;
    {
        let root = BitMapBackend::new(&png_tmp, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(pe)?;
        layout = chart.draw_layout(&root).with_context(|| format!("drawing {}", png.display()))?;
        root.present().map_err(pe)?;
    }
    std::fs::rename(&svg_tmp, &svg).with_context(|| format!("writing {}", svg.display()))?;
    std::fs::rename(&png_tmp, &png).with_context(|| format!("writing {}", png.display()))?;
    layout.stem = stem.to_string();
    Ok(([svg, png], layout))
}

/// The colour of series `i` (a qualitative palette, Tableau 10).
pub fn colour(i: usize) -> RGBColor {
    const P: [(u8, u8, u8); 10] = [
        (31, 119, 180),
        (255, 127, 14),
        (44, 160, 44),
        (214, 39, 40),
        (148, 103, 189),
        (140, 86, 75),
        (227, 119, 194),
        (127, 127, 127),
        (188, 189, 34),
        (23, 190, 207),
    ];
    let (r, g, b) = P[i % P.len()];
    RGBColor(r, g, b)
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mark {
    /// A polyline.
    Line,
    /// A dashed polyline.
    Dashed,
    /// Markers only.
    Points,
    /// A polyline with markers.
    LinePoints,
}

/// One named series of points.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// Points `(x, y)`; non-finite points (and non-positive ones on a log axis) are skipped.
    pub points: Vec<(f64, f64)>,
    /// How to draw it.
    pub mark: Mark,
    /// Palette index of its colour.
    pub colour: usize,
    /// Half-widths of vertical error bars, one per point (empty: none). A
    /// bar's lower end below zero on a log axis is cut at the axis.
    pub y_err: Vec<f64>,
}

impl Series {
    /// A series with palette colour `colour`.
    pub fn new(
        label: impl Into<String>,
        points: Vec<(f64, f64)>,
        mark: Mark,
        colour: usize,
    ) -> Self {
        Series { label: label.into(), points, mark, colour, y_err: Vec::new() }
    }

    /// The same series with error bars of half-width `y_err[i]` at point `i`.
    pub fn with_y_err(mut self, y_err: Vec<f64>) -> Self {
        self.y_err = y_err;
        self
    }
}

/// An x/y chart of several series, each axis linear or logarithmic.
/// Also serves as the Pareto chart (error against time, log-log).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LineChart {
    /// Title above the chart.
    pub title: String,
    /// Label of the x axis.
    pub x_label: String,
    /// Label of the y axis.
    pub y_label: String,
    /// Logarithmic x axis.
    pub x_log: bool,
    /// Logarithmic y axis.
    pub y_log: bool,
    /// Fixed x range (data units); `None`: from the data.
    pub x_range: Option<(f64, f64)>,
    /// Fixed y range (data units); `None`: from the data.
    pub y_range: Option<(f64, f64)>,
    /// The series.
    pub series: Vec<Series>,
    /// Horizontal reference lines `(y, label)`, drawn dotted.
    pub h_lines: Vec<(f64, String)>,
}

/// Transform a value to axis space (log10 on log axes); `None` if not drawable.
fn to_axis(v: f64, log: bool) -> Option<f64> {
    if !v.is_finite() {
        return None;
    }
    if log { if v > 0.0 { Some(v.log10()) } else { None } } else { Some(v) }
}

/// Axis range from data (in axis space), padded by 5 %.
fn axis_range(
    values: impl Iterator<Item = f64>,
    log: bool,
    fixed: Option<(f64, f64)>,
) -> (f64, f64) {
    if let Some((a, b)) = fixed
        && let (Some(a), Some(b)) = (to_axis(a, log), to_axis(b, log))
        && b > a
    {
        return (a, b);
    }
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for v in values.filter_map(|v| to_axis(v, log)) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    if hi - lo < 1e-12 {
        let pad = if log { 0.5 } else { lo.abs().max(1e-3) * 0.1 };
        return (lo - pad, hi + pad);
    }
    let pad = 0.05 * (hi - lo);
    (lo - pad, hi + pad)
}

/// `v` rounded to `sig` significant digits, written without trailing
/// zeros, in decimal or (`sci`) as `m e p` (e.g. `2.5e-4`).
pub fn format_sig(v: f64, sig: usize, sci: bool) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    if v == 0.0 {
        return "0".into();
    }
    let sig = sig.max(1);
    if sci {
        let s = format!("{:.*e}", sig - 1, v);
        let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
        let m = if m.contains('.') { m.trim_end_matches('0').trim_end_matches('.') } else { m };
        return format!("{m}e{e}");
    }
    // Decimals so that `sig` digits survive: sig - 1 - floor(log10 |v|).
    let mag = v.abs().log10().floor() as i32;
    let decimals = (sig as i32 - 1 - mag).max(0) as usize;
    let rounded = {
        // Round to sig digits first (a value such as 12345.6 keeps 4 digits: 12350).
        let scale = 10f64.powi(mag - sig as i32 + 1);
        (v / scale).round() * scale
    };
    let s = format!("{rounded:.decimals$}");
    let s = if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.') } else { &s };
    if s == "-0" { "0".into() } else { s.to_string() }
}

/// Label of the tick at `v` (axis space) on an axis spanning `lo..hi` (axis
/// space; `log10` of the data on a log axis).
///
/// * Linear axes: the value to 4 significant digits, a value within 1e-9 of
///   the span of zero written `0` (so floating-point noise such as 2.2e-16
///   never shows); scientific (`1.5e5`) for the whole axis when its largest
///   magnitude is at least 1e5 or below 1e-3, decimal otherwise.
/// * Log axes spanning at least one decade: only the powers of ten are
///   labelled (others get an empty label), as `0.01`, `1`, `100` when the
///   labelled powers stay within 1e-3..1e4, else as `1e-6` for every label. Narrower
///   log axes: every tick, to 2 significant digits.
pub fn format_tick(v: f64, lo: f64, hi: f64, log: bool) -> String {
    if !v.is_finite() {
        return String::new();
    }
    let span = (hi - lo).abs();
    if log {
        // Decimal when every labelled power of ten lies in 1e-3..1e4.
        let decimal = lo.ceil() >= -3.0 && hi.floor() <= 4.0;
        if span >= 1.0 {
            let p = v.round();
            if (v - p).abs() > 1e-6 * span.max(1.0) {
                return String::new();
            }
            return if decimal {
                format_sig(10f64.powi(p as i32), 1, false)
            } else {
                format!("1e{}", p as i32)
            };
        }
        return format_sig(10f64.powf(v), 2, !decimal);
    }
    if v.abs() <= 1e-9 * span.max(f64::MIN_POSITIVE) {
        return "0".into();
    }
    let big = lo.abs().max(hi.abs());
    let sci = !(1e-3..1e5).contains(&big);
    format_sig(v, 4, sci)
}

/// A compact decimal or scientific rendering of a number for labels and tables.
pub fn format_number(v: f64) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if (1e-3..1e5).contains(&a) {
        let s = format!("{v:.4}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_string()
    } else {
        format!("{v:.2e}")
    }
}

/// Liang–Barsky: the part of segment `a`-`b` inside the box `xr` x `yr`, if any.
pub fn clip_segment(
    a: (f64, f64),
    b: (f64, f64),
    xr: (f64, f64),
    yr: (f64, f64),
) -> Option<((f64, f64), (f64, f64))> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [(-dx, a.0 - xr.0), (dx, xr.1 - a.0), (-dy, a.1 - yr.0), (dy, yr.1 - a.1)] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    (t0 <= t1).then_some(((a.0 + t0 * dx, a.1 + t0 * dy), (a.0 + t1 * dx, a.1 + t1 * dy)))
}

/// Split a polyline (axis space) into runs clipped to the box, each run a
/// polyline drawn in one piece (so dashes stay continuous).
fn clip_polyline(pts: &[(f64, f64)], xr: (f64, f64), yr: (f64, f64)) -> Vec<Vec<(f64, f64)>> {
    let mut runs: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut open = false;
    for w in pts.windows(2) {
        match clip_segment(w[0], w[1], xr, yr) {
            Some((p, q)) => {
                let continues = open && p == w[0];
                if !continues {
                    runs.push(vec![p]);
                }
                if let Some(r) = runs.last_mut() {
                    r.push(q);
                }
                open = q == w[1];
            }
            None => open = false,
        }
    }
    runs
}

/// How a legend entry's sample is drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Sample {
    colour: RGBColor,
    mark: Mark,
    error_bar: bool,
}

/// A legend: entries, measured box size, and where it was put.
#[derive(Debug, Clone, PartialEq)]
pub struct Legend {
    entries: Vec<(String, Sample)>,
    /// Text width of each entry (pixels).
    widths: Vec<f64>,
}

/// Height of one legend row, pixels.
const ROW: f64 = 18.0;
/// Width of a legend sample (line, dashes or marker), pixels.
const SAMPLE_W: f64 = 26.0;
/// Clearance between a legend box and the data, pixels.
const CLEAR: f64 = 4.0;
/// Font of the legend.
const LEGEND_FONT: (&str, u32) = ("sans-serif", 13);

impl Legend {
    fn measure<DB: DrawingBackend>(
        root: &DrawingArea<DB, Shift>,
        entries: Vec<(String, Sample)>,
    ) -> anyhow::Result<Self> {
        let font: TextStyle = LEGEND_FONT.into();
        let mut widths = Vec::new();
        for (l, _) in &entries {
            widths.push(root.estimate_text_size(l, &font).map_err(pe)?.0 as f64);
        }
        Ok(Legend { entries, widths })
    }

    fn size(&self) -> (f64, f64) {
        let tw = self.widths.iter().copied().fold(0.0, f64::max);
        (8.0 + SAMPLE_W + 6.0 + tw + 8.0, 6.0 + ROW * self.entries.len() as f64 + 4.0)
    }

    /// The first candidate box inside `plot` (corners, then edge middles)
    /// whose neighbourhood meets no obstacle.
    fn place_inside(&self, plot: PixelRect, obstacles: &ChartLayout) -> Option<PixelRect> {
        let (w, h) = self.size();
        let inset = 6.0;
        let (l, r) = (plot.x0 + inset, plot.x1 - inset - w);
        let (t, b) = (plot.y0 + inset, plot.y1 - inset - h);
        let (cx, cy) = (0.5 * (plot.x0 + plot.x1 - w), 0.5 * (plot.y0 + plot.y1 - h));
        if r < l || b < t {
            return None;
        }
        let candidates = [(r, t), (l, t), (r, b), (l, b), (cx, t), (cx, b), (r, cy), (l, cy)];
        candidates.into_iter().find_map(|(x, y)| {
            let rect = PixelRect { x0: x, y0: y, x1: x + w, y1: y + h };
            let probe = ChartLayout { legend: Some(rect.grow(CLEAR)), ..obstacles.clone() };
            (!probe.legend_overlaps_data()).then_some(rect)
        })
    }

    /// Draw the legend with its top-left corner at `rect` (absolute pixels).
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        rect: PixelRect,
    ) -> anyhow::Result<()> {
        let (bx, by) = root.get_base_pixel();
        let px = |x: f64, y: f64| ((x.round() as i32) - bx, (y.round() as i32) - by);
        root.draw(&Rectangle::new(
            [px(rect.x0, rect.y0), px(rect.x1, rect.y1)],
            WHITE.mix(0.9).filled(),
        ))
        .map_err(pe)?;
        root.draw(&Rectangle::new([px(rect.x0, rect.y0), px(rect.x1, rect.y1)], BLACK.mix(0.4)))
            .map_err(pe)?;
        for (i, ((label, s), _)) in self.entries.iter().zip(&self.widths).enumerate() {
            let y = rect.y0 + 6.0 + ROW * (i as f64 + 0.5);
            let x = rect.x0 + 8.0;
            let style = ShapeStyle::from(&s.colour).stroke_width(2);
            match s.mark {
                Mark::Line | Mark::LinePoints => {
                    root.draw(&PathElement::new(vec![px(x, y), px(x + SAMPLE_W, y)], style))
                        .map_err(pe)?;
                }
                Mark::Dashed => {
                    // The same 6 on, 4 off pattern as the series.
                    let mut a = 0.0;
                    while a < SAMPLE_W {
                        let e = (a + 6.0).min(SAMPLE_W);
                        root.draw(&PathElement::new(vec![px(x + a, y), px(x + e, y)], style))
                            .map_err(pe)?;
                        a += 10.0;
                    }
                }
                Mark::Points => {}
            }
            let c = x + 0.5 * SAMPLE_W;
            if s.error_bar {
                let thin = ShapeStyle::from(&s.colour).stroke_width(1);
                root.draw(&PathElement::new(vec![px(c, y - 6.0), px(c, y + 6.0)], thin))
                    .map_err(pe)?;
                for yy in [y - 6.0, y + 6.0] {
                    root.draw(&PathElement::new(vec![px(c - 3.0, yy), px(c + 3.0, yy)], thin))
                        .map_err(pe)?;
                }
            }
            if matches!(s.mark, Mark::Points | Mark::LinePoints) {
                root.draw(&Circle::new(px(c, y), 3, s.colour.filled())).map_err(pe)?;
            }
            root.draw(&Text::new(
                label.clone(),
                px(x + SAMPLE_W + 6.0, y - 7.0),
                LEGEND_FONT.into_font(),
            ))
            .map_err(pe)?;
        }
        Ok(())
    }
}

/// A rectangle of pixels from backend coordinates.
fn prect(a: (i32, i32), b: (i32, i32)) -> PixelRect {
    PixelRect {
        x0: a.0.min(b.0) as f64,
        y0: a.1.min(b.1) as f64,
        x1: a.0.max(b.0) as f64,
        y1: a.1.max(b.1) as f64,
    }
}

/// A backend coordinate as `f64` pixels.
fn fpx(p: (i32, i32)) -> (f64, f64) {
    (p.0 as f64, p.1 as f64)
}

impl LineChart {
    /// The data ranges in axis space.
    fn ranges(&self) -> ((f64, f64), (f64, f64)) {
        let x = axis_range(
            self.series.iter().flat_map(|s| s.points.iter().map(|p| p.0)),
            self.x_log,
            self.x_range,
        );
        let y = axis_range(
            self.series
                .iter()
                .flat_map(|s| {
                    // Error bars count towards the range on a linear axis only
                    // (on a log axis a bar's lower end may reach zero).
                    s.points.iter().enumerate().flat_map(move |(i, p)| {
                        let e = s.y_err.get(i).copied().filter(|e| e.is_finite()).unwrap_or(0.0);
                        if self.y_log { [p.1, p.1 + e, p.1] } else { [p.1 - e, p.1 + e, p.1] }
                    })
                })
                .chain(self.h_lines.iter().map(|h| h.0)),
            self.y_log,
            self.y_range,
        );
        (x, y)
    }

    /// Everything that will be drawn, in backend pixels, for a chart built on `chart`.
    fn obstacles<DB: DrawingBackend>(
        &self,
        chart: &ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
        xr: (f64, f64),
        yr: (f64, f64),
    ) -> ChartLayout {
        let mut lay = ChartLayout::default();
        let bc = |p: (f64, f64)| fpx(chart.backend_coord(&p));
        let (xl, yl) = (self.x_log, self.y_log);
        for s in &self.series {
            let pts = axis_points(&s.points, xl, yl);
            let mut sl = SeriesLayout { label: s.label.clone(), ..Default::default() };
            if matches!(s.mark, Mark::Line | Mark::Dashed | Mark::LinePoints) {
                let flat: Vec<(f64, f64)> = pts.iter().map(|p| p.1).collect();
                for run in clip_polyline(&flat, xr, yr) {
                    for w in run.windows(2) {
                        lay.segments.push([bc(w[0]), bc(w[1])]);
                    }
                }
            }
            for &(i, p) in &pts {
                if !inside(p, xr, yr) {
                    continue;
                }
                sl.points += 1;
                if matches!(s.mark, Mark::Points | Mark::LinePoints) {
                    let c = bc(p);
                    lay.markers.push(PixelRect {
                        x0: c.0 - 3.0,
                        y0: c.1 - 3.0,
                        x1: c.0 + 3.0,
                        y1: c.1 + 3.0,
                    });
                }
                if let Some(bar) = error_bar(s, i, p, yl, yr) {
                    let (a, b) = (bc(bar.0), bc(bar.1));
                    lay.segments.push([a, b]);
                    for (end, clipped) in [(a, bar.2), (b, bar.3)] {
                        if !clipped {
                            lay.segments.push([(end.0 - 3.0, end.1), (end.0 + 3.0, end.1)]);
                        }
                    }
                    sl.error_bars += 1;
                }
            }
            lay.series.push(sl);
        }
        for (y, _) in &self.h_lines {
            if let Some(ya) = to_axis(*y, yl).filter(|v| *v >= yr.0 && *v <= yr.1) {
                lay.segments.push([bc((xr.0, ya)), bc((xr.1, ya))]);
            }
        }
        lay
    }
}

/// The drawable points of a series in axis space, with their index.
fn axis_points(points: &[(f64, f64)], xl: bool, yl: bool) -> Vec<(usize, (f64, f64))> {
    points
        .iter()
        .enumerate()
        .filter_map(|(i, &(x, y))| Some((i, (to_axis(x, xl)?, to_axis(y, yl)?))))
        .collect()
}

/// Whether an axis-space point lies in the box.
fn inside(p: (f64, f64), xr: (f64, f64), yr: (f64, f64)) -> bool {
    p.0 >= xr.0 && p.0 <= xr.1 && p.1 >= yr.0 && p.1 <= yr.1
}

/// An error bar in axis space: low end, high end, whether each end was cut.
type Bar = ((f64, f64), (f64, f64), bool, bool);

/// A text drawn in the plot: its box (pixels), anchor (axis space) and text.
type Annotation = (PixelRect, (f64, f64), String);

/// The error bar of point `i` (axis space, clipped to the y range):
/// `(low end, high end, low clipped, high clipped)`.
fn error_bar(s: &Series, i: usize, p: (f64, f64), yl: bool, yr: (f64, f64)) -> Option<Bar> {
    let e = s.y_err.get(i).copied().filter(|e| e.is_finite() && *e >= 0.0)?;
    let y = if yl { 10f64.powf(p.1) } else { p.1 };
    let lo = to_axis(y - e, yl).unwrap_or(f64::NEG_INFINITY);
    let hi = to_axis(y + e, yl)?;
    let (lo_c, hi_c) = (lo < yr.0, hi > yr.1);
    Some(((p.0, lo.max(yr.0)), (p.0, hi.min(yr.1)), lo_c, hi_c))
}

impl Chart for LineChart {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> anyhow::Result<()> {
        self.draw_layout(root).map(|_| ())
    }

    fn draw_layout<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> anyhow::Result<ChartLayout> {
        let (xr, yr) = self.ranges();
        let (x0, x1) = xr;
        let (y0, y1) = yr;
        let body = root.titled(&self.title, ("sans-serif", 20)).map_err(pe)?;
        let build = |area: &DrawingArea<DB, Shift>| {
            ChartBuilder::on(area)
                .margin(12)
                .x_label_area_size(45)
                .y_label_area_size(70)
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(pe)
        };
        // Reference-line labels: where they go (backend pixels), measured once.
        let label_font: TextStyle = ("sans-serif", 12).into();
        let entries: Vec<(String, Sample)> = self
            .series
            .iter()
            .filter(|s| !s.label.is_empty())
            .map(|s| {
                let sample = Sample {
                    colour: colour(s.colour),
                    mark: s.mark,
                    error_bar: s.y_err.iter().any(|e| e.is_finite() && *e > 0.0),
                };
                (s.label.clone(), sample)
            })
            .collect();
        let legend = Legend::measure(root, entries)?;
        let h_text = |chart: &ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>|
         -> anyhow::Result<Vec<Annotation>> {
            let mut out = Vec::new();
            for (y, label) in &self.h_lines {
                if let Some(ya) = to_axis(*y, self.y_log).filter(|v| *v >= y0 && *v <= y1) {
                    let at = (x0 + 0.01 * (x1 - x0), ya);
                    let p = fpx(chart.backend_coord(&at));
                    let (w, h) = root.estimate_text_size(label, &label_font).map_err(pe)?;
                    out.push((
                        PixelRect { x0: p.0, y0: p.1, x1: p.0 + w as f64, y1: p.1 + h as f64 },
                        at,
                        label.clone(),
                    ));
                }
            }
            Ok(out)
        };
        // First layout on the whole body: is there an empty place for the legend?
        let trial = build(&body)?;
        let plot_px = {
            let (xs, ys) = trial.plotting_area().get_pixel_range();
            PixelRect {
                x0: xs.start as f64,
                y0: ys.start as f64,
                x1: xs.end as f64,
                y1: ys.end as f64,
            }
        };
        let texts = h_text(&trial)?;
        let mut obstacles = self.obstacles(&trial, xr, yr);
        obstacles.texts = texts.iter().map(|t| t.0).collect();
        let inside_place =
            if legend.entries.is_empty() { None } else { legend.place_inside(plot_px, &obstacles) };
        drop(trial);
        // Outside on the right when no place inside is free.
        let (area, legend_rect) = match (legend.entries.is_empty(), inside_place) {
            (true, _) => (body.clone(), None),
            (false, Some(r)) => (body.clone(), Some(r)),
            (false, None) => {
                let (w, h) = legend.size();
                let (bw, _) = body.dim_in_pixel();
                let split = (bw as f64 - w - 10.0).max(0.5 * bw as f64) as i32;
                let (left, _) = body.split_horizontally(split);
                let (bx, _) = body.get_base_pixel();
                let x = (bx + split) as f64;
                let r = PixelRect { x0: x, y0: plot_px.y0, x1: x + w, y1: plot_px.y0 + h };
                (left, Some(r))
            }
        };
        let mut chart = build(&area)?;
        let x_ticks = RefCell::new(Vec::new());
        let y_ticks = RefCell::new(Vec::new());
        let (xl, yl) = (self.x_log, self.y_log);
        let fx = |v: &f64| {
            let s = format_tick(*v, x0, x1, xl);
            if !s.is_empty() {
                x_ticks.borrow_mut().push(s.clone());
            }
            s
        };
        let fy = |v: &f64| {
            let s = format_tick(*v, y0, y1, yl);
            if !s.is_empty() {
                y_ticks.borrow_mut().push(s.clone());
            }
            s
        };
        chart
            .configure_mesh()
            .x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .x_label_formatter(&fx)
            .y_label_formatter(&fy)
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 15))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(pe)?;
        let texts = h_text(&chart)?;
        for (y, _) in &self.h_lines {
            if let Some(ya) = to_axis(*y, yl).filter(|v| *v >= y0 && *v <= y1) {
                let style = ShapeStyle::from(&BLACK.mix(0.5)).stroke_width(1);
                chart
                    .draw_series(DashedLineSeries::new(vec![(x0, ya), (x1, ya)], 4, 4, style))
                    .map_err(pe)?;
            }
        }
        for (_, at, label) in &texts {
            chart
                .draw_series(std::iter::once(Text::new(label.clone(), *at, ("sans-serif", 12))))
                .map_err(pe)?;
        }
        for s in &self.series {
            let c = colour(s.colour);
            let pts = axis_points(&s.points, xl, yl);
            let style = ShapeStyle::from(&c).stroke_width(2);
            if matches!(s.mark, Mark::Line | Mark::Dashed | Mark::LinePoints) {
                let flat: Vec<(f64, f64)> = pts.iter().map(|p| p.1).collect();
                for run in clip_polyline(&flat, xr, yr) {
                    if s.mark == Mark::Dashed {
                        chart.draw_series(DashedLineSeries::new(run, 6, 4, style)).map_err(pe)?;
                    } else {
                        chart.draw_series(LineSeries::new(run, style)).map_err(pe)?;
                    }
                }
            }
            let thin = ShapeStyle::from(&c).stroke_width(1);
            for &(i, p) in &pts {
                if !inside(p, xr, yr) {
                    continue;
                }
                if let Some((a, b, a_clip, b_clip)) = error_bar(s, i, p, yl, yr) {
                    chart
                        .draw_series(std::iter::once(PathElement::new(vec![a, b], thin)))
                        .map_err(pe)?;
                    // Caps: 3 pixels either side, drawn in pixels on the root.
                    for (end, clipped) in [(a, a_clip), (b, b_clip)] {
                        if clipped {
                            continue;
                        }
                        let q = chart.backend_coord(&end);
                        let (rx, ry) = root.get_base_pixel();
                        root.draw(&PathElement::new(
                            vec![(q.0 - 3 - rx, q.1 - ry), (q.0 + 3 - rx, q.1 - ry)],
                            thin,
                        ))
                        .map_err(pe)?;
                    }
                }
                if matches!(s.mark, Mark::Points | Mark::LinePoints) {
                    chart
                        .draw_series(std::iter::once(Circle::new(p, 3, c.filled())))
                        .map_err(pe)?;
                }
            }
        }
        let mut layout = self.obstacles(&chart, xr, yr);
        layout.texts = texts.iter().map(|t| t.0).collect();
        let (xs, ys) = chart.plotting_area().get_pixel_range();
        layout.plot = prect((xs.start, ys.start), (xs.end, ys.end));
        if let Some(r) = legend_rect {
            legend.draw(root, r)?;
            layout.legend = Some(r);
        }
        layout.kind = "line".into();
        layout.x_ticks = x_ticks.into_inner();
        layout.y_ticks = y_ticks.into_inner();
        Ok(layout)
    }
}

/// A curve of a polar plot: radial value against the angle `psi` in the
/// plane of incidence.
///
/// `psi` is measured in degrees from the upward normal, positive towards the
/// side the light travels to (the mirror side), so reflected directions have
/// `|psi| < 90` and transmitted ones `|psi| > 90`; see [`plane_angle`].
#[derive(Debug, Clone, PartialEq)]
pub struct PolarCurve {
    /// Legend text.
    pub label: String,
    /// Points `(psi_deg, value)`, value `>= 0`.
    pub points: Vec<(f64, f64)>,
    /// Palette index of its colour.
    pub colour: usize,
    /// Dashed line.
    pub dashed: bool,
}

/// A delta part (mirror reflection, unscattered beam) drawn as a spike.
#[derive(Debug, Clone, PartialEq)]
pub struct PolarSpike {
    /// Direction, same convention as [`PolarCurve`].
    pub psi_deg: f64,
    /// Length of the spike in the units of the radial axis.
    pub length: f64,
    /// Annotation.
    pub label: String,
}

/// The angle `psi` (degrees, see [`PolarCurve`]) of a direction in the
/// plane of incidence: polar angle `theta_deg` from the normal on its side,
/// `reflected` above the surface or transmitted below, on the `forward`
/// (mirror / beam) side (azimuth 180 in the scene convention) or back
/// towards the source (azimuth 0).
pub fn plane_angle(theta_deg: f64, reflected: bool, forward: bool) -> f64 {
    let side = if forward { 1.0 } else { -1.0 };
    if reflected { side * theta_deg } else { side * (180.0 - theta_deg) }
}

/// A polar plot in the plane of incidence, as the seed's figures: the
/// surface is the horizontal line, reflection above, transmission below,
/// the incident beam drawn as an arrow from the upper left.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PolarChart {
    /// Title.
    pub title: String,
    /// Incidence angle (degrees from the normal), if collimated.
    pub incidence_deg: Option<f64>,
    /// The curves.
    pub curves: Vec<PolarCurve>,
    /// Delta parts.
    pub spikes: Vec<PolarSpike>,
    /// Radial axis label (units).
    pub r_label: String,
    /// Draw the surface line (false for a full-circle distribution such as
    /// a field inside the medium).
    pub surface: bool,
}

impl Chart for PolarChart {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> anyhow::Result<()> {
        self.draw_layout(root).map(|_| ())
    }

    fn draw_layout<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> anyhow::Result<ChartLayout> {
        // Radial scale: the largest value of the curves; spikes longer than
        // SPIKE_CLIP of it are cut there and marked with a chevron.
        const SPIKE_CLIP: f64 = 1.05;
        let mut r_max = self
            .curves
            .iter()
            .flat_map(|c| c.points.iter().map(|p| p.1))
            .filter(|v| v.is_finite())
            .fold(0.0f64, f64::max);
        if r_max <= 0.0 {
            r_max = self
                .spikes
                .iter()
                .map(|s| s.length)
                .filter(|v| v.is_finite())
                .fold(0.0f64, f64::max);
        }
        if r_max <= 0.0 || !r_max.is_finite() {
            r_max = 1.0;
        }
        let lim = 1.2 * r_max;
        let body = root.titled(&self.title, ("sans-serif", 20)).map_err(pe)?;
        let (w, h) = body.dim_in_pixel();
        // Equal aspect: x spans more than y in proportion to the pixel area.
        let aspect = (w as f64 - 24.0) / (h as f64 - 24.0);
        let mut chart = ChartBuilder::on(&body)
            .margin(12)
            .build_cartesian_2d(-lim * aspect..lim * aspect, -lim..lim)
            .map_err(pe)?;
        let mut layout = ChartLayout { kind: "polar".into(), ..Default::default() };
        let (xs, ys) = chart.plotting_area().get_pixel_range();
        layout.plot = prect((xs.start, ys.start), (xs.end, ys.end));
        let text_box = |text: &str, at: (i32, i32), size: u32| -> anyhow::Result<PixelRect> {
            let (tw, th) =
                root.estimate_text_size(text, &("sans-serif", size).into()).map_err(pe)?;
            Ok(PixelRect {
                x0: at.0 as f64,
                y0: at.1 as f64,
                x1: (at.0 + tw as i32) as f64,
                y1: (at.1 + th as i32) as f64,
            })
        };
        // Radial grid: circles at quarter steps of a round scale value, with labels.
        let step = nice_step(r_max / 4.0);
        let grey = RGBColor(200, 200, 200);
        let mut r = step;
        let mut ticks = Vec::new();
        while r <= lim * 1.0001 {
            let circle: Vec<(f64, f64)> = (0..=180)
                .map(|k| {
                    let a = k as f64 * 2.0 * std::f64::consts::PI / 180.0;
                    (r * a.sin(), r * a.cos())
                })
                .collect();
            chart.draw_series(LineSeries::new(circle, grey)).map_err(pe)?;
            let label = format_sig(r, 4, !(1e-3..1e5).contains(&r_max));
            ticks.push(label.clone());
            chart
                .draw_series(std::iter::once(Text::new(
                    label,
                    (r * 0.05, r + 0.01 * lim),
                    ("sans-serif", 11).into_font().color(&RGBColor(120, 120, 120)),
                )))
                .map_err(pe)?;
            r += step;
        }
        layout.y_ticks = ticks;
        // Normal (vertical, dotted) and surface (horizontal, solid).
        chart
            .draw_series(DashedLineSeries::new(
                vec![(0.0, -lim), (0.0, lim)],
                3,
                5,
                ShapeStyle::from(&grey),
            ))
            .map_err(pe)?;
        if self.surface {
            chart
                .draw_series(LineSeries::new(
                    vec![(-lim * aspect, 0.0), (lim * aspect, 0.0)],
                    BLACK.stroke_width(2),
                ))
                .map_err(pe)?;
        }
        // Pixel mapping of the (linear) coordinates, from two far-apart points,
        // so that the chart can be drawn on while positions are recorded.
        let (o, e) = (chart.backend_coord(&(0.0, 0.0)), chart.backend_coord(&(lim, lim)));
        let bc = move |p: (f64, f64)| -> (i32, i32) {
            (
                (o.0 as f64 + (e.0 - o.0) as f64 * p.0 / lim).round() as i32,
                (o.1 as f64 + (e.1 - o.1) as f64 * p.1 / lim).round() as i32,
            )
        };
        // Incident beam: from the upper left towards the origin.
        if let Some(t) = self.incidence_deg {
            let a = (-t).to_radians();
            let (x, y) = (lim * 0.95 * a.sin(), lim * 0.95 * a.cos());
            let style = ShapeStyle::from(&BLACK).stroke_width(2);
            chart
                .draw_series(std::iter::once(PathElement::new(vec![(x, y), (0.0, 0.0)], style)))
                .map_err(pe)?;
            let label = format!("incident {t:.0} deg");
            layout.segments.push([fpx(bc((x, y))), fpx(bc((0.0, 0.0)))]);
            // The label ends just left of the arrow's tail, clear of the line.
            let (tw, th) =
                root.estimate_text_size(&label, &("sans-serif", 12).into()).map_err(pe)?;
            let tail = bc((x, y));
            let at = (tail.0 - tw as i32 - 6, tail.1 - th as i32 / 2);
            layout.texts.push(text_box(&label, at, 12)?);
            let (rx, ry) = root.get_base_pixel();
            root.draw(&Text::new(label, (at.0 - rx, at.1 - ry), ("sans-serif", 12))).map_err(pe)?;
        }
        // Curves.
        let mut entries = Vec::new();
        for c in &self.curves {
            let col = colour(c.colour);
            let pts: Vec<(f64, f64)> = c
                .points
                .iter()
                .filter(|p| p.0.is_finite() && p.1.is_finite())
                .map(|&(psi, v)| {
                    let a = psi.to_radians();
                    let v = v.max(0.0);
                    (v * a.sin(), v * a.cos())
                })
                .collect();
            for w in pts.windows(2) {
                layout.segments.push([fpx(bc(w[0])), fpx(bc(w[1]))]);
            }
            layout.series.push(SeriesLayout {
                label: c.label.clone(),
                points: pts.len(),
                error_bars: 0,
            });
            let style = ShapeStyle::from(&col).stroke_width(2);
            if c.dashed {
                chart.draw_series(DashedLineSeries::new(pts, 6, 4, style)).map_err(pe)?;
            } else {
                chart.draw_series(LineSeries::new(pts, style)).map_err(pe)?;
            }
            if !c.label.is_empty() {
                let mark = if c.dashed { Mark::Dashed } else { Mark::Line };
                entries.push((c.label.clone(), Sample { colour: col, mark, error_bar: false }));
            }
        }
        // Spikes for delta parts, cut at SPIKE_CLIP r_max with a chevron when longer.
        for s in &self.spikes {
            let a = s.psi_deg.to_radians();
            // NaN or infinite lengths count as off scale.
            let clipped = s.length.is_nan() || s.length > SPIKE_CLIP * r_max;
            let len = if clipped { SPIKE_CLIP * r_max } else { s.length.max(0.0) };
            let (dx, dy) = (a.sin(), a.cos());
            let tip = (len * dx, len * dy);
            let style = ShapeStyle::from(&RGBColor(90, 90, 90)).stroke_width(3);
            chart
                .draw_series(std::iter::once(PathElement::new(vec![(0.0, 0.0), tip], style)))
                .map_err(pe)?;
            layout.segments.push([fpx(bc((0.0, 0.0))), fpx(bc(tip))]);
            let mut label = s.label.clone();
            if clipped {
                // Chevron pointing outwards: the spike goes on beyond the plot's scale.
                let (px, py) = (-dy, dx);
                let back = 0.05 * r_max;
                let half = 0.03 * r_max;
                for sign in [-1.0, 1.0] {
                    let side = (
                        tip.0 - back * dx + sign * half * px,
                        tip.1 - back * dy + sign * half * py,
                    );
                    chart
                        .draw_series(std::iter::once(PathElement::new(vec![side, tip], style)))
                        .map_err(pe)?;
                    layout.segments.push([fpx(bc(side)), fpx(bc(tip))]);
                }
                label += " (off scale)";
            }
            // The label beside the tip, away from the spike.
            let at = bc(tip);
            let at = (at.0 + 8, at.1 - 16);
            layout.texts.push(text_box(&label, at, 12)?);
            let (rx, ry) = root.get_base_pixel();
            root.draw(&Text::new(label, (at.0 - rx, at.1 - ry), ("sans-serif", 12))).map_err(pe)?;
        }
        if !entries.is_empty() {
            let legend = Legend::measure(root, entries)?;
            let place = legend.place_inside(layout.plot, &layout);
            let rect = place.unwrap_or_else(|| {
                // No empty place: the upper right corner of the whole area.
                let (ww, _) = legend.size();
                let (bx, by) = root.get_base_pixel();
                let (rw, _) = root.dim_in_pixel();
                let x = bx as f64 + rw as f64 - ww - 4.0;
                PixelRect {
                    x0: x,
                    y0: by as f64 + 4.0,
                    x1: x + ww,
                    y1: by as f64 + 4.0 + legend.size().1,
                }
            });
            legend.draw(root, rect)?;
            layout.legend = Some(rect);
        }
        if !self.r_label.is_empty() {
            let text = format!("radius: {}", self.r_label);
            let (_, rh) = root.dim_in_pixel();
            root.draw(&Text::new(text, (14, rh as i32 - 22), ("sans-serif", 13))).map_err(pe)?;
        }
        Ok(layout)
    }
}

/// A round step (1, 2 or 5 times a power of ten) near `x`.
fn nice_step(x: f64) -> f64 {
    if x.is_nan() || x <= 0.0 || !x.is_finite() {
        return 1.0;
    }
    let e = x.log10().floor();
    let base = 10f64.powf(e);
    let m = x / base;
    let f = if m < 1.5 {
        1.0
    } else if m < 3.5 {
        2.0
    } else if m < 7.5 {
        5.0
    } else {
        10.0
    };
    f * base
}

/// A heat map over a grid of (x, y) cells, with a colour bar.
///
/// Cells whose value is `None` (the method refused the case with an error)
/// are drawn grey; non-finite values are drawn magenta. Both are counted
/// in the title, so a single NaN cannot hide.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct HeatMap {
    /// Title.
    pub title: String,
    /// Label of the x axis.
    pub x_label: String,
    /// Label of the y axis.
    pub y_label: String,
    /// Centre of each column (data units), increasing.
    pub x: Vec<f64>,
    /// Centre of each row (data units), increasing.
    pub y: Vec<f64>,
    /// Logarithmic x axis (for the tick labels; cells are equal-width in index space).
    pub x_log: bool,
    /// Values `z[iy][ix]`.
    pub z: Vec<Vec<Option<f64>>>,
    /// Label of the colour bar.
    pub z_label: String,
    /// Colour by `log10(z)`, with values below `z_floor` clipped to it.
    pub z_log: bool,
    /// Lower clip of `z` on a log scale (e.g. 1e-16).
    pub z_floor: f64,
}

/// A perceptually ordered colour map (viridis, 5 anchors interpolated linearly) at `t` in `[0, 1]`.
pub fn viridis(t: f64) -> RGBColor {
    const A: [(f64, f64, f64); 5] = [
        (68.0, 1.0, 84.0),
        (59.0, 82.0, 139.0),
        (33.0, 145.0, 140.0),
        (94.0, 201.0, 98.0),
        (253.0, 231.0, 37.0),
    ];
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.0 };
    let s = t * (A.len() - 1) as f64;
    let i = (s.floor() as usize).min(A.len() - 2);
    let f = s - i as f64;
    let lerp = |a: f64, b: f64| (a + (b - a) * f).round() as u8;
    RGBColor(lerp(A[i].0, A[i + 1].0), lerp(A[i].1, A[i + 1].1), lerp(A[i].2, A[i + 1].2))
}

impl HeatMap {
    /// The value used for colouring, or `None` for an invalid cell.
    fn colour_value(&self, v: Option<f64>) -> Option<f64> {
        let v = v.filter(|v| v.is_finite())?;
        if self.z_log { Some(v.abs().max(self.z_floor.max(1e-300)).log10()) } else { Some(v) }
    }

    /// Number of non-finite cells.
    pub fn invalid_cells(&self) -> usize {
        self.z.iter().flatten().filter(|v| matches!(v, Some(x) if !x.is_finite())).count()
    }

    /// Number of refused cells (`None`).
    pub fn refused_cells(&self) -> usize {
        self.z.iter().flatten().filter(|v| v.is_none()).count()
    }
}

impl Chart for HeatMap {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> anyhow::Result<()> {
        self.draw_layout(root).map(|_| ())
    }

    fn draw_layout<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> anyhow::Result<ChartLayout> {
        let (w, _) = root.dim_in_pixel();
        let (main, bar) = root.split_horizontally(w.saturating_sub(130));
        let nx = self.x.len().max(1);
        let ny = self.y.len().max(1);
        let vals: Vec<f64> =
            self.z.iter().flatten().filter_map(|&v| self.colour_value(v)).collect();
        let (mut lo, mut hi) =
            vals.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
        if !lo.is_finite() {
            lo = 0.0;
            hi = 1.0;
        }
        // On a log scale with a floor, the scale starts at the floor (the
        // method's rounding level): values at or below it share the darkest
        // colour, so rounding noise cannot pass for structure.
        if self.z_log && self.z_floor > 0.0 && self.z_floor.is_finite() {
            lo = self.z_floor.log10();
            hi = hi.max(lo + 1.0);
        }
        if hi - lo < 1e-12 {
            hi = lo + 1.0;
        }
        let (bad, refused) = (self.invalid_cells(), self.refused_cells());
        let mut title = self.title.clone();
        if bad > 0 {
            title += &format!(" [{bad} NaN: magenta]");
        }
        if refused > 0 {
            title += &format!(" [{refused} refused: grey]");
        }
        let mut chart = ChartBuilder::on(&main)
            .caption(title, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(45)
            .y_label_area_size(60)
            .build_cartesian_2d(-0.5..nx as f64 - 0.5, -0.5..ny as f64 - 0.5)
            .map_err(pe)?;
        let xs = self.x.clone();
        let ys = self.y.clone();
        let xlog = self.x_log;
        // Cell i is centred on the integer i; only integer ticks are labelled.
        let at = |v: f64| -> Option<usize> {
            ((v - v.round()).abs() < 1e-6 && v > -0.5).then(|| v.round() as usize)
        };
        let x_ticks = RefCell::new(Vec::new());
        let y_ticks = RefCell::new(Vec::new());
        let fx = |v: &f64| {
            let s = at(*v)
                .and_then(|i| xs.get(i))
                .map(|&x| {
                    if xlog && x > 0.0 {
                        format_tick(x.log10(), -30.0, 30.0, true)
                    } else {
                        format_sig(x, 4, false)
                    }
                })
                .unwrap_or_default();
            if !s.is_empty() {
                x_ticks.borrow_mut().push(s.clone());
            }
            s
        };
        let fy = |v: &f64| {
            let s = at(*v)
                .and_then(|i| ys.get(i))
                .map(|&y| format_sig(y, 4, false))
                .unwrap_or_default();
            if !s.is_empty() {
                y_ticks.borrow_mut().push(s.clone());
            }
            s
        };
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .x_labels(nx.min(13))
            .y_labels(ny.min(14))
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 15))
            .x_label_formatter(&fx)
            .y_label_formatter(&fy)
            .draw()
            .map_err(pe)?;
        let mut cells = Vec::with_capacity(nx * ny);
        for (iy, row) in self.z.iter().enumerate() {
            for (ix, &v) in row.iter().enumerate() {
                let c = match (v, self.colour_value(v)) {
                    (_, Some(c)) => viridis((c - lo) / (hi - lo)).filled(),
                    (None, _) => RGBColor(190, 190, 190).filled(),
                    (Some(_), None) => MAGENTA.filled(),
                };
                let (x, y) = (ix as f64, iy as f64);
                cells.push(Rectangle::new([(x - 0.5, y - 0.5), (x + 0.5, y + 0.5)], c));
            }
        }
        chart.draw_series(cells).map_err(pe)?;
        // Colour bar.
        let mut cb = ChartBuilder::on(&bar)
            .margin_top(40)
            .margin_bottom(55)
            .margin_right(10)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..1.0, lo..hi)
            .map_err(pe)?;
        let zlog = self.z_log;
        let fz = |v: &f64| {
            let s = format_tick(*v, lo, hi, zlog);
            if !s.is_empty() {
                y_ticks.borrow_mut().push(s.clone());
            }
            s
        };
        cb.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_desc(&self.z_label)
            .label_style(("sans-serif", 12))
            .axis_desc_style(("sans-serif", 13))
            .y_label_formatter(&fz)
            .draw()
            .map_err(pe)?;
        let steps = 64;
        cb.draw_series((0..steps).map(|k| {
            let a = lo + (hi - lo) * k as f64 / steps as f64;
            let b = lo + (hi - lo) * (k + 1) as f64 / steps as f64;
            Rectangle::new([(0.0, a), (1.0, b)], viridis((k as f64 + 0.5) / steps as f64).filled())
        }))
        .map_err(pe)?;
        let (xs, ys) = chart.plotting_area().get_pixel_range();
        Ok(ChartLayout {
            kind: "heat".into(),
            plot: prect((xs.start, ys.start), (xs.end, ys.end)),
            x_ticks: x_ticks.into_inner(),
            y_ticks: y_ticks.into_inner(),
            ..Default::default()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn number_format_is_compact() {
        assert_eq!(format_number(0.5), "0.5");
        assert_eq!(format_number(1e-6), "1.00e-6");
        assert_eq!(format_number(0.0), "0");
    }

    #[test]
    fn tick_labels_are_short_and_zero_is_zero() {
        // Floating-point noise at zero on a linear axis of span 1.
        assert_eq!(format_tick(2.220446049250313e-16, -0.5, 0.5, false), "0");
        assert_eq!(format_tick(-1.1102230246251565e-16, -0.2, 0.2, false), "0");
        assert_eq!(format_tick(0.30000000000000004, 0.0, 1.0, false), "0.3");
        assert_eq!(format_tick(12345.678, 0.0, 20000.0, false), "12350");
        assert_eq!(format_tick(2e5, 0.0, 5e5, false), "2e5");
        // Log axes over several decades: powers of ten only, one style per axis.
        assert_eq!(format_tick(-25.0, -25.5, 0.2, true), "1e-25");
        assert_eq!(format_tick(0.5, -25.5, 0.2, true), "");
        assert_eq!(format_tick(-3.0, -3.2, 0.1, true), "0.001");
        assert_eq!(format_tick(-4.0, -4.2, 0.1, true), "1e-4");
        assert_eq!(format_tick(-3.0, -4.2, 0.1, true), "1e-3");
        // Less than a decade: every tick, two digits.
        assert_eq!(format_tick(0.5, 0.2, 0.9, true), "3.2");
        assert_eq!(format_sig(-0.0, 4, false), "0");
        assert_eq!(format_sig(0.000123456, 4, true), "1.235e-4");
    }

    #[test]
    fn segments_are_clipped_to_the_box() {
        let b = ((0.0, 1.0), (0.0, 1.0));
        assert_eq!(clip_segment((-1.0, 0.5), (2.0, 0.5), b.0, b.1), Some(((0.0, 0.5), (1.0, 0.5))));
        assert_eq!(clip_segment((-1.0, 2.0), (2.0, 2.0), b.0, b.1), None);
        let r = PixelRect { x0: 0.0, y0: 0.0, x1: 10.0, y1: 10.0 };
        assert!(r.meets_segment((-5.0, 5.0), (15.0, 5.0)));
        assert!(!r.meets_segment((-5.0, 11.0), (15.0, 11.0)));
        // A polyline leaving and re-entering the box gives two runs.
        let runs = clip_polyline(&[(0.5, 0.5), (0.5, 2.0), (0.6, 0.5)], b.0, b.1);
        assert_eq!(runs.len(), 2);
    }

    #[test]
    fn plane_angles_follow_the_convention() {
        assert_eq!(plane_angle(30.0, true, true), 30.0);
        assert_eq!(plane_angle(30.0, true, false), -30.0);
        assert_eq!(plane_angle(30.0, false, true), 150.0);
        assert_eq!(plane_angle(0.0, false, false), -180.0);
    }

    #[test]
    fn charts_survive_empty_and_non_finite_data() {
        let dir = std::env::temp_dir().join(format!("km-bench-chart-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let line = LineChart {
            series: vec![Series::new(
                "a",
                vec![(f64::NAN, 1.0), (1.0, f64::INFINITY), (-1.0, 2.0)],
                Mark::LinePoints,
                0,
            )],
            x_log: true,
            y_log: true,
            ..Default::default()
        };
        write_chart(&dir, "line", &line).unwrap();
        write_chart(&dir, "polar", &PolarChart::default()).unwrap();
        let hm = HeatMap {
            x: vec![1.0, 2.0],
            y: vec![0.0],
            z: vec![vec![Some(f64::NAN), None]],
            z_log: true,
            z_floor: 1e-16,
            ..Default::default()
        };
        assert_eq!((hm.invalid_cells(), hm.refused_cells()), (1, 1));
        write_chart(&dir, "heat", &hm).unwrap();
        let svg = std::fs::read_to_string(dir.join("heat.svg")).unwrap();
        assert!(svg.contains("1 NaN"), "the title counts the NaN cell");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn viridis_ends() {
        assert_eq!(viridis(0.0), RGBColor(68, 1, 84));
        assert_eq!(viridis(1.0), RGBColor(253, 231, 37));
        assert_eq!(viridis(f64::NAN), RGBColor(68, 1, 84));
    }
}
