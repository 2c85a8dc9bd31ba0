//! Time of the library call that `km.solve` wraps ([`_km::engine::solve`]),
//! for the one-layer slab of `bench/throughput.py`: median over rounds of the
//! mean per call, wall and thread CPU time.
//!
//! `cargo run --release -p km-python --example call_time`

use std::time::Instant;

use _km::engine::{Options, solve};
use km::Method;

/// CPU time of this thread, seconds (Linux: /proc/thread-self/schedstat, ns).
fn thread_cpu() -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next().and_then(|x| x.parse::<f64>().ok()))
        .map(|ns| ns * 1e-9)
        .unwrap_or(f64::NAN)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let scene = km::Scene::from_toml_str(
        "[[layer]]\nsigma_a = 0.1\nsigma_s = 2.0\nthickness = 1.0\ng = 0.5\nn = 1.0\n",
    )
    .expect("scene");
    for method in [Method::Multiflux, Method::Km] {
        let opts = Options { method, ..Default::default() };
        let calls = if method == Method::Km { 20_000 } else { 2_000 };
        let (mut wall, mut cpu) = (Vec::new(), Vec::new());
        for _ in 0..7 {
            let (t0, c0) = (Instant::now(), thread_cpu());
            for _ in 0..calls {
                std::hint::black_box(solve(&scene, &opts).expect("solve"));
            }
            wall.push(t0.elapsed().as_secs_f64() / calls as f64);
            cpu.push((thread_cpu() - c0) / calls as f64);
        }
        println!(
            "{:>9}: {:8.2} us wall, {:8.2} us cpu per call (median of 7 rounds of {calls})",
            method.name(),
            median(wall) * 1e6,
            median(cpu) * 1e6
        );
    }
}
