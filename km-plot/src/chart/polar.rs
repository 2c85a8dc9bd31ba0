//! The polar plot of a distribution in the plane of incidence.

use super::*;

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
    fn draw_layout<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> anyhow::Result<ChartLayout> {
        // Radial scale: the largest value of the curves.
        let r_max = self.radial_scale();
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
        // Radial grid: circles at quarter steps of a round scale value, with labels.
        layout.y_ticks = radial_grid(&mut chart, r_max, lim)?;
        // Normal (vertical, dotted) and surface (horizontal, solid).
        chart
            .draw_series(DashedLineSeries::new(
                vec![(0.0, -lim), (0.0, lim)],
                3,
                5,
                ShapeStyle::from(&GRID_GREY),
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
            layout.texts.push(text_box(root, &label, at, 12)?);
            let (rx, ry) = root.get_base_pixel();
            root.draw(&Text::new(label, (at.0 - rx, at.1 - ry), ("sans-serif", 12))).map_err(pe)?;
        }
        // Curves.
        let mut entries = Vec::new();
        for c in &self.curves {
            if let Some(entry) = draw_curve(&mut chart, c, &bc, &mut layout)? {
                entries.push(entry);
            }
        }
        // Spikes for delta parts, cut at SPIKE_CLIP r_max with a chevron when longer.
        for spike in &self.spikes {
            draw_spike(root, &mut chart, spike, r_max, &bc, &mut layout)?;
        }
        if !entries.is_empty() {
            draw_legend(root, entries, &mut layout)?;
        }
        if !self.r_label.is_empty() {
            let text = format!("radius: {}", self.r_label);
            let (_, rh) = root.dim_in_pixel();
            root.draw(&Text::new(text, (14, rh as i32 - 22), ("sans-serif", 13))).map_err(pe)?;
        }
        Ok(layout)
    }
}

/// Spikes longer than this fraction of the curves' largest value are cut
/// there and marked with a chevron.
const SPIKE_CLIP: f64 = 1.05;

impl PolarChart {
    /// The radial scale: the largest value of the curves, else of the
    /// spikes, else 1.
    fn radial_scale(&self) -> f64 {
        let finite_max =
            |v: &mut dyn Iterator<Item = f64>| v.filter(|v| v.is_finite()).fold(0.0f64, f64::max);
        let mut r_max =
            finite_max(&mut self.curves.iter().flat_map(|c| c.points.iter().map(|p| p.1)));
        if r_max <= 0.0 {
            r_max = finite_max(&mut self.spikes.iter().map(|s| s.length));
        }
        if r_max <= 0.0 || !r_max.is_finite() { 1.0 } else { r_max }
    }
}

/// The pixel box of `text` at `at` (pixels of the backend).
fn text_box<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    text: &str,
    at: (i32, i32),
    size: u32,
) -> anyhow::Result<PixelRect> {
    let (tw, th) = root.estimate_text_size(text, &("sans-serif", size).into()).map_err(pe)?;
    Ok(PixelRect {
        x0: at.0 as f64,
        y0: at.1 as f64,
        x1: (at.0 + tw as i32) as f64,
        y1: (at.1 + th as i32) as f64,
    })
}

/// One spike (a delta part) from the origin, cut at [`SPIKE_CLIP`] times
/// the radial scale `r_max` with an outward chevron when longer, labelled beside its tip; `bc` maps chart
/// coordinates to backend pixels.
fn draw_spike<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    chart: &mut PolarContext<'_, DB>,
    s: &PolarSpike,
    r_max: f64,
    bc: &dyn Fn((f64, f64)) -> (i32, i32),
    layout: &mut ChartLayout,
) -> anyhow::Result<()> {
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
            let side = (tip.0 - back * dx + sign * half * px, tip.1 - back * dy + sign * half * py);
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
    layout.texts.push(text_box(root, &label, at, 12)?);
    let (rx, ry) = root.get_base_pixel();
    root.draw(&Text::new(label, (at.0 - rx, at.1 - ry), ("sans-serif", 12))).map_err(pe)?;
    Ok(())
}

/// Colour of the radial grid and the normal.
const GRID_GREY: RGBColor = RGBColor(200, 200, 200);

/// The chart type of the polar plot (linear in both axes).
type PolarContext<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Circles at round radial steps up to `lim`, labelled; returns the labels.
fn radial_grid<DB: DrawingBackend>(
    chart: &mut PolarContext<'_, DB>,
    r_max: f64,
    lim: f64,
) -> anyhow::Result<Vec<String>> {
    let step = nice_step(r_max / 4.0);
    let mut r = step;
    let mut ticks = Vec::new();
    while r <= lim * 1.0001 {
        let circle: Vec<(f64, f64)> = (0..=180)
            .map(|k| {
                let a = k as f64 * 2.0 * std::f64::consts::PI / 180.0;
                (r * a.sin(), r * a.cos())
            })
            .collect();
        chart.draw_series(LineSeries::new(circle, GRID_GREY)).map_err(pe)?;
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
    Ok(ticks)
}

/// One curve (points `(psi, value)` drawn at radius `value`); its segments
/// go into `layout`; returns its legend entry when it has a label.
fn draw_curve<DB: DrawingBackend>(
    chart: &mut PolarContext<'_, DB>,
    c: &PolarCurve,
    bc: &dyn Fn((f64, f64)) -> (i32, i32),
    layout: &mut ChartLayout,
) -> anyhow::Result<Option<(String, Sample)>> {
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
        ..Default::default()
    });
    let style = ShapeStyle::from(&col).stroke_width(2);
    if c.dashed {
        chart.draw_series(DashedLineSeries::new(pts, 6, 4, style)).map_err(pe)?;
    } else {
        chart.draw_series(LineSeries::new(pts, style)).map_err(pe)?;
    }
    if c.label.is_empty() {
        return Ok(None);
    }
    let mark = if c.dashed { Mark::Dashed } else { Mark::Line };
    Ok(Some((c.label.clone(), Sample { colour: col, mark, error_bar: false })))
}

/// The legend in the first empty place of the plot, else in the upper right
/// corner of the whole area.
fn draw_legend<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    entries: Vec<(String, Sample)>,
    layout: &mut ChartLayout,
) -> anyhow::Result<()> {
    let legend = Legend::measure(root, entries)?;
    let place = legend.place_inside(layout.plot, layout);
    let rect = place.unwrap_or_else(|| {
        // No empty place: the upper right corner of the whole area.
        let (ww, _) = legend.size();
        let (bx, by) = root.get_base_pixel();
        let (rw, _) = root.dim_in_pixel();
        let x = bx as f64 + rw as f64 - ww - 4.0;
        PixelRect { x0: x, y0: by as f64 + 4.0, x1: x + ww, y1: by as f64 + 4.0 + legend.size().1 }
    });
    legend.draw(root, rect)?;
    layout.legend = Some(rect);
    Ok(())
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
