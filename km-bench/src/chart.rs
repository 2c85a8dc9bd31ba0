//! Charts: line charts (linear or logarithmic axes), polar plots of a
//! distribution in the plane of incidence, heat maps and Pareto scatters.
//!
//! Every chart is a plain description (data plus labels) implementing
//! [`Chart`]; [`write_chart`] draws it twice, as `STEM.svg` and `STEM.png`.
//! Logarithmic axes are drawn by plotting `log10` of the data on a linear
//! axis and labelling the ticks with `10^v`, so every chart uses the same
//! coordinate type.

use std::path::{Path, PathBuf};

use anyhow::{Context, anyhow};
use plotters::coord::Shift;
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
    font::ensure_registered()?;
    let svg = dir.join(format!("{stem}.svg"));
    let png = dir.join(format!("{stem}.png"));
    {
        let root = SVGBackend::new(&svg, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(pe)?;
        chart.draw(&root).with_context(|| format!("drawing {}", svg.display()))?;
        root.present().map_err(pe)?;
    }
    {
        let root = BitMapBackend::new(&png, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(pe)?;
        chart.draw(&root).with_context(|| format!("drawing {}", png.display()))?;
        root.present().map_err(pe)?;
    }
    Ok([svg, png])
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
}

impl Series {
    /// A series with palette colour `colour`.
    pub fn new(
        label: impl Into<String>,
        points: Vec<(f64, f64)>,
        mark: Mark,
        colour: usize,
    ) -> Self {
        Series { label: label.into(), points, mark, colour }
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

/// Tick label of an axis value.
fn tick(v: f64, log: bool) -> String {
    if log { format_number(10f64.powf(v)) } else { format_number(v) }
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

impl Chart for LineChart {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> anyhow::Result<()> {
        let (x0, x1) = axis_range(
            self.series.iter().flat_map(|s| s.points.iter().map(|p| p.0)),
            self.x_log,
            self.x_range,
        );
        let (y0, y1) = axis_range(
            self.series
                .iter()
                .flat_map(|s| s.points.iter().map(|p| p.1))
                .chain(self.h_lines.iter().map(|h| h.0)),
            self.y_log,
            self.y_range,
        );
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(pe)?;
        let (xl, yl) = (self.x_log, self.y_log);
        chart
            .configure_mesh()
            .x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .x_label_formatter(&|v| tick(*v, xl))
            .y_label_formatter(&|v| tick(*v, yl))
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 15))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(pe)?;
        for (y, label) in &self.h_lines {
            if let Some(ya) = to_axis(*y, yl) {
                let style = ShapeStyle::from(&BLACK.mix(0.5)).stroke_width(1);
                chart
                    .draw_series(DashedLineSeries::new(vec![(x0, ya), (x1, ya)], 4, 4, style))
                    .map_err(pe)?;
                chart
                    .draw_series(std::iter::once(Text::new(
                        label.clone(),
                        (x0 + 0.01 * (x1 - x0), ya),
                        ("sans-serif", 12),
                    )))
                    .map_err(pe)?;
            }
        }
        let mut any_label = false;
        for s in &self.series {
            let c = colour(s.colour);
            let pts: Vec<(f64, f64)> = s
                .points
                .iter()
                .filter_map(|&(x, y)| Some((to_axis(x, xl)?, to_axis(y, yl)?)))
                .collect();
            let style = ShapeStyle::from(&c).stroke_width(2);
            let legend_style = style;
            let anno = match s.mark {
                Mark::Line => chart.draw_series(LineSeries::new(pts, style)).map_err(pe)?,
                Mark::Dashed => {
                    chart.draw_series(DashedLineSeries::new(pts, 6, 4, style)).map_err(pe)?
                }
                Mark::Points => chart
                    .draw_series(pts.iter().map(|&p| Circle::new(p, 3, c.filled())))
                    .map_err(pe)?,
                Mark::LinePoints => {
                    chart.draw_series(LineSeries::new(pts.clone(), style)).map_err(pe)?;
                    chart
                        .draw_series(pts.iter().map(|&p| Circle::new(p, 3, c.filled())))
                        .map_err(pe)?
                }
            };
            if !s.label.is_empty() {
                any_label = true;
                anno.label(s.label.clone()).legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], legend_style)
                });
            }
        }
        if any_label {
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK.mix(0.4))
                .label_font(("sans-serif", 13))
                .draw()
                .map_err(pe)?;
        }
        Ok(())
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
        // Radial scale: the largest value of the curves (spikes are clipped at 1.15 of it).
        let mut r_max = self
            .curves
            .iter()
            .flat_map(|c| c.points.iter().map(|p| p.1))
            .filter(|v| v.is_finite())
            .fold(0.0f64, f64::max);
        if r_max <= 0.0 {
            r_max = self.spikes.iter().map(|s| s.length).fold(0.0f64, f64::max);
        }
        if r_max <= 0.0 || !r_max.is_finite() {
            r_max = 1.0;
        }
        let lim = 1.2 * r_max;
        let (w, h) = root.dim_in_pixel();
        // Equal aspect: x spans more than y in proportion to the pixel area.
        let aspect = (w as f64 - 40.0) / (h as f64 - 60.0);
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, ("sans-serif", 20))
            .margin(12)
            .build_cartesian_2d(-lim * aspect..lim * aspect, -lim..lim)
            .map_err(pe)?;
        // Radial grid: circles at quarter steps of a round scale value, with labels.
        let step = nice_step(r_max / 4.0);
        let grey = RGBColor(200, 200, 200);
        let mut r = step;
        while r <= lim * 1.0001 {
            let circle: Vec<(f64, f64)> = (0..=180)
                .map(|k| {
                    let a = k as f64 * 2.0 * std::f64::consts::PI / 180.0;
                    (r * a.sin(), r * a.cos())
                })
                .collect();
            chart.draw_series(LineSeries::new(circle, grey)).map_err(pe)?;
            chart
                .draw_series(std::iter::once(Text::new(
                    format_number(r),
                    (r * 0.05, r + 0.01 * lim),
                    ("sans-serif", 11).into_font().color(&RGBColor(120, 120, 120)),
                )))
                .map_err(pe)?;
            r += step;
        }
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
        // Incident beam: from the upper left towards the origin.
        if let Some(t) = self.incidence_deg {
            let a = (-t).to_radians();
            let (x, y) = (lim * 0.95 * a.sin(), lim * 0.95 * a.cos());
            let style = ShapeStyle::from(&BLACK).stroke_width(2);
            chart
                .draw_series(std::iter::once(PathElement::new(vec![(x, y), (0.0, 0.0)], style)))
                .map_err(pe)?;
            chart
                .draw_series(std::iter::once(Text::new(
                    format!("incident {t:.0} deg"),
                    (x, y),
                    ("sans-serif", 12),
                )))
                .map_err(pe)?;
        }
        // Curves.
        let mut any_label = false;
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
            let style = ShapeStyle::from(&col).stroke_width(2);
            let anno = if c.dashed {
                chart.draw_series(DashedLineSeries::new(pts, 6, 4, style)).map_err(pe)?
            } else {
                chart.draw_series(LineSeries::new(pts, style)).map_err(pe)?
            };
            if !c.label.is_empty() {
                any_label = true;
                anno.label(c.label.clone())
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
            }
        }
        // Spikes for delta parts, clipped to the plot.
        for s in &self.spikes {
            let a = s.psi_deg.to_radians();
            let len = s.length.min(1.15 * r_max);
            let (x, y) = (len * a.sin(), len * a.cos());
            let style = ShapeStyle::from(&RGBColor(90, 90, 90)).stroke_width(3);
            chart
                .draw_series(std::iter::once(PathElement::new(vec![(0.0, 0.0), (x, y)], style)))
                .map_err(pe)?;
            chart
                .draw_series(std::iter::once(Text::new(
                    s.label.clone(),
                    (x, y),
                    ("sans-serif", 12),
                )))
                .map_err(pe)?;
        }
        if any_label {
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK.mix(0.4))
                .label_font(("sans-serif", 13))
                .draw()
                .map_err(pe)?;
        }
        if !self.r_label.is_empty() {
            root.draw(&Text::new(
                format!("radius: {}", self.r_label),
                (14, h as i32 - 22),
                ("sans-serif", 13),
            ))
            .map_err(pe)?;
        }
        Ok(())
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
        let fx = move |v: &f64| {
            at(*v)
                .and_then(|i| xs.get(i))
                .map(|x| if xlog { format!("{x:.0e}") } else { format!("{x}") })
                .unwrap_or_default()
        };
        let fy = move |v: &f64| {
            at(*v).and_then(|i| ys.get(i)).map(|y| format!("{y}")).unwrap_or_default()
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
        cb.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_desc(&self.z_label)
            .label_style(("sans-serif", 12))
            .axis_desc_style(("sans-serif", 13))
            .y_label_formatter(&|v| tick(*v, zlog))
            .draw()
            .map_err(pe)?;
        let steps = 64;
        cb.draw_series((0..steps).map(|k| {
            let a = lo + (hi - lo) * k as f64 / steps as f64;
            let b = lo + (hi - lo) * (k + 1) as f64 / steps as f64;
            Rectangle::new([(0.0, a), (1.0, b)], viridis((k as f64 + 0.5) / steps as f64).filled())
        }))
        .map_err(pe)?;
        Ok(())
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
