//! The heat map with its colour bar.

use super::*;

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
    /// Cells marked with a cross, `marked[iy][ix]` (empty: none), e.g. the
    /// Monte Carlo cells whose photons met the step cap.
    pub marked: Vec<Vec<bool>>,
    /// What a cross means, drawn under the title when any cell is marked.
    pub mark_note: String,
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

    /// Number of cells marked with a cross.
    pub fn marked_cells(&self) -> usize {
        self.marked.iter().flatten().filter(|m| **m).count()
    }

    /// Number of refused cells (`None`).
    pub fn refused_cells(&self) -> usize {
        self.z.iter().flatten().filter(|v| v.is_none()).count()
    }
}

impl Chart for HeatMap {
    fn draw_layout<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> anyhow::Result<ChartLayout> {
        let (w, _) = root.dim_in_pixel();
        let (main, bar) = root.split_horizontally(w.saturating_sub(130));
        let nx = self.x.len().max(1);
        let ny = self.y.len().max(1);
        let (lo, hi) = self.colour_range();
        let marked = self.marked_cells();
        let main = main.titled(&self.full_title(), ("sans-serif", 18)).map_err(pe)?;
        let mut notes = Vec::new();
        let main = if marked > 0 && !self.mark_note.is_empty() {
            let (strip, rest) = main.split_vertically(22);
            let (sw, _) = strip.dim_in_pixel();
            let note = format!("\u{d7} ({marked} cells): {}", self.mark_note);
            let style =
                TextStyle::from(("sans-serif", 13)).pos(plotters::style::text_anchor::Pos::new(
                    plotters::style::text_anchor::HPos::Center,
                    plotters::style::text_anchor::VPos::Top,
                ));
            strip.draw_text(&note, &style, (sw as i32 / 2, 2)).map_err(pe)?;
            notes.push(note);
            rest
        } else {
            main
        };
        let x_axis = CellAxis::new(&self.x, self.x_log);
        let y_axis = CellAxis::new(&self.y, false);
        let mut chart = ChartBuilder::on(&main)
            .margin(10)
            .x_label_area_size(45)
            .y_label_area_size(60)
            .build_cartesian_2d(-0.5..nx as f64 - 0.5, -0.5..ny as f64 - 0.5)
            .map_err(pe)?;
        // The axes and their descriptions by plotters; the ticks by
        // `CellAxis` (cell centres or round cell edges), drawn below.
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .x_labels(0)
            .y_labels(0)
            .axis_desc_style(("sans-serif", 15))
            .draw()
            .map_err(pe)?;
        let x_ticks = draw_ticks(&main, &chart, &x_axis, 13, true)?;
        let y_ticks = draw_ticks(&main, &chart, &y_axis, 14, false)?;
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
        let cross = ShapeStyle::from(&WHITE).stroke_width(2);
        for (iy, row) in self.marked.iter().enumerate() {
            for (ix, _) in row.iter().enumerate().filter(|c| *c.1) {
                let (x, y) = (ix as f64, iy as f64);
                for (a, b) in [((-0.3, -0.3), (0.3, 0.3)), ((-0.3, 0.3), (0.3, -0.3))] {
                    let line = vec![(x + a.0, y + a.1), (x + b.0, y + b.1)];
                    chart
                        .draw_series(std::iter::once(PathElement::new(line, cross)))
                        .map_err(pe)?;
                }
            }
        }
        let z_ticks = RefCell::new(Vec::new());
        self.draw_colour_bar(&bar, (lo, hi), &z_ticks)?;
        let (xs, ys) = chart.plotting_area().get_pixel_range();
        Ok(ChartLayout {
            kind: "heat".into(),
            plot: prect((xs.start, ys.start), (xs.end, ys.end)),
            x_ticks,
            y_ticks,
            z_ticks: z_ticks.into_inner(),
            marked_cells: marked,
            notes,
            ..Default::default()
        })
    }
}

/// Draw the ticks of one axis (`x`: the bottom one, else the left one)
/// with their labels on `area`, outside the plot; the labels drawn.
fn draw_ticks<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    chart: &ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    axis: &CellAxis,
    max: usize,
    x: bool,
) -> anyhow::Result<Vec<String>> {
    use plotters::style::text_anchor::{HPos, Pos, VPos};
    let (bx, by) = area.get_base_pixel();
    let (xs, ys) = chart.plotting_area().get_pixel_range();
    let pos =
        if x { Pos::new(HPos::Center, VPos::Top) } else { Pos::new(HPos::Right, VPos::Center) };
    let style = TextStyle::from(("sans-serif", 13)).pos(pos);
    let mut labels = Vec::new();
    for v in axis.positions(max) {
        let label = axis.label(v);
        if label.is_empty() {
            continue;
        }
        let (px, py) = if x {
            (chart.backend_coord(&(v, 0.0)).0 - bx, ys.end - by)
        } else {
            (xs.start - bx, chart.backend_coord(&(0.0, v)).1 - by)
        };
        let tick = if x { [(px, py), (px, py + 5)] } else { [(px - 5, py), (px, py)] };
        area.draw(&PathElement::new(tick.to_vec(), BLACK)).map_err(pe)?;
        let at = if x { (px, py + 7) } else { (px - 8, py) };
        area.draw_text(&label, &style, at).map_err(pe)?;
        labels.push(label);
    }
    Ok(labels)
}

/// Push a non-empty tick label into `ticks`; the label back.
fn record(ticks: &RefCell<Vec<String>>, s: String) -> String {
    if !s.is_empty() {
        ticks.borrow_mut().push(s.clone());
    }
    s
}

/// One axis of cells: where its ticks go (in index space, cell `i`
/// centred on `i`) and what they say.
///
/// * Cells of equal width on a linear axis are labelled on a round step;
///   those whose edges are rounder
///   numbers than their centres (azimuth cells 0-5, 5-10, ... centred on
///   2.5, 7.5, ...) are labelled at their edges, every `k`-th edge with
///   `k` the smallest giving at most `max` labels on a round step
///   (1, 1.5, 2, 2.5, 3, 4.5 or 5 times a power of ten).
/// * Otherwise every `k`-th cell is labelled at its centre, with the
///   fewest significant digits (4 to 6) that keep the labels distinct.
struct CellAxis {
    /// Centre values.
    centres: Vec<f64>,
    /// Logarithmic axis (labels as powers of ten).
    log: bool,
    /// Equally spaced cells: (first labelled value, cell width, labelled
    /// at the edges rather than the centres).
    uniform: Option<(f64, f64, bool)>,
    /// Significant digits of the centre labels.
    digits: usize,
}

impl CellAxis {
    fn new(centres: &[f64], log: bool) -> Self {
        let centres = centres.to_vec();
        let uniform = if log { None } else { uniform_cells(&centres) };
        let digits = (4..=6)
            .find(|&d| {
                let mut l: Vec<String> = centres.iter().map(|&v| format_sig(v, d, false)).collect();
                l.sort();
                l.dedup();
                l.len() == centres.len()
            })
            .unwrap_or(6);
        CellAxis { centres, log, uniform, digits }
    }

    /// Tick positions (index space), at most about `max`.
    fn positions(&self, max: usize) -> Vec<f64> {
        let n = self.centres.len().max(1);
        if let Some((first, width, edges)) = self.uniform {
            // Labelled places: the n + 1 edges or the n centres.
            let places = if edges { n + 1 } else { n };
            let offset = if edges { -0.5 } else { 0.0 };
            let k = (1..=places)
                .find(|&k| places.div_ceil(k) <= max && nice_step(k as f64 * width))
                .unwrap_or_else(|| places.div_ceil(max.max(1)).max(1));
            let step = k as f64 * width;
            // Start at the first place on a multiple of the step.
            let start = (0..places)
                .find(|&j| {
                    let v = (first + j as f64 * width) / step;
                    (v - v.round()).abs() < 1e-6
                })
                .unwrap_or(0);
            return (start..places).step_by(k).map(|j| j as f64 + offset).collect();
        }
        let k = n.div_ceil(max.max(1)).max(1);
        (0..n).step_by(k).map(|i| i as f64).collect()
    }

    /// The label of the tick at index-space position `v`.
    fn label(&self, v: f64) -> String {
        if let Some((first, width, true)) = self.uniform {
            let e = v + 0.5;
            if (e - e.round()).abs() > 1e-6 || e < -1e-6 || e > self.centres.len() as f64 + 1e-6 {
                return String::new();
            }
            return format_sig(first + e.round() * width, 6, false);
        }
        if (v - v.round()).abs() > 1e-6 || v < -0.5 {
            return String::new();
        }
        match self.centres.get(v.round() as usize) {
            Some(&x) if self.log && x > 0.0 => format_tick(x.log10(), -30.0, 30.0, true),
            Some(&x) => format_sig(x, self.digits, false),
            None => String::new(),
        }
    }
}

/// For equally spaced centres: `(first value, width, edges)`, labelled at
/// the edges (`first` the first edge) when they need fewer significant
/// digits than the centres, else at the centres (`first` the first centre).
fn uniform_cells(c: &[f64]) -> Option<(f64, f64, bool)> {
    if c.len() < 2 {
        return None;
    }
    let w = c[1] - c[0];
    let scale = c.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(w.abs());
    if w.is_nan() || w <= 0.0 || c.windows(2).any(|p| ((p[1] - p[0]) - w).abs() > 1e-9 * scale) {
        return None;
    }
    let digits = |v: f64| -> usize {
        let s = format_sig(v, 6, false);
        s.trim_start_matches('-').trim_start_matches(['0', '.']).replace('.', "").len()
    };
    let first = c[0] - 0.5 * w;
    let edge_digits = (0..=c.len()).map(|e| digits(first + e as f64 * w)).max().unwrap_or(0);
    let centre_digits = c.iter().map(|&v| digits(v)).max().unwrap_or(0);
    Some(if edge_digits < centre_digits { (first, w, true) } else { (c[0], w, false) })
}

/// Whether `step` is 1, 1.5, 2, 2.5, 3, 4.5 or 5 times a power of ten
/// (15, 30 and 45 for angles in degrees; 9 or 6 would label 0, 9, 18, ...).
fn nice_step(step: f64) -> bool {
    if step.is_nan() || step <= 0.0 || !step.is_finite() {
        return false;
    }
    let m = step / 10f64.powf(step.log10().floor());
    [1.0, 1.5, 2.0, 2.5, 3.0, 4.5, 5.0, 10.0].iter().any(|n| (m - n).abs() < 1e-6)
}

impl HeatMap {
    /// The colour scale `(lo, hi)` over the cells' colour values (from the
    /// floor on a floored log scale), at least a unit wide on a log scale.
    fn colour_range(&self) -> (f64, f64) {
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
        (lo, hi)
    }

    /// The title with the counts of NaN and refused cells.
    fn full_title(&self) -> String {
        let (bad, refused) = (self.invalid_cells(), self.refused_cells());
        let mut title = self.title.clone();
        if bad > 0 {
            title += &format!(" [{bad} NaN: magenta]");
        }
        if refused > 0 {
            title += &format!(" [{refused} refused: grey]");
        }
        title
    }

    /// The colour bar on `bar` over `(lo, hi)`; its tick labels go into `y_ticks`.
    fn draw_colour_bar<DB: DrawingBackend>(
        &self,
        bar: &DrawingArea<DB, Shift>,
        (lo, hi): (f64, f64),
        z_ticks: &RefCell<Vec<String>>,
    ) -> anyhow::Result<()> {
        // Colour bar.
        let mut cb = ChartBuilder::on(bar)
            .margin_top(40)
            .margin_bottom(55)
            .margin_right(10)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..1.0, lo..hi)
            .map_err(pe)?;
        let zlog = self.z_log;
        let fz = |v: &f64| record(z_ticks, format_tick(*v, lo, hi, zlog));
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
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn labels(axis: &CellAxis, max: usize) -> Vec<String> {
        axis.positions(max).into_iter().map(|v| axis.label(v)).collect()
    }

    #[test]
    fn azimuth_cells_are_labelled_at_round_edges() {
        // 72 cells of 5 degrees centred on 2.5 ... 357.5.
        let centres: Vec<f64> = (0..72).map(|i| 2.5 + 5.0 * i as f64).collect();
        let l = labels(&CellAxis::new(&centres, false), 13);
        let want: Vec<String> = (0..=12).map(|k| (30 * k).to_string()).collect();
        assert_eq!(l, want);
        // Fewer labels allowed: a coarser round step.
        let l = labels(&CellAxis::new(&centres, false), 9);
        assert_eq!(l, ["0", "45", "90", "135", "180", "225", "270", "315", "360"]);
    }

    #[test]
    fn close_rows_get_distinct_labels() {
        let rows = [0.0, 0.5, 0.99, 0.9999, 0.999999, 1.0];
        let l = labels(&CellAxis::new(&rows, false), 14);
        assert_eq!(l, ["0", "0.5", "0.99", "0.9999", "0.999999", "1"]);
        // Rows 0, 1, ..., 89: every tenth, on round values.
        let rows: Vec<f64> = (0..90).map(f64::from).collect();
        let want: Vec<String> = (0..9).map(|k| (10 * k).to_string()).collect();
        assert_eq!(labels(&CellAxis::new(&rows, false), 14), want);
        // Uneven rows are labelled at their centres, all of them.
        let thetas = [1.5, 8.0, 19.7];
        assert_eq!(labels(&CellAxis::new(&thetas, false), 14), ["1.5", "8", "19.7"]);
    }
}
