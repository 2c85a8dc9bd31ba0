//! The drawing of every chart of a tiny reproduction, checked on the layout
//! the chart module records (pixels of the PNG as drawn), not only for
//! well-formedness: the checks of [`km_plot::check`] on every chart, and
//! the Monte Carlo stability maps' marked cells against their CSV.

use std::path::PathBuf;

use km_bench::{ReproduceOptions, reproduce};
use km_plot::check::{companion_defects, defects, png_lines_aliased};

/// A fresh directory under the system temporary directory.
fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("km-bench-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
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
            let png = dir.join(format!("{}.png", l.stem));
            if let Some(d) = png_lines_aliased(&png, &l.segments).unwrap() {
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
