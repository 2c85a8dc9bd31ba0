//! The charts of the fits: the hiding curves of a Kubelka–Munk drawdown fit
//! (`km fit --km --plot`).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use km_inverse::drawdown::{DrawdownFit, hiding_curves};

use crate::chart::{LineChart, Mark, Series, write_chart};

/// Points of the hiding curves (thicknesses from 0 to this many, at most).
const PLOT_POINTS: usize = 200;

/// Draw the fitted film's hiding curves ([`hiding_curves`]: its internal
/// reflectance over the grounds against thickness, the readings at the
/// measured thickness, and `R_inf`) into `dir/km-fit-km.svg` and `.png`
/// (the directory created when absent).
///
/// # Errors
/// A fit without `K` and `S` (nothing to draw), and the errors of the
/// curves and of writing the files.
pub fn write_hiding_curves(fit: &DrawdownFit, dir: &Path) -> Result<[PathBuf; 2]> {
    let Some((curves, x)) = hiding_curves(fit, PLOT_POINTS)? else {
        bail!("--plot needs K and S: give --r-zero and --thickness, or --r-black and --r-white");
    };
    let mut series = Vec::new();
    for (i, c) in curves.into_iter().enumerate() {
        if let Some(r) = c.reading {
            let label = format!("reading, {}", c.label);
            series.push(Series::new(label, vec![(x, r)], Mark::Points, i));
        }
        series.push(Series::new(format!("{} ({})", c.label, c.ground), c.points, Mark::Line, i));
    }
    let (k, s, r_inf) = fit.film.map_or((f64::NAN, f64::NAN, fit.r_inf), |f| (f.k, f.s, f.r_inf));
    let chart = LineChart {
        title: format!("Kubelka–Munk fit: K = {k:.4}, S = {s:.4} (internal reflectance)"),
        x_label: "film thickness".into(),
        y_label: "reflectance".into(),
        y_range: Some((0.0, 1.0)),
        series,
        h_lines: vec![(r_inf, format!("R_inf = {r_inf:.4}"))],
        ..Default::default()
    };
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    write_chart(dir, "km-fit-km", &chart)
}
