//! The chart of a depth field: `phi(z)` and `A(z)` of every channel
//! (`km field --plot`).

use std::path::Path;

use anyhow::{Context, Result};
use km::field::Field;

use crate::chart::{LineChart, Mark, Series, write_chart};

/// phi(z) and A(z) of every channel against depth (Monte Carlo with error
/// bars) into `dir/stem.svg` and `.png`.
///
/// # Errors
/// Those of writing the files.
pub fn write_field_chart(f: &Field, dir: &Path, stem: &str) -> Result<()> {
    let mut series = Vec::new();
    for (c, label) in f.labels.iter().enumerate() {
        let ch = if f.labels.len() > 1 { format!(" ({label})") } else { String::new() };
        let pts = |v: &Vec<Vec<f64>>| f.depths.iter().copied().zip(v[c].iter().copied()).collect();
        let mark = if f.stderr.is_some() { Mark::LinePoints } else { Mark::Line };
        let mut phi = Series::new(format!("phi(z){ch}"), pts(&f.fluence), mark, 2 * c);
        let mut a = Series::new(format!("A(z){ch}"), pts(&f.absorbed), Mark::Dashed, 2 * c + 1);
        if let Some(e) = &f.stderr {
            phi = phi.with_y_err(e.fluence[c].clone());
            a = a.with_y_err(e.absorbed[c].clone());
        }
        series.extend([phi, a]);
    }
    let chart = LineChart {
        title: format!("km field, {}: fluence rate and absorbed power density", f.method),
        x_label: "depth z".into(),
        y_label: "phi (per unit irradiance), A (per unit depth)".into(),
        series,
        ..Default::default()
    };
    write_chart(dir, stem, &chart)
        .with_context(|| format!("drawing {}/{stem}.svg", dir.display()))?;
    Ok(())
}
