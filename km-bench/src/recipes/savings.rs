//! What the planner saves (`docs/planner.md`): the solver time of each
//! method with the plan against `--all-effects` (every interface, every
//! eigen-solve, every Fourier order, every tally, every channel), on scenes
//! that call for each simplification, with the largest difference of the
//! answers against the stated tolerance.

use km::{McOptions, Method, MultifluxOptions, Options, Scene};

use crate::context::Ctx;
use crate::data::Csv;
use crate::recipes::common::{Spread, ratio_text};
use crate::report::{Section, Table};
use km_plot::chart::format_number;

/// Multi-flux agreement where the skipped work is exact (an identity
/// interface, a zero scattering term, an order that is not excited): rounding only.
const MF_TOL: f64 = 1e-10;

/// Directions of the scenes that ask for a BRDF.
const DIRS: &str = "[output]\ndirections_deg = [[0.0, 0.0], [20.0, 0.0], [40.0, 180.0], \
                    [60.0, 90.0], [75.0, 180.0]]\n";

/// The scenes: name, method (`multiflux` or `mc`), TOML text.
fn scenes() -> Vec<(&'static str, &'static str, String)> {
    let light = "[light]\ntheta_deg = 30\n";
    vec![
        (
            "matched indices (n = 1), 2 layers, g = 0.5, totals",
            "multiflux",
            format!(
                "{light}[[layer]]\ntau = 1\nalbedo = 0.9\ng = 0.5\n[[layer]]\ntau = 2\n\
                 albedo = 0.6\ng = 0.5\n[substrate]\nkind = \"transparent\"\nn = 1\n"
            ),
        ),
        (
            "unmatched indices (1.5 over 1.33), g = 0.5, totals",
            "multiflux",
            format!(
                "{light}[[layer]]\ntau = 1\nalbedo = 0.9\ng = 0.5\nn = 1.5\n[[layer]]\ntau = 2\n\
                 albedo = 0.6\ng = 0.5\nn = 1.33\n[substrate]\nkind = \"transparent\"\nn = 1.5\n"
            ),
        ),
        (
            "absorbing-only layer over a scattering one (n = 1.5), BRDF",
            "multiflux",
            format!(
                "{light}[[layer]]\nsigma_a = 1\nsigma_s = 0\nthickness = 0.5\nn = 1.5\n\
                 [[layer]]\ntau = 1\nalbedo = 0.9\ng = 0.5\nn = 1.5\n\
                 [substrate]\nkind = \"lambertian\"\nalbedo = 0.5\n{DIRS}"
            ),
        ),
        (
            "isotropic, n = 1.3, totals",
            "multiflux",
            format!("{light}[[layer]]\ntau = 1\nalbedo = 0.9\nn = 1.3\n"),
        ),
        (
            "isotropic, n = 1.3, BRDF at 5 directions",
            "multiflux",
            format!("{light}[[layer]]\ntau = 1\nalbedo = 0.9\nn = 1.3\n{DIRS}"),
        ),
        (
            "g = 0.7, n = 1.3, totals",
            "multiflux",
            format!("{light}[[layer]]\ntau = 1\nalbedo = 0.9\ng = 0.7\nn = 1.3\n"),
        ),
        (
            "g = 0.7, n = 1.3, BRDF at 5 directions",
            "multiflux",
            format!("{light}[[layer]]\ntau = 1\nalbedo = 0.9\ng = 0.7\nn = 1.3\n{DIRS}"),
        ),
        (
            "thick absorbing layer (tau 40, albedo 0.2) over a stack and a substrate",
            "multiflux",
            format!(
                "{light}[[layer]]\ntau = 40\nalbedo = 0.2\nn = 1.4\n[[layer]]\ntau = 2\n\
                 albedo = 0.9\ng = 0.5\nn = 1.4\n[[layer]]\ntau = 1\nalbedo = 0.8\nn = 1.2\n\
                 [substrate]\nkind = \"lambertian\"\nalbedo = 0.5\n"
            ),
        ),
        (
            "RGB x 2 (6 channels, 2 distinct), g = 0.5, n = 1.4, totals",
            "multiflux",
            format!("{light}[[layer]]\ntau = [1, 2, 1, 1, 2, 1]\nalbedo = 0.9\ng = 0.5\nn = 1.4\n"),
        ),
        (
            "Monte Carlo, matched indices, totals",
            "mc",
            format!("{light}[[layer]]\ntau = 2\nalbedo = 0.9\ng = 0.7\n"),
        ),
        (
            "Monte Carlo, n = 1.4, totals",
            "mc",
            format!("{light}[[layer]]\ntau = 2\nalbedo = 0.9\ng = 0.7\nn = 1.4\n"),
        ),
    ]
}

/// One solve as `km solve` does it ([`km::solve`]: with the plan,
/// duplicate channels are solved once); `all` switches every effect on.
fn solve(
    scene: &Scene,
    method: &str,
    all: bool,
    samples: u64,
    seed: u64,
) -> anyhow::Result<km_core::Solution> {
    let opts: Options = match method.parse::<Method>()? {
        Method::Mc => McOptions {
            samples,
            seed,
            // One thread: a stable solver time on a shared machine.
            threads: Some(1),
            ..crate::methods::mc_options(samples, seed)
        }
        .into(),
        _ => MultifluxOptions::default().into(),
    };
    Ok(km::solve(scene, &opts.with_all_effects(all))?)
}

/// The spread (min, median, max) of `k` solver times (`Solution::seconds`,
/// the solver's own wall time).
fn best_of(
    k: usize,
    scene: &Scene,
    method: &str,
    all: bool,
    samples: u64,
    seed: u64,
) -> anyhow::Result<(km_core::Solution, Spread)> {
    let mut sol = solve(scene, method, all, samples, seed)?;
    let mut times = vec![sol.seconds];
    for _ in 1..k.max(1) {
        sol = solve(scene, method, all, samples, seed)?;
        times.push(sol.seconds);
    }
    Ok((sol, Spread::of(&times)))
}

/// Largest difference over every channel's totals, specular/direct parts and BRDF/BTDF.
fn max_diff(a: &km_core::Solution, b: &km_core::Solution) -> f64 {
    let mut worst = 0.0f64;
    for (x, y) in a.channels.iter().zip(&b.channels) {
        for (p, q) in [
            (x.reflectance, y.reflectance),
            (x.transmittance, y.transmittance),
            (x.reflectance_specular, y.reflectance_specular),
            (x.transmittance_direct, y.transmittance_direct),
        ] {
            worst = worst.max((p - q).abs());
        }
        for (p, q) in x.brdf.iter().zip(&y.brdf).chain(x.btdf.iter().zip(&y.btdf)) {
            worst = worst.max((p - q).abs());
        }
    }
    worst
}

/// For Monte Carlo: the largest |R_a - R_b| and |T_a - T_b| in units of the
/// combined standard error, and that error (of R).
fn mc_sigmas(a: &km_core::Solution, b: &km_core::Solution) -> (f64, f64) {
    let se = |s: &km_core::Solution, c: usize, k: &str| {
        s.channels[c].stderr.as_ref().and_then(|m| m.get(k)).unwrap_or(0.0)
    };
    let mut worst = 0.0f64;
    let mut se_r = 0.0f64;
    for c in 0..a.channels.len() {
        for (k, p, q) in [
            ("reflectance", a.channels[c].reflectance, b.channels[c].reflectance),
            ("transmittance", a.channels[c].transmittance, b.channels[c].transmittance),
        ] {
            let s = se(a, c, k).hypot(se(b, c, k));
            if k == "reflectance" {
                se_r = se_r.max(s);
            }
            if p != q {
                worst = worst.max(if s > 0.0 { (p - q).abs() / s } else { f64::INFINITY });
            }
        }
    }
    (worst, se_r)
}

/// The CSV of the savings table, with its header comment.
fn savings_csv(k: usize, k_mc: usize, samples: u64, seed: u64) -> Csv {
    let mut csv = Csv::new(&[
        "scene",
        "method",
        "skipped",
        "planned_s_median",
        "planned_s_min",
        "planned_s_max",
        "all_effects_s_median",
        "all_effects_s_min",
        "all_effects_s_max",
        "speedup_median_ratio",
        "speedup_min",
        "speedup_max",
        "max_diff",
        "tolerance",
        "equal",
    ]);
    csv.comment(format!(
    "solver time: median, min and max of {k} runs (multi-flux, default streams) or of {k_mc} (Monte Carlo, \
     {samples} photons, one thread, seed {}); tolerance: multi-flux {MF_TOL:e} (+ the transmission \
     cut-off bound), Monte Carlo 4 combined standard errors",
    seed
));
    csv
}

/// The planned and the full solution compared: (difference, tolerance,
/// both in words). Monte Carlo: in combined standard errors, within 4;
/// multi-flux: the largest absolute difference, within rounding plus the
/// bound of a transmission cut-off.
fn difference(
    method: &str,
    planned: &km_core::Solution,
    full: &km_core::Solution,
) -> (f64, f64, String, String) {
    if method == "mc" {
        let (sig, se) = mc_sigmas(planned, full);
        let d = max_diff(planned, full);
        (
            sig,
            4.0,
            format!("{} ({:.2} se)", format_number(d), sig),
            format!("4 se = {}", format_number(4.0 * se)),
        )
    } else {
        let bound = planned.to_json().get("cutoff_bound").and_then(|v| v.as_f64()).unwrap_or(0.0);
        let tol = MF_TOL + bound;
        let d = max_diff(planned, full);
        let tt = if bound > 0.0 {
            format!("{MF_TOL:.0e} + cut-off {}", format_number(bound))
        } else {
            format!("{MF_TOL:.0e}")
        };
        (d, tol, format_number(d), tt)
    }
}

/// The savings table: time with the plan vs everything on.
///
/// # Errors
/// Solver or file errors.
pub fn recipe(ctx: &mut Ctx) -> anyhow::Result<Section> {
    let k = ctx.size.pick(3, 9, 25);
    let samples = ctx.size.pick(5_000u64, 200_000, 2_000_000);
    let k_mc = ctx.size.pick(1, 3, 3);
    let mut t = Table::new(&[
        "scene",
        "method",
        "skipped by the plan",
        "planned: median (min to max)",
        "all effects: median (min to max)",
        "speed-up: ratio of medians (extremes)",
        "max difference",
        "tolerance",
        "equal",
    ]);
    let mut csv = savings_csv(k, k_mc, samples, ctx.seed);
    let (mut n_equal, mut n) = (0, 0);
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for (name, method, text) in scenes() {
        let scene = Scene::from_toml_str(&text)?;
        let plan = km::plan_for(&scene, method.parse::<Method>()?, false);
        let reps = if method == "mc" { k_mc } else { k };
        let (planned, tp) = best_of(reps, &scene, method, false, samples, ctx.seed)?;
        let (full, tf) = best_of(reps, &scene, method, true, samples, ctx.seed)?;
        let (diff, tol, diff_text, tol_text) = difference(method, &planned, &full);
        let equal = diff <= tol;
        n += 1;
        n_equal += usize::from(equal);
        let ratio = tf.ratio(&tp);
        let speedup = ratio.0;
        lo = lo.min(speedup);
        hi = hi.max(speedup);
        let skipped = plan.skipped.iter().map(|s| s.name()).collect::<Vec<_>>().join(", ");
        t.push(vec![
            name.to_string(),
            method.to_string(),
            skipped.clone(),
            tp.text(),
            tf.text(),
            ratio_text(ratio),
            diff_text,
            tol_text.clone(),
            if equal { "yes".into() } else { "NO".into() },
        ]);
        csv.push(vec![
            name.to_string(),
            method.to_string(),
            skipped,
            crate::data::num(tp.median),
            crate::data::num(tp.min),
            crate::data::num(tp.max),
            crate::data::num(tf.median),
            crate::data::num(tf.min),
            crate::data::num(tf.max),
            crate::data::num(ratio.0),
            crate::data::num(ratio.1),
            crate::data::num(ratio.2),
            crate::data::num(max_diff(&planned, &full)),
            tol_text,
            equal.to_string(),
        ]);
    }
    ctx.csv("savings", &mut csv)?;
    let mut sec = Section::new("What the planner saves");
    sec.text(format!(
        "Solver time with the plan (`km solve`) against `--all-effects` (every interface \
         built, also between equal indices; every layer eigen-solved, also those that only \
         absorb; every Fourier order the streams resolve, also for totals; no thick-layer \
         cut-off; every channel solved; for Monte Carlo a Fresnel test at every boundary and \
         angular rings). Multi-flux times are the median of {k} runs with the default streams; \
         Monte Carlo times the median of {k_mc} runs of {samples} photons on one thread \
         (the two runs draw different random \
         numbers where the Fresnel test is added, so their totals differ by noise, judged in \
         combined standard errors; where only tallies are added the streams are the same and \
         the totals identical). The multi-flux answers agree to rounding ({MF_TOL:.0e}), or \
         within the stated bound of the `transmission` cut-off."
    ))
    .table(t);
    ctx.headline = format!(
        "{n} scenes, speed-up (ratio of median times) {lo:.1}x to {hi:.1}x, {n_equal} of {n} equal within tolerance"
    );
    Ok(sec)
}
