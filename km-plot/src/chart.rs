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

use anyhow::{Context, anyhow, bail};
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use crate::font;

mod heat;
mod line;
mod polar;

pub use heat::{HeatMap, viridis};
pub use line::LineChart;
pub use polar::{PolarChart, PolarCurve, PolarSpike, plane_angle};

/// Pixel size of every chart (width, height).
pub const SIZE: (u32, u32) = (800, 560);

/// A chart that can draw itself on any plotters backend.
pub trait Chart {
    /// Draw on a drawing area (already filled white), and return where
    /// things went (pixels of the backend).
    ///
    /// # Errors
    /// Any plotters drawing error, as text.
    fn draw_layout<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> anyhow::Result<ChartLayout>;

    /// Draw on a drawing area (already filled white): [`Chart::draw_layout`]
    /// without the layout.
    ///
    /// # Errors
    /// Any plotters drawing error, as text.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> anyhow::Result<()> {
        self.draw_layout(root).map(|_| ())
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
    /// Error bars whose lower end was cut at the bottom of the plot.
    pub bars_cut_at_floor: usize,
    /// Points drawn with their own label.
    pub labelled: usize,
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
    /// Description of the x axis.
    pub x_label: String,
    /// Tick labels of the x axis, as drawn.
    pub x_ticks: Vec<String>,
    /// Tick labels of the y axis, as drawn.
    pub y_ticks: Vec<String>,
    /// Tick labels of a heat map's colour bar, as drawn.
    pub z_ticks: Vec<String>,
    /// Heat-map cells marked with a cross.
    pub marked_cells: usize,
    /// Notes drawn beside the title (what a mark means).
    pub notes: Vec<String>,
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

/// The directory and stem of the chart `--plot FILE.svg` or `--plot
/// FILE.png` (both are drawn, side by side), refused before anything is computed:
/// a directory that does not exist, or an SVG or PNG of that stem that is not
/// a chart (never replaced).
///
/// # Errors
/// Each refusal, naming `--plot` and the file.
pub fn chart_target(path: &Path) -> anyhow::Result<(PathBuf, String)> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let is_chart = matches!(ext.as_deref(), Some("svg" | "png"));
    let stem = path.file_stem().and_then(|s| s.to_str()).filter(|s| !s.is_empty());
    let (Some(stem), true) = (stem, is_chart) else {
        anyhow::bail!(
            "--plot {}: the chart is an SVG and a PNG file, give a name ending in .svg or .png",
            path.display()
        );
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        anyhow::bail!("--plot {}: directory {} does not exist", path.display(), dir.display());
    }
    // Never replace a file that is not a chart.
    for (ext, magic) in [("svg", &b"<svg"[..]), ("png", &b"\x89PNG"[..])] {
        let p = dir.join(format!("{stem}.{ext}"));
        if p.exists() && !looks_like(&p, magic) {
            anyhow::bail!("--plot: {} exists and is not an {ext} chart; not replaced", p.display());
        }
    }
    Ok((dir, stem.to_string()))
}

/// Whether the file at `p` is a regular file whose first bytes hold `magic`
/// (an SVG may open with an XML declaration: its first 256 bytes are searched).
fn looks_like(p: &Path, magic: &[u8]) -> bool {
    use std::io::Read;
    let Ok(file) = std::fs::File::open(p) else { return false };
    let mut head = Vec::new();
    if file.take(256).read_to_end(&mut head).is_err() || !p.is_file() {
        return false;
    }
    head.windows(magic.len()).any(|w| w == magic)
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
    let svg_tmp = temp_file(dir, stem, "svg")?;
    let png_tmp = match temp_file(dir, stem, "png") {
        Ok(p) => p,
        Err(e) => {
            let _ = std::fs::remove_file(&svg_tmp);
            return Err(e);
        }
    };
    let drawn = draw_both(chart, [&svg_tmp, &png_tmp], [&svg, &png]).and_then(|layout| {
        std::fs::rename(&svg_tmp, &svg).with_context(|| format!("writing {}", svg.display()))?;
        std::fs::rename(&png_tmp, &png).with_context(|| format!("writing {}", png.display()))?;
        Ok(layout)
    });
    let mut layout = match drawn {
        Ok(layout) => layout,
        Err(e) => {
            let _ = std::fs::remove_file(&svg_tmp);
            let _ = std::fs::remove_file(&png_tmp);
            return Err(e);
        }
    };
    layout.stem = stem.to_string();
    Ok(([svg, png], layout))
}

/// Draw `chart` into the temporary files `tmp` (SVG, PNG) for the targets
/// `shown` (named in the errors); the layout as drawn (SVG user units are
/// the PNG's pixels).
///
/// The chart is drawn once, as SVG; the PNG is that SVG rasterised with
/// anti-aliasing ([`rasterise`]), so both files show the same picture and
/// no line or glyph edge is a staircase.
fn draw_both(
    chart: &impl Chart,
    tmp: [&Path; 2],
    shown: [&Path; 2],
) -> anyhow::Result<ChartLayout> {
    let mut svg = String::new();
    let layout = {
        let root = SVGBackend::with_string(&mut svg, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| cannot(shown[0], e))?;
        let layout =
            chart.draw_layout(&root).with_context(|| format!("drawing {}", shown[0].display()))?;
        root.present().map_err(|e| cannot(shown[0], e))?;
        layout
    };
    std::fs::write(tmp[0], &svg).map_err(|e| cannot(shown[0], e))?;
    let png = rasterise(&svg, SIZE).with_context(|| format!("drawing {}", shown[1].display()))?;
    std::fs::write(tmp[1], png).map_err(|e| cannot(shown[1], e))?;
    Ok(layout)
}

/// An SVG document rendered to PNG bytes of `size` pixels, anti-aliased,
/// with the embedded font standing for every generic family.
///
/// # Errors
/// The SVG cannot be parsed or the PNG encoded (never expected for a
/// chart's own SVG).
pub fn rasterise(svg: &str, size: (u32, u32)) -> anyhow::Result<Vec<u8>> {
    use resvg::{tiny_skia, usvg};
    let mut opt = usvg::Options::default();
    {
        let db = opt.fontdb_mut();
        db.load_font_data(font::FONT.to_vec());
        db.set_sans_serif_family(font::FAMILY);
        db.set_serif_family(font::FAMILY);
        db.set_monospace_family(font::FAMILY);
    }
    opt.font_family = font::FAMILY.into();
    let tree = usvg::Tree::from_str(svg, &opt).map_err(|e| anyhow!("SVG: {e}"))?;
    let mut pixmap = tiny_skia::Pixmap::new(size.0, size.1)
        .ok_or_else(|| anyhow!("empty image {}x{}", size.0, size.1))?;
    pixmap.fill(tiny_skia::Color::WHITE);
    let t = tree.size();
    let scale = tiny_skia::Transform::from_scale(
        size.0 as f32 / t.width().max(1.0),
        size.1 as f32 / t.height().max(1.0),
    );
    resvg::render(&tree, scale, &mut pixmap.as_mut());
    pixmap.encode_png().map_err(|e| anyhow!("PNG: {e}"))
}

/// A drawing error in words, naming the file (its `Display`, not the nested
/// `Debug` of the backend's error).
fn cannot(path: &Path, e: impl std::fmt::Display) -> anyhow::Error {
    anyhow!("cannot write {}: {e}", path.display())
}

/// Create an empty temporary file `.STEM.PID-N.tmp.EXT` in `dir` under a
/// name of its own (`O_CREAT | O_EXCL`): processes drawing the same chart
/// into the same directory never share one, and an unwritable directory is
/// refused with the system's words before any drawing.
fn temp_file(dir: &Path, stem: &str, ext: &str) -> anyhow::Result<PathBuf> {
    use std::sync::atomic::{AtomicU64, Ordering};
    static NEXT: AtomicU64 = AtomicU64::new(0);
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    for _ in 0..16 {
        let k = NEXT.fetch_add(1, Ordering::Relaxed);
        let name = format!(".{stem}.{}-{nanos:x}-{k}.tmp.{ext}", std::process::id());
        let path = dir.join(name);
        match std::fs::OpenOptions::new().write(true).create_new(true).open(&path) {
            Ok(_) => return Ok(path),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => bail!("cannot write into {}: {e}", dir.display()),
        }
    }
    bail!("cannot write into {}: no free temporary name", dir.display())
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
    /// Half-widths of vertical error bars, one per point (empty: none). On
    /// a log axis a bar whose lower end would lie below a tenth of its
    /// value (or reach zero) is drawn one decade down and ends in an open
    /// arrow: "reaches down to zero or near it".
    pub y_err: Vec<f64>,
    /// A short label beside each point (the setting it was run at), one
    /// per point (empty: none).
    pub point_labels: Vec<String>,
}

impl Series {
    /// A series with palette colour `colour`.
    pub fn new(
        label: impl Into<String>,
        points: Vec<(f64, f64)>,
        mark: Mark,
        colour: usize,
    ) -> Self {
        Series {
            label: label.into(),
            points,
            mark,
            colour,
            y_err: Vec::new(),
            point_labels: Vec::new(),
        }
    }

    /// The same series with `labels[i]` beside point `i`.
    pub fn with_point_labels(mut self, labels: Vec<String>) -> Self {
        self.point_labels = labels;
        self
    }

    /// The same series with error bars of half-width `y_err[i]` at point `i`.
    pub fn with_y_err(mut self, y_err: Vec<f64>) -> Self {
        self.y_err = y_err;
        self
    }
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

    /// `--plot` takes either name of the pair (`.svg`, `.png`, any case) to
    /// the same directory and stem, and refuses any other ending.
    #[test]
    fn chart_target_takes_either_name_of_the_pair() {
        let dir = std::env::temp_dir();
        for name in ["curve.svg", "curve.png", "curve.PNG"] {
            let (d, stem) = chart_target(&dir.join(name)).unwrap();
            assert_eq!((d, stem.as_str()), (dir.clone(), "curve"));
        }
        for name in ["curve.txt", "curve", ".svg"] {
            let e = chart_target(&dir.join(name)).unwrap_err().to_string();
            assert!(e.contains(".svg or .png"), "{name}: {e}");
        }
    }
}
