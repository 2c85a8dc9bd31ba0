//! First solve of a fresh process against warm solves (multi-flux):
//! `cargo run --release -p km-bench --example cold_start -- STREAMS [REPEATS]`
//! solves a Fresnel slab (tau = 2, albedo 0.9, g = 0.75, n = 1.4, light at
//! 30 degrees, three exit directions) once, then `REPEATS` more times (default
//! 50), and prints one JSON line with the first call's `Solution::seconds`,
//! the median and best of the warm calls and the ratio first / median.
//!
//! Run it in several fresh processes (each run is one cold start); the
//! one-time costs it exposes are those of the first solve in a process
//! (lazy statics, first-touch allocations, library probes).

use anyhow::Context;

const SCENE: &str = "[light]\ntheta_deg = 30.0\n[[layer]]\ntau = 2.0\nalbedo = 0.9\n\
                     g = 0.75\nn = 1.4\n[output]\ndirections_deg = [[0.0, 0.0], [30.0, 0.0], \
                     [60.0, 180.0]]\n";

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let streams: usize =
        args.first().context("usage: cold_start STREAMS [REPEATS]")?.parse().context("STREAMS")?;
    let repeats: usize = match args.get(1) {
        Some(r) => r.parse::<usize>().context("REPEATS")?.max(1),
        None => 50,
    };
    let scene = km_core::Scene::from_toml_str(SCENE)?;
    let opts = km_multiflux::MultifluxOptions { streams: Some(streams), ..Default::default() };
    let first = km_multiflux::solve(&scene, &opts)?.seconds;
    let mut warm = Vec::with_capacity(repeats);
    for _ in 0..repeats {
        warm.push(km_multiflux::solve(&scene, &opts)?.seconds);
    }
    warm.sort_by(f64::total_cmp);
    let median = warm[warm.len() / 2];
    let line = serde_json::json!({
        "streams": streams,
        "first_s": first,
        "warm_median_s": median,
        "warm_best_s": warm[0],
        "first_over_median": first / median,
    });
    println!("{line}");
    Ok(())
}
