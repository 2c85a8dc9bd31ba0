//! The defects a drawn chart must not have, read from its layout
//! ([`ChartLayout`], pixels of the PNG as drawn) and its pixels, for the
//! tests of every crate that draws charts:
//!
//! * every tick label parses as a number and has at most 4 significant digits;
//! * no legend box meets a drawn data segment, marker or annotation, and
//!   every legend lies inside the image;
//! * every Monte Carlo series (label naming "Monte Carlo" or "MC") has an
//!   error bar at each of its drawn points;
//! * heat-map axes: no repeated label, labels on multiples of their step,
//!   marked cells explained by a note;
//! * slanted lines are anti-aliased ([`lines_aliased`]);
//! * companion charts of one study share their x axis ([`companion_defects`]).
//!
//! The overlap is computed here independently of the chart module's own
//! placement test (which clips segments exactly): each segment is sampled
//! every half pixel and each sample tested against the legend box.

use std::path::Path;

use anyhow::anyhow;
use resvg::tiny_skia::Pixmap;

use crate::chart::{ChartLayout, PixelRect, SIZE};

/// Significant digits of a decimal or `m e p` number as written (leading
/// zeros never count; trailing zeros of an integer mantissa do not count).
pub fn significant_digits(label: &str) -> usize {
    let s = label.trim_start_matches(['-', '+']);
    let mantissa = s.split(['e', 'E']).next().unwrap_or("");
    let digits: String = mantissa.chars().filter(|c| c.is_ascii_digit()).collect();
    let digits = digits.trim_start_matches('0');
    let digits = if mantissa.contains('.') { digits } else { digits.trim_end_matches('0') };
    digits.len().max(1)
}

/// Whether a segment comes within the box, by sampling it every half pixel.
fn segment_meets(r: &PixelRect, a: (f64, f64), b: (f64, f64)) -> bool {
    let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
    let n = (len / 0.5).ceil().max(1.0) as usize;
    (0..=n).any(|k| {
        let t = k as f64 / n as f64;
        let (x, y) = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
        x >= r.x0 && x <= r.x1 && y >= r.y0 && y <= r.y1
    })
}

/// The defects of one heat-map axis's labels: repeated labels (two rows
/// both "1"), more than 6 significant digits, and evenly spaced labels that
/// are not multiples of their spacing (azimuth ticks at 2.5, 52.5, ...).
fn heat_axis_defects(axis: &str, labels: &[String]) -> Vec<String> {
    let mut out = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for t in labels {
        if !seen.insert(t) {
            out.push(format!("{axis} label {t:?} repeated"));
        }
        if significant_digits(t) > 6 {
            out.push(format!("{axis} label {t:?} has more than 6 significant digits"));
        }
    }
    let v: Vec<f64> = labels.iter().filter_map(|t| t.parse().ok()).collect();
    if v.len() >= 3 {
        let d = v[1] - v[0];
        let even = v.windows(2).all(|w| ((w[1] - w[0]) - d).abs() <= 1e-9 * d.abs().max(1.0));
        if even && d != 0.0 && v.iter().any(|x| ((x / d) - (x / d).round()).abs() > 1e-6) {
            out.push(format!("{axis} labels {labels:?} are not on multiples of their step {d}"));
        }
    }
    out
}

/// Every defect of one chart's layout, as text.
pub fn defects(l: &ChartLayout) -> Vec<String> {
    let mut out = Vec::new();
    for t in l.x_ticks.iter().chain(&l.y_ticks).chain(&l.z_ticks) {
        if t.parse::<f64>().is_err() {
            out.push(format!("tick label {t:?} is not a number"));
        } else if l.kind != "heat" && significant_digits(t) > 4 {
            out.push(format!("tick label {t:?} has more than 4 significant digits"));
        }
    }
    if l.kind == "heat" {
        out.extend(heat_axis_defects("x", &l.x_ticks));
        out.extend(heat_axis_defects("y", &l.y_ticks));
        out.extend(
            l.z_ticks
                .iter()
                .filter(|t| significant_digits(t) > 4)
                .map(|t| format!("colour-bar label {t:?} has more than 4 significant digits")),
        );
        if l.marked_cells > 0 && l.notes.is_empty() {
            out.push(format!(
                "{} marked cells and no note saying what a mark means",
                l.marked_cells
            ));
        }
    }
    if let Some(r) = &l.legend {
        let (w, h) = (SIZE.0 as f64, SIZE.1 as f64);
        if r.x0 < 0.0 || r.y0 < 0.0 || r.x1 > w || r.y1 > h {
            out.push(format!("legend {r:?} leaves the {w}x{h} image"));
        }
        if let Some(s) = l.segments.iter().find(|s| segment_meets(r, s[0], s[1])) {
            out.push(format!("legend {r:?} meets the segment {s:?}"));
        }
        if let Some(m) = l.markers.iter().find(|m| r.meets(m)) {
            out.push(format!("legend {r:?} meets the marker {m:?}"));
        }
        if let Some(t) = l.texts.iter().find(|t| r.meets(t)) {
            out.push(format!("legend {r:?} meets the annotation {t:?}"));
        }
    }
    for s in &l.series {
        let lower = s.label.to_lowercase();
        let mc = lower.contains("monte carlo")
            || lower.contains("montecarlo")
            || s.label.split(' ').any(|w| w == "MC");
        if s.bars_cut_at_floor > 0 {
            out.push(format!(
                "series {:?}: {} error bars run into the bottom of the plot",
                s.label, s.bars_cut_at_floor
            ));
        }
        // Accuracy-against-time charts: every point of a multi-point series
        // says which setting it is.
        if l.stem.starts_with("pareto-") && s.points > 1 && s.labelled < s.points {
            out.push(format!(
                "series {:?}: {} of {} points labelled with their setting",
                s.label, s.labelled, s.points
            ));
        }
        if mc && s.error_bars < s.points {
            out.push(format!(
                "Monte Carlo series {:?}: {} of {} points have error bars",
                s.label, s.error_bars, s.points
            ));
        }
    }
    out
}

/// Distinct colours in the 7x7 pixel window around `(x, y)`.
fn window_colours(img: &Pixmap, (x, y): (f64, f64)) -> usize {
    let mut seen = std::collections::HashSet::new();
    for dy in -3i64..=3 {
        for dx in -3i64..=3 {
            let (px, py) = (x.round() as i64 + dx, y.round() as i64 + dy);
            if px >= 0 && py >= 0 && (px as u32) < img.width() && (py as u32) < img.height() {
                let c = img.pixel(px as u32, py as u32).expect("inside");
                seen.insert((c.red(), c.green(), c.blue()));
            }
        }
    }
    seen.len()
}

/// Whether the slanted lines of a chart are drawn without anti-aliasing:
/// at the middle of each slanted segment (both extents at least 8 pixels)
/// an aliased line shows only its own colour on the background (at most 3
/// colours with a grid line), an anti-aliased one the blends between them.
/// Aliased when more than half of such segments show at most 3 colours.
pub fn lines_aliased(img: &Pixmap, segments: &[[(f64, f64); 2]]) -> Option<String> {
    let slanted: Vec<_> = segments
        .iter()
        .filter(|s| (s[1].0 - s[0].0).abs() >= 8.0 && (s[1].1 - s[0].1).abs() >= 8.0)
        .collect();
    let hard = slanted
        .iter()
        .filter(|s| window_colours(img, ((s[0].0 + s[1].0) / 2.0, (s[0].1 + s[1].1) / 2.0)) <= 3)
        .count();
    (!slanted.is_empty() && 2 * hard > slanted.len()).then(|| {
        format!("{hard} of {} slanted segments drawn without anti-aliasing", slanted.len())
    })
}

/// [`lines_aliased`] on the PNG file at `path`.
///
/// # Errors
/// The file cannot be read or decoded as PNG.
pub fn png_lines_aliased(
    path: &Path,
    segments: &[[(f64, f64); 2]],
) -> anyhow::Result<Option<String>> {
    let img = Pixmap::load_png(path).map_err(|e| anyhow!("reading {}: {e}", path.display()))?;
    Ok(lines_aliased(&img, segments))
}

/// Companion line charts of one study (same stem up to the second `-`)
/// that plot against the albedo must share one x axis: `1 - albedo` on
/// one and `1 / (1 - albedo)` on the other reads as a contradiction.
pub fn companion_defects(layouts: &[ChartLayout]) -> Vec<String> {
    let mut by_study: std::collections::BTreeMap<String, Vec<&ChartLayout>> = Default::default();
    for l in layouts.iter().filter(|l| l.kind == "line" && l.x_label.contains("albedo")) {
        let study: String = l.stem.splitn(3, '-').take(2).collect::<Vec<_>>().join("-");
        by_study.entry(study).or_default().push(l);
    }
    let mut out = Vec::new();
    for (study, ls) in by_study {
        if ls.iter().any(|l| l.x_label != ls[0].x_label) {
            let labels: Vec<String> =
                ls.iter().map(|l| format!("{}: {}", l.stem, l.x_label)).collect();
            out.push(format!("{study}: companion charts on different x axes ({labels:?})"));
        }
    }
    out
}
