//! The chart of a phase report: `p(theta)` of every scattering layer and
//! channel (`km phase --plot`).

use std::path::Path;

use anyhow::{Context, Result, bail};
use km::phase_report::PhaseReport;

use crate::chart::{LineChart, Mark, Series, write_chart};

/// The most curves of one chart (the legend stays readable).
const MAX_CURVES: usize = 12;

/// `p(theta)` of every scattering layer and channel (the first
/// [`MAX_CURVES`]), on a log axis.
///
/// # Errors
/// No layer scatters (nothing to draw), and the errors of writing the files.
pub fn write_phase_chart(r: &PhaseReport, dir: &Path, stem: &str) -> Result<()> {
    let mut series = Vec::new();
    let mut total = 0;
    for (i, chans) in r.layers.iter().enumerate() {
        for (c, ch) in chans.iter().enumerate().filter(|(_, ch)| ch.scatters) {
            total += 1;
            if series.len() == MAX_CURVES {
                continue;
            }
            let ch_name = if chans.len() > 1 {
                format!(", {}", km::phase_report::channel_name(r, c))
            } else {
                String::new()
            };
            let label = format!("layer {}{ch_name}: {}, g = {:.3}", i + 1, ch.kind, ch.g);
            let pts = r.angles_deg.iter().copied().zip(ch.p.iter().copied()).collect();
            series.push(Series::new(label, pts, Mark::Line, series.len()));
        }
    }
    if series.is_empty() {
        bail!("--plot: no layer of the scene scatters; there is no phase function to draw");
    }
    let shown = if total > series.len() {
        format!(" (the first {} of {total} curves)", series.len())
    } else {
        String::new()
    };
    let chart = LineChart {
        title: format!("km phase: p(theta), integral p dOmega = 1{shown}"),
        x_label: "scattering angle theta (degrees)".into(),
        y_label: "p (1/sr)".into(),
        y_log: true,
        x_range: Some((0.0, 180.0)),
        series,
        ..Default::default()
    };
    write_chart(dir, stem, &chart)
        .with_context(|| format!("drawing {}/{stem}.svg", dir.display()))?;
    Ok(())
}
