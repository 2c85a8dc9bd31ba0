//! Property test: 12 000 randomly mutated scene texts (deleted, duplicated
//! and swapped lines, random numbers, random bytes) go through the parser and
//! the two-flux solver, and every sixth also through the multi-flux, Monte
//! Carlo and dipole solvers. Nothing may panic; every refusal must be an
//! error value; every accepted scene must give finite answers in [0, 1] and
//! non-negative BRDF values. A fixed-seed generator keeps the run
//! reproducible; a failure prints the mutated text so it can be pinned as a
//! regression test.
//!
//! A second property test grows scenes instead: huge numbers (near the
//! overflow of f64 and of TOML's i64), huge lists (thousands of channels or
//! directions) and huge counts (thousands of layers); each case must end, by
//! an answer or a refusal, within a bound of time (docs/limits.md).
//!
//! A fixed-seed generator keeps the run reproducible; a failure prints the
//! mutated text so it can be pinned as a regression test.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::time::Instant;

use km_core::Scene;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

const CORPUS: &[&str] = &[
    include_str!("../../examples/seed-three-layers.toml"),
    include_str!("../../examples/paint-over-primer.toml"),
    include_str!("../../examples/fresnel-slab.toml"),
    include_str!("../../examples/marble-half-space.toml"),
    include_str!("../../examples/cloud-deck.toml"),
    "[light]\nkind = \"diffuse\"\n[[layer]]\ntau = \"inf\"\nalbedo = 0.99\ng = 0.9\n",
    "[spectrum]\nwavelengths_nm = [450, 550, 650]\n[[layer]]\nsigma_a = [0.1, 0.2, 0.3]\nsigma_s = 1\nthickness = 2\n[substrate]\nkind = \"lambertian\"\nalbedo = [0.2, 0.5, 0.8]\n",
];

const NUMBERS: &[&str] = &[
    "0",
    "-0",
    "1",
    "-1",
    "0.5",
    "1e-300",
    "1e300",
    "-1e300",
    "inf",
    "-inf",
    "nan",
    "\"inf\"",
    "0.999999",
    "1.000001",
    "89.9999",
    "90",
    "180",
    "[]",
    "[1]",
    "[1, 2]",
    "[1, 2, 3]",
    "\"x\"",
    "true",
    "1e-6",
    "1e6",
    "4.9e-324",
    "[[1, 2], [3]]",
];

fn mutate(rng: &mut Pcg64, text: &str) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let rounds = rng.random_range(1..4);
    for _ in 0..rounds {
        if lines.is_empty() {
            lines.push(String::new());
        }
        let i = rng.random_range(0..lines.len());
        match rng.random_range(0..6) {
            // Delete a line.
            0 => {
                lines.remove(i);
            }
            // Duplicate a line.
            1 => {
                let l = lines[i].clone();
                lines.insert(i, l);
            }
            // Swap two lines.
            2 => {
                let j = rng.random_range(0..lines.len());
                lines.swap(i, j);
            }
            // Replace the value of an assignment by a random number-like token.
            3 => {
                if let Some(eq) = lines[i].find('=') {
                    let tok = NUMBERS[rng.random_range(0..NUMBERS.len())];
                    let key = lines[i][..eq].to_string();
                    lines[i] = format!("{key}= {tok}");
                }
            }
            // Replace the value by a random float over many decades.
            4 => {
                if let Some(eq) = lines[i].find('=') {
                    let x: f64 = rng.random::<f64>() * 10f64.powi(rng.random_range(-8..8));
                    let sign = if rng.random_bool(0.2) { "-" } else { "" };
                    let key = lines[i][..eq].to_string();
                    lines[i] = format!("{key}= {sign}{x:e}");
                }
            }
            // Random bytes (kept valid UTF-8 by lossy conversion).
            _ => {
                let mut bytes = lines[i].clone().into_bytes();
                let n = rng.random_range(1..4);
                for _ in 0..n {
                    let b: u8 = rng.random();
                    if bytes.is_empty() || rng.random_bool(0.5) {
                        let at = rng.random_range(0..=bytes.len());
                        bytes.insert(at, b);
                    } else {
                        let at = rng.random_range(0..bytes.len());
                        bytes[at] = b;
                    }
                }
                lines[i] = String::from_utf8_lossy(&bytes).into_owned();
            }
        }
    }
    lines.join("\n")
}

const HUGE_NUMBERS: &[&str] = &[
    "1e308",
    "1.7976931348623157e308",
    "-1.7976931348623157e308",
    "1e-308",
    "9223372036854775807",
    "-9223372036854775808",
    "18446744073709551615",
    "99999999999999999999999999",
    "89.9999999",
    "89.999999",
    "1e16",
];

/// Grow a scene: a huge number in one assignment, a huge list, many layers,
/// many directions.
fn grow(rng: &mut Pcg64, text: &str) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let assignments: Vec<usize> = (0..lines.len()).filter(|&i| lines[i].contains('=')).collect();
    match rng.random_range(0..4) {
        0 if !assignments.is_empty() => {
            let i = assignments[rng.random_range(0..assignments.len())];
            let key = lines[i][..lines[i].find('=').unwrap_or(0)].to_string();
            let tok = HUGE_NUMBERS[rng.random_range(0..HUGE_NUMBERS.len())];
            lines[i] = format!("{key}= {tok}");
        }
        1 if !assignments.is_empty() => {
            // A list of up to 20 000 values.
            let i = assignments[rng.random_range(0..assignments.len())];
            let key = lines[i][..lines[i].find('=').unwrap_or(0)].to_string();
            let n = 10usize.pow(rng.random_range(1..5)) * 2;
            let x: f64 = rng.random();
            let v: Vec<String> = (0..n).map(|k| format!("{}", x + k as f64 * 1e-9)).collect();
            lines[i] = format!("{key}= [{}]", v.join(", "));
        }
        2 => {
            // Up to 20 000 more layers.
            let n = 2 * 10usize.pow(rng.random_range(1..5));
            let n_idx = rng.random_bool(0.5);
            for k in 0..n {
                let n_line = if n_idx {
                    format!("n = {}\n", 1.0 + k as f64 / n as f64)
                } else {
                    String::new()
                };
                lines.push(format!("[[layer]]\ntau = 0.01\nalbedo = 0.5\n{n_line}"));
            }
        }
        _ => {
            // Up to 20 000 output directions.
            let n = 2 * 10usize.pow(rng.random_range(1..5));
            let v: Vec<String> =
                (0..n).map(|k| format!("[{}, 0]", 80.0 * k as f64 / n as f64)).collect();
            lines.retain(|l| !l.starts_with("directions_deg") && l.trim() != "[output]");
            lines.push(format!("[output]\ndirections_deg = [{}]", v.join(", ")));
        }
    }
    lines.join("\n")
}

/// Parse and solve one text; Err(message) if anything misbehaves.
fn exercise(text: &str, heavy: bool) -> Result<bool, String> {
    let outcome = catch_unwind(AssertUnwindSafe(|| -> Result<bool, String> {
        let Ok(scene) = Scene::from_toml_str(text) else {
            return Ok(false);
        };
        check_solvers(&scene, heavy)?;
        Ok(true)
    }));
    match outcome {
        Ok(r) => r,
        Err(_) => Err("panic".into()),
    }
}

fn finite_unit(method: &str, sol: &km_core::Solution) -> Result<(), String> {
    for c in &sol.channels {
        for (name, v) in [
            ("reflectance", c.reflectance),
            ("transmittance", c.transmittance),
            ("absorptance", c.absorptance),
        ] {
            // Monte Carlo absorptance may be a hair below 0 only by rounding.
            if !(v.is_finite() && (-1e-9..=1.0 + 1e-9).contains(&v)) {
                return Err(format!("{method} {name} = {v}"));
            }
        }
        for v in c.brdf.iter().chain(&c.btdf) {
            if !(v.is_finite() && *v >= -1e-9) {
                return Err(format!("{method} brdf/btdf value {v}"));
            }
        }
    }
    Ok(())
}

/// The two-flux solver on every scene; the transport solvers (`heavy`) on a
/// subset, so the test stays short.
fn check_solvers(scene: &Scene, heavy: bool) -> Result<(), String> {
    if let Ok(sol) = km_core::two_flux::solve(scene, &Default::default()) {
        finite_unit("km", &sol)?;
    }
    if !heavy {
        return Ok(());
    }
    let mf = km_multiflux::MultifluxOptions { streams: Some(6), ..Default::default() };
    if let Ok(sol) = km_multiflux::solve(scene, &mf) {
        finite_unit("multiflux", &sol)?;
    }
    let mc = km_montecarlo::McOptions {
        samples: 64,
        threads: Some(1),
        max_steps_per_photon: 2_000,
        max_events: Some(2_000_000),
        ..Default::default()
    };
    if let Ok(sol) = km_montecarlo::solve(scene, &mc) {
        finite_unit("mc", &sol)?;
    }
    if let Ok(sol) = km_dipole::solve(scene, &Default::default()) {
        finite_unit("dipole", &sol)?;
    }
    Ok(())
}

#[test]
fn mutated_scenes_never_panic_any_solver() {
    let _ = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let mut rng = Pcg64::seed_from_u64(0x5eed_2027);
    let mut accepted = 0usize;
    let total = 12_000usize;
    // Every sixth scene also goes through multi-flux, Monte Carlo and dipole.
    let mut heavy_accepted = 0usize;
    for k in 0..total {
        let base = CORPUS[k % CORPUS.len()];
        let text = mutate(&mut rng, base);
        let heavy = k % 6 == 0;
        match exercise(&text, heavy) {
            Ok(true) => {
                accepted += 1;
                heavy_accepted += usize::from(heavy);
            }
            Ok(false) => {}
            Err(what) => {
                let _ = std::panic::take_hook();
                panic!("case {k}: {what} on input:\n{text}");
            }
        }
    }
    let _ = std::panic::take_hook();
    println!(
        "{accepted} of {total} mutated scenes parsed and solved ({heavy_accepted} by every method)"
    );
    assert!(heavy_accepted > 100, "only {heavy_accepted} scenes reached the transport solvers");
    // Both outcomes must be exercised, or the mutations are too weak (or too strong).
    assert!(accepted > total / 20, "only {accepted} of {total} mutated scenes parsed");
    assert!(accepted < total * 19 / 20, "{accepted} of {total} mutated scenes parsed");
}

#[test]
fn grown_scenes_end_within_their_budgets() {
    let _ = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let mut rng = Pcg64::seed_from_u64(0x0060_2026);
    let total = 240usize;
    let (mut accepted, mut slowest, mut slowest_case) = (0usize, 0.0f64, 0usize);
    for k in 0..total {
        let base = CORPUS[k % CORPUS.len()];
        let text = grow(&mut rng, base);
        let t0 = Instant::now();
        // Every case goes through every solver at the default budgets.
        match exercise(&text, true) {
            Ok(ok) => accepted += usize::from(ok),
            Err(what) => {
                let _ = std::panic::take_hook();
                panic!("case {k}: {what} on input of {} bytes:\n{:.400}", text.len(), text);
            }
        }
        let dt = t0.elapsed().as_secs_f64();
        if dt > slowest {
            (slowest, slowest_case) = (dt, k);
        }
    }
    let _ = std::panic::take_hook();
    println!(
        "{accepted} of {total} grown scenes solved; slowest case {slowest_case}: {slowest:.2} s"
    );
    // Bound: the largest accepted work is a 20 000-layer two-flux solve and a
    // multi-flux solve under its budget at 6 streams (a fraction of a
    // second); 20 s leaves room for a loaded machine without admitting the
    // minutes-long runs of unbounded input.
    assert!(slowest < 20.0, "case {slowest_case} took {slowest:.1} s");
    assert!(accepted > total / 10 && accepted < total, "{accepted} of {total} accepted");
}
