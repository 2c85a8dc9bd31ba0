//! The chart checks of [`km_plot::check`] catch what they are meant to:
//! each defect planted alone in a clean layout, or drawn on pixels, is
//! reported once, and the clean one passes.

use km_plot::chart::{ChartLayout, PixelRect, SeriesLayout};
use km_plot::check::{companion_defects, defects, lines_aliased, significant_digits};
use resvg::tiny_skia::{Color, Paint, PathBuilder, Pixmap, Stroke, Transform};

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
    l.series.push(SeriesLayout {
        label: "Monte Carlo 1e5".into(),
        points: 10,
        error_bars: 9,
        ..Default::default()
    });
    assert_eq!(defects(&l).len(), 1, "{:?}", defects(&l));
    let mut l = clean.clone();
    l.series.push(SeriesLayout {
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

/// A fresh directory under the system temporary directory.
fn temp_dir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("km-plot-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn a_drawn_line_chart_with_a_monte_carlo_series_passes_the_checks() {
    use km_plot::chart::{LineChart, Mark, Series, write_chart_layout};
    // A decaying curve over five decades (log y) and noisy points with
    // bars: the legend must find a free corner, every MC point its bar.
    let x: Vec<f64> = (0..40).map(|k| k as f64 * 0.25).collect();
    let curve: Vec<(f64, f64)> = x.iter().map(|&x| (x, (-x).exp())).collect();
    let points: Vec<(f64, f64)> = x.iter().step_by(4).map(|&x| (x, (-x).exp() * 1.05)).collect();
    let err: Vec<f64> = points.iter().map(|p| 0.1 * p.1).collect();
    let chart = LineChart {
        title: "exp(-x)".into(),
        x_label: "x".into(),
        y_label: "value".into(),
        y_log: true,
        series: vec![
            Series::new("exact", curve, Mark::Line, 0),
            Series::new("Monte Carlo 1e5", points, Mark::Points, 1).with_y_err(err),
        ],
        ..Default::default()
    };
    let dir = temp_dir("line");
    let ([svg, png], layout) = write_chart_layout(&dir, "decay", &chart).unwrap();
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));
    assert!(!layout.y_ticks.is_empty() && layout.legend.is_some(), "{layout:?}");
    assert_eq!(layout.series[1].error_bars, layout.series[1].points);
    assert!(defects(&layout).is_empty(), "{:?}", defects(&layout));
    let aliased = km_plot::check::png_lines_aliased(&png, &layout.segments).unwrap();
    assert!(aliased.is_none(), "{aliased:?}");
    let _ = std::fs::remove_dir_all(&dir);
}
