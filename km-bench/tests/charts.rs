//! The drawing of every chart of a tiny reproduction, checked on the layout
//! the chart module records (pixels of the PNG as drawn), not only for
//! well-formedness:
//!
//! * every tick label parses as a number and has at most 4 significant digits;
//! * no legend box meets a drawn data segment, marker or annotation, and
//!   every legend lies inside the image;
//! * every Monte Carlo series (label naming "Monte Carlo" or "MC") has an
//!   error bar at each of its drawn points.
//!
//! The overlap is computed here independently of the chart module's own
//! placement test (which clips segments exactly): each segment is sampled
//! every half pixel and each sample tested against the legend box.

use std::path::PathBuf;

use km_bench::chart::{ChartLayout, PixelRect, SIZE};
use km_bench::{ReproduceOptions, reproduce};
use resvg::tiny_skia::{Color, Paint, PathBuilder, Pixmap, Stroke, Transform};

/// A fresh directory under the system temporary directory.
fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("km-bench-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Significant digits of a decimal or `m e p` number as written (leading
/// zeros never count; trailing zeros of an integer mantissa do not count).
fn significant_digits(label: &str) -> usize {
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
fn defects(l: &ChartLayout) -> Vec<String> {
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
fn lines_aliased(img: &Pixmap, segments: &[[(f64, f64); 2]]) -> Option<String> {
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

#[test]
fn the_aliasing_check_tells_a_staircase_from_a_smooth_line() {
    let line = [[(10.0, 10.0), (90.0, 60.0)], [(10.0, 90.0), (90.0, 20.0)]];
    let draw = |aa: bool| {
        let mut img = Pixmap::new(100, 100).unwrap();
        img.fill(Color::WHITE);
        let mut paint = Paint::default();
        paint.set_color_rgba8(31, 119, 180, 255);
        paint.anti_alias = aa;
        let stroke = Stroke { width: 2.0, ..Default::default() };
        for s in &line {
            let mut pb = PathBuilder::new();
            pb.move_to(s[0].0 as f32, s[0].1 as f32);
            pb.line_to(s[1].0 as f32, s[1].1 as f32);
            img.stroke_path(&pb.finish().unwrap(), &paint, &stroke, Transform::identity(), None);
        }
        // Through PNG, as the charts are read back.
        Pixmap::decode_png(&img.encode_png().unwrap()).unwrap()
    };
    assert!(lines_aliased(&draw(false), &line).is_some(), "a staircase passes");
    assert!(lines_aliased(&draw(true), &line).is_none(), "a smooth line is flagged");
}

/// Companion line charts of one study (same stem up to the second `-`)
/// that plot against the albedo must share one x axis: `1 - albedo` on
/// one and `1 / (1 - albedo)` on the other reads as a contradiction.
fn companion_defects(layouts: &[ChartLayout]) -> Vec<String> {
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

#[test]
fn companion_charts_on_different_axes_are_caught() {
    let chart = |stem: &str, x: &str| ChartLayout {
        stem: stem.into(),
        kind: "line".into(),
        x_label: x.into(),
        ..Default::default()
    };
    let same = [
        chart("diffusion-limits-total", "1 - albedo"),
        chart("diffusion-limits-error", "1 - albedo"),
    ];
    assert!(companion_defects(&same).is_empty());
    let mixed = [
        chart("diffusion-limits-total", "1 - albedo"),
        chart("diffusion-limits-error", "1 / (1 - albedo)"),
    ];
    assert_eq!(companion_defects(&mixed).len(), 1);
}

#[test]
fn significant_digits_are_counted_as_written() {
    assert_eq!(significant_digits("0"), 1);
    assert_eq!(significant_digits("0.001"), 1);
    assert_eq!(significant_digits("1e-25"), 1);
    assert_eq!(significant_digits("-2.5e4"), 2);
    assert_eq!(significant_digits("12000"), 2);
    assert_eq!(significant_digits("3.1623"), 5);
    assert_eq!(significant_digits("2.22e-16"), 3);
    assert_eq!(significant_digits("0.30000000000000004"), 17);
}

#[test]
fn the_checks_catch_planted_defects() {
    // A clean layout, then one defect of each kind planted in it.
    let clean = ChartLayout {
        plot: PixelRect { x0: 80.0, y0: 40.0, x1: 780.0, y1: 500.0 },
        legend: Some(PixelRect { x0: 600.0, y0: 50.0, x1: 770.0, y1: 100.0 }),
        segments: vec![[(90.0, 400.0), (500.0, 300.0)]],
        x_ticks: vec!["0".into(), "0.5".into(), "1e-4".into()],
        y_ticks: vec!["1000".into()],
        ..Default::default()
    };
    assert!(defects(&clean).is_empty(), "{:?}", defects(&clean));
    let mut l = clean.clone();
    l.y_ticks.push("2.22e-16".into());
    l.y_ticks.push("3.1623".into());
    assert_eq!(defects(&l).len(), 1, "{:?}", defects(&l));
    let mut l = clean.clone();
    // A line passing under the legend, with both ends outside it.
    l.segments.push([(550.0, 80.0), (790.0, 60.0)]);
    assert_eq!(defects(&l).len(), 1, "{:?}", defects(&l));
    let mut l = clean.clone();
    l.series.push(km_bench::chart::SeriesLayout {
        label: "Monte Carlo 1e5".into(),
        points: 10,
        error_bars: 9,
        ..Default::default()
    });
    assert_eq!(defects(&l).len(), 1, "{:?}", defects(&l));
    let mut l = clean.clone();
    l.series.push(km_bench::chart::SeriesLayout {
        label: "Monte Carlo".into(),
        points: 2,
        error_bars: 2,
        bars_cut_at_floor: 1,
        labelled: 0,
    });
    assert_eq!(defects(&l).len(), 1, "{:?}", defects(&l));
    l.stem = "pareto-x-R".into();
    l.series[0].bars_cut_at_floor = 0;
    assert_eq!(defects(&l).len(), 1, "{:?}", defects(&l));
    l.series[0].labelled = 2;
    assert!(defects(&l).is_empty(), "{:?}", defects(&l));
    // Heat maps: a repeated row label, ticks between round values, and
    // marked cells without a note, each caught alone.
    let heat = ChartLayout {
        kind: "heat".into(),
        plot: clean.plot,
        x_ticks: vec!["0".into(), "45".into(), "90".into(), "135".into()],
        y_ticks: vec!["0.99".into(), "0.9999".into(), "0.99999".into(), "1".into()],
        z_ticks: vec!["1e-2".into()],
        ..Default::default()
    };
    assert!(defects(&heat).is_empty(), "{:?}", defects(&heat));
    let mut l = heat.clone();
    l.y_ticks = vec!["0.99".into(), "0.9999".into(), "1".into(), "1".into()];
    assert_eq!(defects(&l).len(), 1, "{:?}", defects(&l));
    let mut l = heat.clone();
    l.x_ticks = vec!["2.5".into(), "52.5".into(), "102.5".into()];
    assert_eq!(defects(&l).len(), 1, "{:?}", defects(&l));
    let mut l = heat.clone();
    l.marked_cells = 3;
    assert_eq!(defects(&l).len(), 1, "{:?}", defects(&l));
    l.notes.push("x: capped".into());
    assert!(defects(&l).is_empty(), "{:?}", defects(&l));
}

#[test]
fn every_chart_of_a_tiny_run_is_drawn_without_defects() {
    let dir = temp_dir("charts");
    let mut opts = ReproduceOptions::tiny(&dir);
    opts.quiet = true;
    let summary = reproduce(&opts).unwrap();
    assert_eq!(summary.failures(), 0, "failed recipes:\n{summary}");
    // Every chart written is recorded, with a plotting area and tick labels.
    let pngs = std::fs::read_dir(&dir)
        .unwrap()
        .filter(|e| e.as_ref().unwrap().path().extension().is_some_and(|x| x == "png"))
        .count();
    assert_eq!(summary.charts.len(), pngs, "one layout per chart file");
    let mut all = Vec::new();
    for l in &summary.charts {
        assert!(l.plot.x1 > l.plot.x0 && l.plot.y1 > l.plot.y0, "{}: no plotting area", l.stem);
        assert!(!l.y_ticks.is_empty() || l.kind == "polar", "{}: no tick labels recorded", l.stem);
        for d in defects(l) {
            all.push(format!("{}: {d}", l.stem));
        }
        if l.kind == "line" {
            let img = Pixmap::load_png(dir.join(format!("{}.png", l.stem))).unwrap();
            if let Some(d) = lines_aliased(&img, &l.segments) {
                all.push(format!("{}: {d}", l.stem));
            }
        }
        // Monte Carlo maps: one cross per cell whose photons met the step cap.
        if l.stem.starts_with("stability-montecarlo") && l.stem.ends_with("-balance") {
            let grid = l.stem.trim_end_matches("-balance");
            let csv = std::fs::read_to_string(dir.join(format!("{grid}.csv"))).unwrap();
            let mut rows = csv.lines().filter(|r| !r.starts_with('#'));
            let head: Vec<&str> = rows.next().unwrap().split(',').collect();
            let k = head.iter().position(|h| *h == "capped_photons").expect("capped column");
            let capped = rows.filter(|r| r.split(',').nth(k).is_some_and(|v| v != "0")).count();
            if capped != l.marked_cells {
                all.push(format!("{}: {capped} capped cells, {} marked", l.stem, l.marked_cells));
            }
        }
    }
    all.extend(companion_defects(&summary.charts));
    assert!(all.is_empty(), "{} chart defects:\n{}", all.len(), all.join("\n"));
    let _ = std::fs::remove_dir_all(&dir);
}
