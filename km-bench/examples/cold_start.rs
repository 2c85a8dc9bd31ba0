//! First solve of a fresh process against warm solves (multi-flux):
//! `cargo run --release -p km-bench --example cold_start -- STREAMS [REPEATS] [SCENE]`
//! solves a scene once, then `REPEATS` more times (default 50), and prints
//! one JSON line with the first call's `Solution::seconds`, the median and
//! best of the warm calls, the ratio first / median, and the minor page
//! faults of the first call and of a warm call (from `/proc/self/stat`;
//! null where it cannot be read).
//!
//! `SCENE` is `fresnel` (default: a Fresnel slab, tau = 2, albedo 0.9,
//! g = 0.75, n = 1.4, light at 30 degrees, three exit directions), `slab`
//! (totals of a slab in air, tau = 1, albedo 0.9, g = 0.75, normal
//! incidence: the peers' comparison case of `km-bench/scripts/peers.py`) or
//! `brdf` (the BRDF case of `peers.py --brdf` at g = 0.5: tau = 1, albedo
//! 0.9, black below, light at 30 degrees, 30 exit directions).
//!
//! Run it in several fresh processes (each run is one cold start); the
//! one-time costs it exposes are those of the first solve in a process
//! (lazy statics, first-touch allocations, library probes, code not yet
//! mapped or cached).

use anyhow::Context;

const FRESNEL: &str = "[light]\ntheta_deg = 30.0\n[[layer]]\ntau = 2.0\nalbedo = 0.9\n\
                       g = 0.75\nn = 1.4\n[output]\ndirections_deg = [[0.0, 0.0], [30.0, 0.0], \
                       [60.0, 180.0]]\n";
const SLAB: &str = "[light]\ntheta_deg = 0.0\n[[layer]]\ntau = 1.0\nalbedo = 0.9\ng = 0.75\n\
                    [substrate]\nkind = \"transparent\"\nn = 1.0\n";

/// The BRDF case of `peers.py --brdf` at g = 0.5 (theta 10..60 by 10 x
/// phi 0..180 by 45).
fn brdf_scene() -> String {
    let mut dirs = String::new();
    for t in [10, 20, 30, 40, 50, 60] {
        for p in [0, 45, 90, 135, 180] {
            dirs += &format!("[{t}.0, {p}.0], ");
        }
    }
    format!(
        "[light]\ntheta_deg = 30.0\n[[layer]]\ntau = 1.0\nalbedo = 0.9\ng = 0.5\n\
         [substrate]\nkind = \"black\"\n[output]\ndirections_deg = [{dirs}]\n"
    )
}

/// Minor page faults of this process so far (field 10 of `/proc/self/stat`).
fn minor_faults() -> Option<u64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // The command name (field 2) may hold spaces: count from its closing ')'.
    let rest = &stat[stat.rfind(')')? + 2..];
    rest.split_whitespace().nth(7)?.parse().ok()
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: cold_start STREAMS [REPEATS] [fresnel|slab|brdf]";
    let streams: usize = args.first().context(usage)?.parse().context("STREAMS")?;
    let repeats: usize = match args.get(1) {
        Some(r) => r.parse::<usize>().context("REPEATS")?.max(1),
        None => 50,
    };
    let text = match args.get(2).map(String::as_str) {
        None | Some("fresnel") => FRESNEL.to_string(),
        Some("slab") => SLAB.to_string(),
        Some("brdf") => brdf_scene(),
        Some(other) => anyhow::bail!("unknown scene {other:?}; {usage}"),
    };
    let scene = km_core::Scene::from_toml_str(&text)?;
    let opts = km_multiflux::MultifluxOptions { streams: Some(streams), ..Default::default() };
    let f0 = minor_faults();
    let first = km_multiflux::solve(&scene, &opts)?.seconds;
    let f1 = minor_faults();
    let mut warm = Vec::with_capacity(repeats);
    for _ in 0..repeats {
        warm.push(km_multiflux::solve(&scene, &opts)?.seconds);
    }
    let f2 = minor_faults();
    warm.sort_by(f64::total_cmp);
    let median = warm[warm.len() / 2];
    let diff = |a: Option<u64>, b: Option<u64>| b?.checked_sub(a?);
    let line = serde_json::json!({
        "streams": streams,
        "first_s": first,
        "warm_median_s": median,
        "warm_best_s": warm[0],
        "first_over_median": first / median,
        "first_minor_faults": diff(f0, f1),
        "warm_minor_faults": diff(f1, f2).map(|d| d as f64 / repeats as f64),
    });
    println!("{line}");
    Ok(())
}
