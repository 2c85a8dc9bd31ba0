//! In-process timing of the multi-flux solver for the peers comparison
//! (`scripts/peers.py`): `cargo run --release -p km-bench --example
//! peers_timing -- STREAMS REPEATS SCENE.toml...` prints one JSON object per
//! scene with the totals and the best and median of `REPEATS` solver wall
//! times (`Solution::seconds`: no parsing, no process start).

use anyhow::Context;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 3 {
        anyhow::bail!("usage: peers_timing STREAMS REPEATS SCENE.toml...");
    }
    let streams: usize = args[0].parse().context("STREAMS")?;
    let repeats: usize = args[1].parse::<usize>().context("REPEATS")?.max(1);
    let opts = km_multiflux::MultifluxOptions { streams: Some(streams), ..Default::default() };
    for path in &args[2..] {
        let scene = km_core::Scene::from_path(std::path::Path::new(path))?;
        let mut times = Vec::with_capacity(repeats);
        let mut last = None;
        for _ in 0..repeats {
            let sol = km_multiflux::solve(&scene, &opts)?;
            times.push(sol.seconds);
            last = Some(sol);
        }
        times.sort_by(f64::total_cmp);
        let Some(sol) = last else { continue };
        let c = &sol.channels[0];
        let line = serde_json::json!({
            "scene": path,
            "streams": streams,
            "reflectance": c.reflectance,
            "transmittance": c.transmittance,
            "seconds_best": times[0],
            "seconds_median": times[times.len() / 2],
        });
        println!("{line}");
    }
    Ok(())
}
