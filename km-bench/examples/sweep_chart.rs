//! The cost of a multi-flux solve against the stream count, beside C
//! DISORT's at the equal grid NSTR = 2N (docs/benchmarks.md §9).
//!
//! ```text
//! cargo bench -p km-bench --bench multiflux_sweep
//! python3 km-bench/scripts/peers.py --sweep [--python PY] [--km BIN]
//! cargo run --release -p km-bench --example sweep_chart -- [CSV] [CRITERION] [OUT]
//! ```
//!
//! Reads the criterion medians of the `multiflux_sweep` bench (default
//! `target/criterion`) and the sweep of `peers.py --sweep` (default
//! `out/peers-sweep.csv`: `case,n,km_us,disort_us`), and writes
//! `OUT/sweep-CASE.png` and `.svg` (default `docs/img`) for each case of
//! the CSV: km's criterion median (where the bench has that case), km's
//! best `km solve --repeat` time and C DISORT's best, in microseconds on a
//! log axis.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::Context;
use km_plot::chart::{LineChart, Mark, Series, write_chart};

/// Criterion's file-name form of a benchmark name (its `make_filename_safe`).
fn safe(name: &str) -> String {
    name.chars().map(|c| if "?\"/\\*<>:|^".contains(c) { '_' } else { c }).collect()
}

/// The criterion median of `group`/`n` in microseconds, if measured.
fn median_us(crit: &Path, group: &str, n: usize) -> Option<f64> {
    let p = crit.join(safe(group)).join(n.to_string()).join("new").join("estimates.json");
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(p).ok()?).ok()?;
    Some(v["median"]["point_estimate"].as_f64()? / 1e3)
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, d: &str| PathBuf::from(args.get(i).map_or(d, String::as_str));
    let (csv, crit, out) =
        (arg(0, "out/peers-sweep.csv"), arg(1, "target/criterion"), arg(2, "docs/img"));
    let text = std::fs::read_to_string(&csv).with_context(|| format!("reading {csv:?}"))?;
    // case -> [(n, km, disort)]
    let mut cases: BTreeMap<String, Vec<(f64, f64, f64)>> = BTreeMap::new();
    for (i, line) in text.lines().enumerate().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        anyhow::ensure!(
            f.len() >= 4,
            "{csv:?} line {}: expected case,n,km_us,disort_us,...",
            i + 1
        );
        let num = |s: &str| s.trim().parse::<f64>().with_context(|| format!("line {}", i + 1));
        cases.entry(f[0].to_string()).or_default().push((num(f[1])?, num(f[2])?, num(f[3])?));
    }
    for (case, rows) in &cases {
        // The bench measures g = 0.9 only.
        let group = match case.as_str() {
            "brdf-g0.9" => Some("multiflux sweep g = 0.9 BRDF at 30 directions"),
            "totals-g0.9" => Some("multiflux sweep g = 0.9 totals"),
            _ => None,
        };
        let mut series = Vec::new();
        if let Some(g) = group {
            let pts: Vec<(f64, f64)> = rows
                .iter()
                .filter_map(|r| median_us(&crit, g, r.0 as usize).map(|m| (r.0, m)))
                .collect();
            if !pts.is_empty() {
                series.push(Series::new("km, criterion median", pts, Mark::LinePoints, 0));
            }
        }
        let km: Vec<(f64, f64)> = rows.iter().map(|r| (r.0, r.1)).collect();
        let disort: Vec<(f64, f64)> = rows.iter().map(|r| (r.0, r.2)).collect();
        series.push(Series::new("km solve --repeat, best", km, Mark::Dashed, 1));
        series.push(Series::new("C DISORT at NSTR = 2N, best", disort, Mark::LinePoints, 2));
        let chart = LineChart {
            title: format!("cost per solve against streams: {case}"),
            x_label: "streams per hemisphere N".into(),
            y_label: "time per solve (microseconds)".into(),
            x_log: false,
            y_log: true,
            x_range: None,
            y_range: None,
            series,
            h_lines: Vec::new(),
        };
        let paths = write_chart(&out, &format!("sweep-{case}"), &chart)?;
        println!("{}", paths[0].display());
    }
    Ok(())
}
