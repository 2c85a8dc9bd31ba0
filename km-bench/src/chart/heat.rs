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
    fn draw_layout<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> anyhow::Result<ChartLayout> {
        let (w, _) = root.dim_in_pixel();
        let (main, bar) = root.split_horizontally(w.saturating_sub(130));
        let nx = self.x.len().max(1);
        let ny = self.y.len().max(1);
        let (lo, hi) = self.colour_range();
        let title = self.full_title();
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
        self.draw_colour_bar(&bar, (lo, hi), &y_ticks)?;
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
        y_ticks: &RefCell<Vec<String>>,
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
        Ok(())
    }
}
