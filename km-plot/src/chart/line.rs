//! The line chart (also the Pareto chart): series on linear or logarithmic axes.

use super::*;

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
                    // (on a log axis a bar's lower end is drawn one decade
                    // down at most, see `error_bar`).
                    s.points.iter().enumerate().flat_map(move |(i, p)| {
                        let e = s.y_err.get(i).copied().filter(|e| e.is_finite()).unwrap_or(0.0);
                        if self.y_log {
                            [p.1, p.1 + e, (p.1 - e).max(0.1 * p.1)]
                        } else {
                            [p.1 - e, p.1 + e, p.1]
                        }
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
                    for (end, clipped, open) in [(a, bar.2, bar.4), (b, bar.3, false)] {
                        if !clipped {
                            lay.segments.extend(bar_end(end, open));
                        }
                    }
                    sl.error_bars += 1;
                    sl.bars_cut_at_floor += usize::from(yl && bar.2);
                }
                if let Some(text) = s.point_labels.get(i).filter(|t| !t.is_empty()) {
                    let wh = estimate(text);
                    lay.texts.push(label_box(bc(p), wh));
                    sl.labelled += 1;
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

/// An error bar in axis space: low end, high end, whether each end was
/// cut at the axis, whether the low end is open (an arrow: on a log axis,
/// the bar reaches below a tenth of the value, or zero).
type Bar = ((f64, f64), (f64, f64), bool, bool, bool);

/// A text drawn in the plot: its box (pixels), anchor (axis space) and text.
type Annotation = (PixelRect, (f64, f64), String);

/// The error bar of point `i` (axis space, clipped to the y range).
fn error_bar(s: &Series, i: usize, p: (f64, f64), yl: bool, yr: (f64, f64)) -> Option<Bar> {
    let e = s.y_err.get(i).copied().filter(|e| e.is_finite() && *e >= 0.0)?;
    let y = if yl { 10f64.powf(p.1) } else { p.1 };
    let open = yl && y - e < 0.1 * y;
    let lo = if open { p.1 - 1.0 } else { to_axis(y - e, yl).unwrap_or(f64::NEG_INFINITY) };
    let hi = to_axis(y + e, yl)?;
    let (lo_c, hi_c) = (lo < yr.0, hi > yr.1);
    Some(((p.0, lo.max(yr.0)), (p.0, hi.min(yr.1)), lo_c, hi_c, open))
}

/// The pixel segments of an error bar's end at `q` (pixels): a cap, or
/// for an open end an arrowhead pointing down.
fn bar_end(q: (f64, f64), open: bool) -> Vec<[(f64, f64); 2]> {
    if open {
        vec![[(q.0 - 3.0, q.1 - 5.0), q], [(q.0 + 3.0, q.1 - 5.0), q]]
    } else {
        vec![[(q.0 - 3.0, q.1), (q.0 + 3.0, q.1)]]
    }
}

/// Font size of the points' labels.
const POINT_LABEL_SIZE: u32 = 11;

/// Pixel size of a point label's text (zero when the font cannot tell).
fn estimate(text: &str) -> (u32, u32) {
    let font: FontDesc<'_> = ("sans-serif", POINT_LABEL_SIZE as f64).into_font();
    font.box_size(text).unwrap_or((0, 0))
}

/// Where a point's label goes (pixels of the text's top-left corner) for
/// a point drawn at `c` (pixels), and its box for `text` of size `wh`.
fn label_box(c: (f64, f64), wh: (u32, u32)) -> PixelRect {
    let (x0, y0) = (c.0 + 5.0, c.1 - 5.0 - wh.1 as f64);
    PixelRect { x0, y0, x1: x0 + wh.0 as f64, y1: y0 + wh.1 as f64 }
}

impl Chart for LineChart {
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
        let entries = self.legend_entries();
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
                let (left, r) = legend_outside(&body, legend.size(), plot_px.y0);
                (left, Some(r))
            }
        };
        let mut chart = build(&area)?;
        let (xl, yl) = (self.x_log, self.y_log);
        let (x_ticks, y_ticks) = self.draw_mesh(&mut chart, xr, yr)?;
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
            draw_one_series(root, &mut chart, s, (xl, yl), (xr, yr))?;
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
        layout.x_label = self.x_label.clone();
        layout.x_ticks = x_ticks;
        layout.y_ticks = y_ticks;
        Ok(layout)
    }
}

impl LineChart {
    /// The legend's entries: every labelled series as drawn.
    fn legend_entries(&self) -> Vec<(String, Sample)> {
        self.series
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
            .collect()
    }
}

/// The legend outside the plot, on the right of `body` (whose left part is
/// returned for the chart) with its top at pixel `top`.
fn legend_outside<DB: DrawingBackend>(
    body: &DrawingArea<DB, Shift>,
    size: (f64, f64),
    top: f64,
) -> (DrawingArea<DB, Shift>, PixelRect) {
    let (w, h) = size;
    let (bw, _) = body.dim_in_pixel();
    let split = (bw as f64 - w - 10.0).max(0.5 * bw as f64) as i32;
    let (left, _) = body.split_horizontally(split);
    let (bx, _) = body.get_base_pixel();
    let x = (bx + split) as f64;
    let r = PixelRect { x0: x, y0: top, x1: x + w, y1: top + h };
    (left, r)
}

/// One series: its line clipped to the axis ranges, its points and error
/// bars inside them (caps drawn in pixels on `root`).
fn draw_one_series<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    s: &Series,
    (xl, yl): (bool, bool),
    (xr, yr): ((f64, f64), (f64, f64)),
) -> anyhow::Result<()> {
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
        if let Some((a, b, a_clip, b_clip, open)) = error_bar(s, i, p, yl, yr) {
            chart.draw_series(std::iter::once(PathElement::new(vec![a, b], thin))).map_err(pe)?;
            // Caps (or the open end's arrowhead), in pixels on the root.
            let (rx, ry) = root.get_base_pixel();
            for (end, clipped, open) in [(a, a_clip, open), (b, b_clip, false)] {
                if clipped {
                    continue;
                }
                let q = chart.backend_coord(&end);
                for seg in bar_end((q.0 as f64, q.1 as f64), open) {
                    let px = |p: (f64, f64)| (p.0.round() as i32 - rx, p.1.round() as i32 - ry);
                    root.draw(&PathElement::new(vec![px(seg[0]), px(seg[1])], thin)).map_err(pe)?;
                }
            }
        }
        if let Some(text) = s.point_labels.get(i).filter(|t| !t.is_empty()) {
            let q = chart.backend_coord(&p);
            let r = label_box((q.0 as f64, q.1 as f64), estimate(text));
            let (rx, ry) = root.get_base_pixel();
            let at = (r.x0.round() as i32 - rx, r.y0.round() as i32 - ry);
            let style = TextStyle::from(("sans-serif", POINT_LABEL_SIZE as f64)).color(&c);
            root.draw_text(text, &style, at).map_err(pe)?;
        }
        if matches!(s.mark, Mark::Points | Mark::LinePoints) {
            chart.draw_series(std::iter::once(Circle::new(p, 3, c.filled()))).map_err(pe)?;
        }
    }
    Ok(())
}

impl LineChart {
    /// The axes, labels and grid; returns the tick labels drawn on x and y.
    fn draw_mesh<DB: DrawingBackend>(
        &self,
        chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
        (x0, x1): (f64, f64),
        (y0, y1): (f64, f64),
    ) -> anyhow::Result<(Vec<String>, Vec<String>)> {
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
        Ok((x_ticks.into_inner(), y_ticks.into_inner()))
    }
}
