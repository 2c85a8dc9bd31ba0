//! What accuracy costs in time: for each study scene, the error of the total
//! reflectance and of the BRDF against a converged reference, against the
//! solver's wall time, for every method over its range of settings; and the
//! time each method needs to reach 1 %, 0.1 % and 0.01 %.

use km_core::Scene;

use crate::context::{Ctx, Size};
use crate::data::{Csv, num};
use crate::methods::{self, Method};
use crate::recipes::accuracy::{rel, rel_rms, rel_rms_noise};
use crate::report::{Section, Table};
use crate::scenes::{StudyScene, study_scenes};
use km_plot::chart::{LineChart, Mark, Series, format_number};

/// One method at one setting on one scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Point {
    /// The method and setting.
    pub method: Method,
    /// Solver wall time, seconds (best of repeats).
    pub seconds: f64,
    /// Relative error of the total reflectance.
    pub err_r: f64,
    /// Relative RMS error of the BRDF over the exit directions (NaN if the method gives none).
    pub err_brdf: f64,
    /// The total reflectance.
    pub r: f64,
    /// Error bound used for "time to reach": the error itself, or for Monte
    /// Carlo the larger of the error and twice the relative standard error
    /// (so a lucky run does not count as reaching a threshold).
    pub bound_r: f64,
    /// The same for the BRDF (twice the relative RMS noise).
    pub bound_brdf: f64,
    /// Relative standard error of R (Monte Carlo; 0 for deterministic methods).
    pub se_r: f64,
    /// Relative RMS standard error of the BRDF (Monte Carlo; 0 otherwise).
    pub se_brdf: f64,
}

/// Error thresholds of the time-to-reach table.
pub const THRESHOLDS: [f64; 3] = [1e-2, 1e-3, 1e-4];

/// Smallest error shown on the log axes (an exact match is drawn there).
const ERR_FLOOR: f64 = 1e-16;

/// The settings of every method family at this size (Monte Carlo separately).
fn ladder(size: Size) -> Vec<Method> {
    let mut m = vec![Method::TwoFlux];
    let streams: &[usize] = match size {
        Size::Tiny => &[2, 4, 8, 16],
        Size::Quick => &[2, 4, 8, 16, 32],
        Size::Full => &[2, 4, 8, 16, 32, 64, 128],
    };
    m.extend(streams.iter().map(|&s| Method::Multiflux { streams: s }));
    m.extend((0..=3).map(|order| Method::Neumann { order }));
    let dirs: &[usize] = match size {
        Size::Tiny => &[40, 100],
        Size::Quick => &[60, 150, 303],
        Size::Full => &[60, 150, 303, 600],
    };
    m.extend(dirs.iter().map(|&d| Method::DirectionSet { directions: d }));
    m.push(Method::Dipole);
    m
}

/// Evaluate one method against the reference; `None` when the method refuses the scene.
fn point(method: Method, scene: &km_core::Scene, r_ref: f64, b_ref: &[f64]) -> Option<Point> {
    let (sol, seconds) = methods::timed(method, scene, methods::repeats(method)).ok()?;
    let c = sol.channels.first()?;
    let err_brdf = if c.brdf.len() == b_ref.len() && !c.brdf.is_empty() {
        rel_rms(&c.brdf, b_ref)
    } else {
        f64::NAN
    };
    let err_r = rel(c.reflectance, r_ref);
    let (mut bound_r, mut bound_brdf) = (err_r, err_brdf);
    let (mut se_r, mut se_brdf) = (0.0, 0.0);
    if let Some(se) = methods::stderr_of(&sol, "reflectance") {
        se_r = se / r_ref.abs();
        bound_r = bound_r.max(2.0 * se_r);
    }
    if let Some(se) = methods::stderr_list(&sol, "brdf") {
        se_brdf = rel_rms_noise(&se, b_ref);
        bound_brdf = bound_brdf.max(2.0 * se_brdf);
    }
    Some(Point {
        method,
        seconds,
        err_r,
        err_brdf,
        r: c.reflectance,
        bound_r,
        bound_brdf,
        se_r,
        se_brdf,
    })
}

/// The Pareto study.
///
/// # Errors
/// Solver (of the reference), drawing or file errors.
pub fn recipe(ctx: &mut Ctx) -> anyhow::Result<Section> {
    let scenes = study_scenes(ctx.size.pick(4, 10, 18))?;
    let ref_streams = methods::reference_streams(ctx.size);
    // Monte Carlo ladder: x10 per step while the next step fits the per-scene budget.
    let (mc_cap, mc_budget) =
        ctx.size.pick((10_000u64, 0.3), (10_000_000, 5.0), (100_000_000, 300.0));
    let mut sec = Section::new("What accuracy costs in time");
    sec.text(format!(
        "For each scene, every method at each of its settings is compared with a converged \
         reference (multi-flux, {ref_streams} streams): the relative error of the total \
         reflectance and the relative RMS error of the BRDF over exit directions in the plane \
         of incidence (0 to 80 degrees, both sides), against the solver's own wall time (best \
         of several runs for the fast methods). Methods: two-flux Kubelka-Munk (its BRDF is \
         the Lambertian-equivalent (R - R_specular)/pi), multi-flux with 2 to {} streams, \
         the adding with the Neumann series truncated at orders 0 to 3, the seed's direction-set \
         scheme (totals only, its BRDF lives on its nodes), Monte Carlo from 10^3 photons up to \
         {mc_cap:.0e} or a budget of {mc_budget} s per scene, and the dipole where it applies (the \
         half-space). Errors below {ERR_FLOOR:.0e} are drawn at that floor; a Monte Carlo \
         error includes its noise and its 5 degree cone-bin bias.",
        ladder(ctx.size)
            .iter()
            .filter_map(|m| match m {
                Method::Multiflux { streams } => Some(*streams),
                _ => None,
            })
            .max()
            .unwrap_or(0),
    ));
    let mut reach = Table::new(&[
        "scene",
        "method",
        "R 1 %",
        "R 0.1 %",
        "R 0.01 %",
        "BRDF 1 %",
        "BRDF 0.1 %",
        "BRDF 0.01 %",
    ]);
    let mut best_summary = Vec::new();
    for sc in &scenes {
        let reference = methods::solve(Method::Multiflux { streams: ref_streams }, &sc.scene)?;
        let rc = reference.channels.first().ok_or_else(|| anyhow::anyhow!("empty reference"))?;
        let (r_ref, b_ref) = (rc.reflectance, rc.brdf.clone());
        let points = scene_points(ctx, &sc.scene, r_ref, &b_ref, (mc_cap, mc_budget));
        let stem = format!("pareto-{}", sc.name);
        pareto_csv(ctx, &stem, sc, ref_streams, r_ref, &points)?;
        pareto_charts(ctx, &mut sec, sc, &stem, &points)?;
        reach_rows(&mut reach, sc.name, &points);
        if let Some(p) = points
            .iter()
            .filter(|p| p.bound_r <= 1e-3)
            .min_by(|a, b| a.seconds.total_cmp(&b.seconds))
        {
            best_summary.push(format!("{}: {}", sc.name, p.method));
        }
    }
    sec.text(
        "Time for each method to reach a relative error of 1 %, 0.1 % and 0.01 % (the fastest \
         setting that does, with the setting in brackets; \"not reached\" when no setting tried \
         here does). A Monte Carlo run counts only if twice its standard error is below the \
         threshold too, so that a lucky run does not count:",
    )
    .table(reach);
    ctx.headline = format!("fastest to 0.1 % in R: {}", best_summary.join("; "));
    Ok(sec)
}

/// The method families of the charts and the table, in legend order.
const FAMILIES: [&str; 6] = ["km", "multiflux", "neumann", "direction-set", "montecarlo", "dipole"];

/// Every setting of the ladder on `scene`, then Monte Carlo at x10 photons
/// per step while the next step fits `mc = (photon cap, seconds budget)`.
fn scene_points(ctx: &Ctx, scene: &Scene, r_ref: f64, b_ref: &[f64], mc: (u64, f64)) -> Vec<Point> {
    let (mc_cap, mc_budget) = mc;
    let mut points: Vec<Point> =
        ladder(ctx.size).into_iter().filter_map(|m| point(m, scene, r_ref, b_ref)).collect();
    let mut samples = 1_000u64;
    while samples <= mc_cap {
        let Some(p) = point(Method::MonteCarlo { samples, seed: ctx.seed }, scene, r_ref, b_ref)
        else {
            break;
        };
        let t = p.seconds;
        points.push(p);
        if t * 10.0 > mc_budget {
            break;
        }
        samples *= 10;
    }
    points
}

/// `pareto-SCENE.csv`: every point of one scene.
fn pareto_csv(
    ctx: &Ctx,
    stem: &str,
    sc: &StudyScene,
    ref_streams: usize,
    r_ref: f64,
    points: &[Point],
) -> anyhow::Result<()> {
    let mut csv =
        Csv::new(&["family", "method", "setting", "seconds", "rel_err_R", "rel_rms_err_BRDF", "R"]);
    csv.comment(format!("accuracy vs time, scene {}: {}", sc.name, sc.description));
    csv.comment(format!("reference: multi-flux {ref_streams} streams, R = {r_ref:e}"));
    for p in points {
        csv.push(vec![
            p.method.family().into(),
            p.method.to_string(),
            num(p.method.setting()),
            num(p.seconds),
            num(p.err_r),
            num(p.err_brdf),
            num(p.r),
        ]);
    }
    ctx.csv(stem, &mut csv)
}

/// The charts of one scene, one per error measure (R, BRDF), against time.
fn pareto_charts(
    ctx: &Ctx,
    sec: &mut Section,
    sc: &StudyScene,
    stem: &str,
    points: &[Point],
) -> anyhow::Result<()> {
    type Get = fn(&Point) -> f64;
    for (suffix, measure, get, get_se) in [
        ("R", "relative error of R", (|p: &Point| p.err_r) as Get, (|p: &Point| p.se_r) as Get),
        ("brdf", "relative RMS error of the BRDF", |p: &Point| p.err_brdf, |p: &Point| p.se_brdf),
    ] {
        let mut chart = LineChart {
            title: format!("{}: {measure} against time", sc.name),
            x_label: "solver wall time (s)".into(),
            y_label: measure.into(),
            x_log: true,
            y_log: true,
            h_lines: vec![(1e-2, "1 %".into()), (1e-3, "0.1 %".into()), (1e-4, "0.01 %".into())],
            ..Default::default()
        };
        for (k, fam) in FAMILIES.iter().enumerate() {
            let mut pts: Vec<(f64, f64, f64, String)> = points
                .iter()
                .filter(|p| p.method.family() == *fam && get(p).is_finite())
                .map(|p| (p.seconds.max(1e-9), get(p).max(ERR_FLOOR), get_se(p), setting(p)))
                .collect();
            if pts.is_empty() {
                continue;
            }
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            let xy: Vec<(f64, f64)> = pts.iter().map(|p| (p.0, p.1)).collect();
            let labels: Vec<String> = pts.iter().map(|p| p.3.clone()).collect();
            // Monte Carlo: points with their ± 1 standard error (a line
            // through noisy errors would suggest a trend that is noise).
            let series = if *fam == "montecarlo" {
                Series::new(legend_name(fam), xy, Mark::Points, k)
                    .with_y_err(pts.iter().map(|p| p.2).collect())
            } else {
                Series::new(legend_name(fam), xy, Mark::LinePoints, k)
            };
            chart.series.push(series.with_point_labels(labels));
        }
        ctx.chart(&format!("{stem}-{suffix}"), &chart)?;
        sec.figure_data(
            format!("{stem}-{suffix}"),
            format!("{}: {measure} against wall time", sc.description),
            stem,
        );
    }
    Ok(())
}

/// The legend's name of a method family, saying what its points' labels are.
fn legend_name(family: &str) -> String {
    match family {
        "km" => "two-flux Kubelka-Munk".into(),
        "multiflux" => "multi-flux (label: streams)".into(),
        "neumann" => "adding by the Neumann series, truncated (label: order)".into(),
        "direction-set" => "seed's direction-set (label: directions)".into(),
        "montecarlo" => "Monte Carlo ± 1 s.e. (label: photons; arrow: to 0)".into(),
        "dipole" => "diffusion dipole".into(),
        other => other.into(),
    }
}

/// A point's label: its setting (streams, order, directions, photons), or
/// nothing for the methods without one.
fn setting(p: &Point) -> String {
    match p.method {
        Method::TwoFlux | Method::Dipole => String::new(),
        Method::MonteCarlo { samples, .. } => format!("{:.0e}", samples as f64),
        _ => format!("{}", p.method.setting()),
    }
}

/// Rows of the table: per family, the time to reach each threshold.
fn reach_rows(reach: &mut Table, name: &str, points: &[Point]) {
    for fam in FAMILIES {
        let fam_points: Vec<&Point> = points.iter().filter(|p| p.method.family() == fam).collect();
        if fam_points.is_empty() {
            continue;
        }
        let time_to = |thr: f64, get: fn(&Point) -> f64| -> String {
            fam_points
                .iter()
                .filter(|p| get(p) <= thr)
                .min_by(|a, b| a.seconds.total_cmp(&b.seconds))
                .map(|p| format!("{} s ({})", format_number(p.seconds), p.method))
                .unwrap_or_else(|| "not reached".into())
        };
        let mut row = vec![name.to_string(), fam.to_string()];
        for thr in THRESHOLDS {
            row.push(time_to(thr, |p| p.bound_r));
        }
        for thr in THRESHOLDS {
            row.push(time_to(thr, |p| p.bound_brdf));
        }
        reach.push(row);
    }
}
