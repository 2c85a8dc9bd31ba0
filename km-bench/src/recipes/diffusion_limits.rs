//! Where diffusion fails, measured: the dipole's total diffuse reflectance
//! of a half-space against the multi-flux solver and the Monte Carlo tracer
//! over albedo 0.1 .. 0.9999, `g` in {0, 0.9} and relative index 1 and 1.3
//! (normal incidence), and its radial profile `Rd(r)` against Monte Carlo
//! for measured materials (Jensen et al. 2001).
//!
//! Both transport solvers return every scattering order; the dipole models
//! multiple scattering only. The single-scattering part of the half-space
//! is computed here in closed form ([`single_scattering_reflectance`]), so
//! the dipole is compared both with the total diffuse reflectance and with
//! its multiple-scattering part (total minus single scattering).

use std::time::Instant;

use km_core::fresnel::{critical_cos, reflectance};
use km_core::quadrature::integrate_gl;
use km_core::{Scene, Substrate};

use crate::context::Ctx;
use crate::data::Csv;
use crate::methods;
use crate::report::{Section, Table};
use crate::scenes::slab;
use km_plot::chart::{LineChart, Mark, Series, format_number};

mod profiles;

use profiles::profiles;

/// Relative error above which the dipole is called "off".
const THRESHOLD: f64 = 0.10;

/// The reflectance of a half-space (unit extinction, single-scattering
/// albedo `albedo`, Henyey–Greenstein `g`, relative index `eta` against an
/// ambient of index 1) due to light scattered exactly once, for a
/// collimated beam at normal incidence, as a fraction of the incident power.
///
/// The beam enters with `1 - F(1)`, decays as `exp(-tau)`; the radiance
/// scattered once at depth `tau` into the internal upward direction `mu`
/// decays as `exp(-tau / mu)` and leaves with `1 - F_int(mu)` (zero beyond
/// the critical angle). Integrating over depth gives
/// `mu0 / (mu0 + mu)` with `mu0 = 1`, so (the first-order term of the
/// diffuse reflection of a semi-infinite medium, Chandrasekhar 1960; the
/// single-scattering term of Hanrahan & Krueger 1993 for an infinitely
/// thick layer, with its Fresnel factors; docs/diffusion.md eq. D23):
///
/// `R1 = (1 - F(1)) (albedo / 2) int_0^1 p(-mu) mu / (1 + mu) (1 - F_int(mu)) dmu`   (eq. D23)
///
/// with `p(cos) = (1 - g^2) / (1 + g^2 - 2 g cos)^(3/2)` (normalised to
/// `int p dOmega / (4 pi) = 1`). For `g = 0`, `eta = 1`:
/// `R1 = (albedo / 2)(1 - ln 2)`.
pub fn single_scattering_reflectance(albedo: f64, g: f64, eta: f64) -> f64 {
    let mu_c = critical_cos(eta, 1.0);
    let hg = |c: f64| (1.0 - g * g) / (1.0 + g * g - 2.0 * g * c).powf(1.5);
    let f = |mu: f64| hg(-mu) * mu / (1.0 + mu) * (1.0 - reflectance(mu, eta, 1.0));
    // The integrand is smooth on [mu_c, 1] (zero below): 64 Gauss points.
    let integral = integrate_gl(f, mu_c, 1.0, 64);
    (1.0 - reflectance(1.0, 1.0, eta)) * 0.5 * albedo * integral
}

/// One point of the totals study.
#[derive(Debug, Clone, Copy)]
struct Point {
    eta: f64,
    g: f64,
    albedo: f64,
    /// Dipole diffuse reflectance per incident power, `(1 - F(1)) Rd`.
    dipole: f64,
    /// Multi-flux `R - R_specular` at the reference streams and at half of them.
    mf: f64,
    mf_half: f64,
    /// Exact single-scattering part (eq. D23).
    single: f64,
    /// Monte Carlo `R - R_specular` and its standard error.
    mc: f64,
    mc_se: f64,
}

impl Point {
    /// Relative error of the dipole against the total diffuse reflectance.
    fn err_total(&self) -> f64 {
        self.dipole / self.mf - 1.0
    }
    /// Relative error of the dipole against the multiple-scattering part.
    fn err_multiple(&self) -> f64 {
        self.dipole / (self.mf - self.single) - 1.0
    }
}

/// The albedo below which `|err| > THRESHOLD`: the points are sorted by
/// albedo; from the largest albedo whose error exceeds the threshold, the
/// crossing with the next (higher-albedo) point is interpolated linearly in
/// `log10(1 - albedo)`. `Ok(None)`: within the threshold everywhere;
/// `Err(())`: off at the highest albedo too.
fn threshold_albedo(albedo: &[f64], err: &[f64]) -> Result<Option<f64>, ()> {
    let Some(i) = (0..err.len()).rev().find(|&i| err[i].abs() > THRESHOLD) else {
        return Ok(None);
    };
    if i + 1 == err.len() {
        return Err(());
    }
    let (x0, x1) = ((1.0 - albedo[i]).log10(), (1.0 - albedo[i + 1]).log10());
    let (e0, e1) = (err[i].abs(), err[i + 1].abs());
    let t = (e0 - THRESHOLD) / (e0 - e1);
    Ok(Some(1.0 - 10f64.powf(x0 + t * (x1 - x0))))
}

/// Words for [`threshold_albedo`].
fn threshold_words(t: Result<Option<f64>, ()>) -> String {
    match t {
        Ok(Some(a)) => format!("{a:.4}"),
        Ok(None) => "none (within 10 % at every albedo)".into(),
        Err(()) => "off at every albedo".into(),
    }
}

/// A half-space of unit extinction at normal incidence.
fn half_space(albedo: f64, g: f64, eta: f64) -> anyhow::Result<Scene> {
    slab(f64::INFINITY, albedo, g, eta, 0.0, Substrate::Transparent { n: 1.0 }, vec![])
}

/// Multi-flux diffuse reflectance `R - R_specular` with `streams` nodes.
fn multiflux_diffuse(scene: &Scene, streams: usize) -> anyhow::Result<f64> {
    let s = methods::solve(methods::Method::Multiflux { streams }, scene)?;
    let c = &s.channels[0];
    Ok(c.reflectance - c.reflectance_specular)
}

/// The recipe: totals over albedo, then `Rd(r)` of three presets.
///
/// # Errors
/// Solver, drawing or file errors.
pub fn recipe(ctx: &mut Ctx) -> anyhow::Result<Section> {
    let mut sec = Section::new("Where diffusion fails, measured");
    let totals = totals(ctx, &mut sec)?;
    let profiles = profiles(ctx, &mut sec)?;
    ctx.headline = format!("{totals}; {profiles}");
    Ok(sec)
}

/// Part 1: total diffuse reflectance over albedo.
fn totals(ctx: &mut Ctx, sec: &mut Section) -> anyhow::Result<String> {
    let albedos: Vec<f64> = match ctx.size {
        crate::context::Size::Tiny => vec![0.1, 0.5, 0.9, 0.99, 0.999],
        _ => vec![0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 0.99, 0.999, 0.9999],
    };
    let gs = [0.0, 0.9];
    let etas = [1.0, 1.3];
    let samples = ctx.size.pick(2_000u64, 15_000, 400_000);
    let streams = methods::reference_streams(ctx.size);
    let grid = Grid { albedos: &albedos, gs: &gs, etas: &etas, samples, streams };
    let (pts, (t_dip, t_mf, t_mc)) = total_points(ctx, &grid)?;
    totals_csv(ctx, &pts, &grid)?;
    totals_charts(ctx, &pts, &grid)?;
    let (tt, headline) = threshold_table(&pts, &grid);
    let tp = points_table(&pts);
    sec.text(format!(
        "A half-space of unit extinction (Henyey–Greenstein `g`, relative index `eta` against \
         air, no other boundary) lit by a collimated beam at normal incidence, at {} albedos \
         from {} to {}. Quantity: the diffuse reflectance `R - R_specular` per unit incident \
         power. The multi-flux solver (Fourier–Gauss, {streams} streams, a half-space is `tau = \
         inf`) and the Monte Carlo tracer ({samples:.1e} photons per point) include every \
         scattering order, single scattering too; the dipole (Jensen et al. 2001, `(1 - F(1)) \
         Rd`, exact `F_dr`) is meant to model multiple scattering only. The single-scattering \
         part is computed exactly (first-order term, eq. D23 in docs/diffusion.md §11), so the \
         dipole is compared with both: **the primary 10 % threshold uses the total diffuse \
         reflectance** (what the transport solvers return, single scattering included); the \
         second uses the multiple-scattering part (multi-flux minus the exact single \
         scattering). The threshold is the largest albedo at which the dipole is off by more \
         than 10 %, interpolated linearly in `log(1 - albedo)` towards the next grid point. \
         Multi-flux convergence: the same at {} streams. Wall time: dipole {}, multi-flux {} \
         (two stream counts), Monte Carlo {}.",
        albedos.len(),
        albedos[0],
        albedos[albedos.len() - 1],
        streams / 2,
        secs(t_dip),
        secs(t_mf),
        secs(t_mc),
    ))
    .figure_data(
        "diffusion-limits-total-g0",
        "Diffuse reflectance of a half-space, g = 0: dipole, multi-flux, Monte Carlo",
        "diffusion-limits-total",
    )
    .figure_data(
        "diffusion-limits-total-g09",
        "Diffuse reflectance of a half-space, g = 0.9: dipole, multi-flux, Monte Carlo",
        "diffusion-limits-total",
    )
    .figure_data(
        "diffusion-limits-error",
        "|Relative error| of the dipole against the multi-flux total (solid) and its \
         multiple-scattering part (dashed); the dotted line is 10 %",
        "diffusion-limits-total",
    )
    .table(tt)
    .text(
        "Every point (the Monte Carlo column with its standard error; the relative errors are \
         against multi-flux):",
    )
    .table(tp);
    Ok(headline.join(", "))
}

/// The grid of part 1: albedos, `g`, relative indices, and the work per point.
struct Grid<'a> {
    albedos: &'a [f64],
    gs: &'a [f64],
    etas: &'a [f64],
    samples: u64,
    streams: usize,
}

/// The points of one (`eta`, `g`) case, in albedo order.
fn case_pts(pts: &[Point], eta: f64, g: f64) -> impl Iterator<Item = &Point> {
    pts.iter().filter(move |p| p.eta == eta && p.g == g)
}

/// Every point of the grid by the dipole, multi-flux (two stream counts)
/// and Monte Carlo, with the wall times of the three (seconds).
fn total_points(ctx: &Ctx, grid: &Grid) -> anyhow::Result<(Vec<Point>, (f64, f64, f64))> {
    let Grid { albedos, gs, etas, samples, streams } = *grid;
    let (mut t_dip, mut t_mf, mut t_mc) = (0.0, 0.0, 0.0);
    let mut pts = Vec::new();
    let mut k = 0u64;
    for &eta in etas {
        for &g in gs {
            for &albedo in albedos {
                let scene = half_space(albedo, g, eta)?;
                let t = Instant::now();
                let dipole = km_dipole::compare::diffuse_reflectance_collimated(
                    albedo,
                    g,
                    eta,
                    1.0,
                    Default::default(),
                )?;
                t_dip += t.elapsed().as_secs_f64();
                let t = Instant::now();
                let mf = multiflux_diffuse(&scene, streams)?;
                let mf_half = multiflux_diffuse(&scene, streams / 2)?;
                t_mf += t.elapsed().as_secs_f64();
                let t = Instant::now();
                let opts = methods::mc_options(samples, ctx.seed.wrapping_add(1000 + k));
                k += 1;
                let mc = km_montecarlo::solve(&scene, &opts)?;
                t_mc += t.elapsed().as_secs_f64();
                let c = &mc.channels[0];
                pts.push(Point {
                    eta,
                    g,
                    albedo,
                    dipole,
                    mf,
                    mf_half,
                    single: single_scattering_reflectance(albedo, g, eta),
                    mc: c.reflectance - c.reflectance_specular,
                    mc_se: methods::stderr_of(&mc, "reflectance").unwrap_or(f64::NAN),
                });
            }
        }
    }
    Ok((pts, (t_dip, t_mf, t_mc)))
}

/// `diffusion-limits-total.csv`: every point.
fn totals_csv(ctx: &Ctx, pts: &[Point], grid: &Grid) -> anyhow::Result<()> {
    let (samples, streams) = (grid.samples, grid.streams);
    // CSV of every point.
    let mut csv = Csv::new(&[
        "eta",
        "g",
        "albedo",
        "one_minus_albedo",
        "dipole",
        "multiflux",
        "multiflux_half_streams",
        "single_scattering",
        "multiflux_minus_single",
        "montecarlo",
        "montecarlo_stderr",
        "rel_err_dipole_vs_total",
        "rel_err_dipole_vs_multiple",
    ]);
    csv.comment(format!(
        "Half-space, sigma_t = 1, HG phase, ambient index 1, collimated beam at normal incidence. \
         Diffuse reflectance = R - R_specular per unit incident power. dipole: (1 - F(1)) Rd \
         (Jensen et al. 2001, classical, exact F_dr), multiple scattering only. multiflux: \
         Fourier-Gauss, {streams} streams (and {} for the convergence check), all orders. \
         single_scattering: exact first order (eq. D23 of docs/diffusion.md). montecarlo: {samples} \
         photons per point, survival biasing, seeds base+1000+k, all orders.",
        streams / 2
    ));
    for p in pts {
        csv.push_nums(&[
            p.eta,
            p.g,
            p.albedo,
            1.0 - p.albedo,
            p.dipole,
            p.mf,
            p.mf_half,
            p.single,
            p.mf - p.single,
            p.mc,
            p.mc_se,
            p.err_total(),
            p.err_multiple(),
        ]);
    }
    ctx.csv("diffusion-limits-total", &mut csv)
}

/// The charts: reflectance against `1 - albedo` (one per `g`), and the
/// dipole's relative error.
fn totals_charts(ctx: &Ctx, pts: &[Point], grid: &Grid) -> anyhow::Result<()> {
    let Grid { gs, etas, samples, streams, .. } = *grid;
    // Charts: reflectance against 1 - albedo, one per g.
    for (gi, &g) in gs.iter().enumerate() {
        let mut series = Vec::new();
        for (ei, &eta) in etas.iter().enumerate() {
            let c = 4 * ei;
            let xy = |f: &dyn Fn(&Point) -> f64| -> Vec<(f64, f64)> {
                case_pts(pts, eta, g).map(|p| (1.0 - p.albedo, f(p))).collect()
            };
            series.push(Series::new(
                format!("dipole, eta {eta}"),
                xy(&|p| p.dipole),
                Mark::Line,
                c,
            ));
            series.push(Series::new(
                format!("multi-flux {streams} (all orders), eta {eta}"),
                xy(&|p| p.mf),
                Mark::LinePoints,
                c + 1,
            ));
            series.push(Series::new(
                format!("multi-flux minus single scattering, eta {eta}"),
                xy(&|p| p.mf - p.single),
                Mark::Dashed,
                c + 2,
            ));
            series.push(
                Series::new(
                    format!("Monte Carlo {samples:.1e} (± 1 s.e.), eta {eta}"),
                    xy(&|p| p.mc),
                    Mark::Points,
                    c + 3,
                )
                .with_y_err(case_pts(pts, eta, g).map(|p| p.mc_se).collect()),
            );
        }
        let stem = format!("diffusion-limits-total-g{}", if gi == 0 { "0" } else { "09" });
        let chart = LineChart {
            title: format!("Half-space diffuse reflectance, g = {g}, normal incidence"),
            x_label: "1 - albedo".into(),
            y_label: "R - R_specular".into(),
            x_log: true,
            y_log: true,
            series,
            ..Default::default()
        };
        ctx.chart(&stem, &chart)?;
    }
    // Chart: |relative error| of the dipole against 1 - albedo.
    let mut series = Vec::new();
    for (ei, &eta) in etas.iter().enumerate() {
        for (gi, &g) in gs.iter().enumerate() {
            let c = 2 * ei + gi;
            let xy = |f: &dyn Fn(&Point) -> f64| -> Vec<(f64, f64)> {
                case_pts(pts, eta, g).map(|p| (1.0 - p.albedo, f(p).abs())).collect()
            };
            series.push(Series::new(
                format!("vs total, g {g}, eta {eta}"),
                xy(&|p| p.err_total()),
                Mark::LinePoints,
                c,
            ));
            series.push(Series::new(
                format!("vs multiple scattering, g {g}, eta {eta}"),
                xy(&|p| p.err_multiple()),
                Mark::Dashed,
                c,
            ));
        }
    }
    let chart = LineChart {
        title: "Dipole: |relative error| against multi-flux".into(),
        // The same axis as the reflectance charts it accompanies.
        x_label: "1 - albedo".into(),
        y_label: "|dipole / reference - 1|".into(),
        x_log: true,
        y_log: true,
        series,
        h_lines: vec![(THRESHOLD, "10 %".into())],
        ..Default::default()
    };
    ctx.chart("diffusion-limits-error", &chart)
}

/// The thresholds table (per `eta`, `g`) and the headline's words.
fn threshold_table(pts: &[Point], grid: &Grid) -> (Table, Vec<String>) {
    let Grid { gs, etas, .. } = *grid;
    let mut tt = Table::new(&[
        "eta",
        "g",
        "albedo below which |dipole/total - 1| > 10 %",
        "same vs multiple scattering",
        "worst |error| vs total (albedo)",
        "error vs total at albedo 0.99",
        "multi-flux convergence max |R(N) - R(N/2)|",
        "max |MC - multi-flux| / MC s.e.",
    ]);
    let mut headline = Vec::new();
    for &eta in etas {
        for &g in gs {
            let c: Vec<&Point> = case_pts(pts, eta, g).collect();
            let a: Vec<f64> = c.iter().map(|p| p.albedo).collect();
            let et: Vec<f64> = c.iter().map(|p| p.err_total()).collect();
            let em: Vec<f64> = c.iter().map(|p| p.err_multiple()).collect();
            let tt_total = threshold_albedo(&a, &et);
            let worst = c
                .iter()
                .max_by(|x, y| x.err_total().abs().total_cmp(&y.err_total().abs()))
                .map(|p| format!("{:+.1} % ({})", 100.0 * p.err_total(), p.albedo))
                .unwrap_or_default();
            let at99 = c
                .iter()
                .find(|p| p.albedo == 0.99)
                .map(|p| format!("{:+.1} %", 100.0 * p.err_total()))
                .unwrap_or_else(|| "-".into());
            let conv = c.iter().map(|p| (p.mf - p.mf_half).abs()).fold(0.0, f64::max);
            let z = c.iter().map(|p| (p.mc - p.mf).abs() / p.mc_se).fold(0.0, f64::max);
            if eta == 1.0 {
                headline.push(format!(
                    "eta 1, g {g}: off > 10 % below albedo {}",
                    threshold_words(tt_total)
                ));
            }
            tt.push(vec![
                format!("{eta}"),
                format!("{g}"),
                threshold_words(tt_total),
                threshold_words(threshold_albedo(&a, &em)),
                worst,
                at99,
                format!("{conv:.1e}"),
                format!("{z:.1}"),
            ]);
        }
    }
    (tt, headline)
}

/// The table of every point.
fn points_table(pts: &[Point]) -> Table {
    let mut tp = Table::new(&[
        "eta",
        "g",
        "albedo",
        "dipole",
        "multi-flux (all orders)",
        "single scattering",
        "Monte Carlo",
        "dipole vs total",
        "dipole vs multiple",
    ]);
    for p in pts {
        tp.push(vec![
            format!("{}", p.eta),
            format!("{}", p.g),
            format!("{}", p.albedo),
            format!("{:.4}", p.dipole),
            format!("{:.4}", p.mf),
            format!("{:.4}", p.single),
            format!("{:.4} ± {:.4}", p.mc, p.mc_se),
            format!("{:+.1} %", 100.0 * p.err_total()),
            format!("{:+.1} %", 100.0 * p.err_multiple()),
        ]);
    }
    tp
}

/// Seconds, compactly.
fn secs(s: f64) -> String {
    format!("{} s", format_number(s))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_scattering_of_an_isotropic_index_matched_half_space() {
        // Closed form (albedo / 2)(1 - ln 2); quadrature of a smooth integrand: 1e-14.
        let exact = 0.45 * (1.0 - 2f64.ln());
        assert!((single_scattering_reflectance(0.9, 0.0, 1.0) - exact).abs() < 1e-14);
    }

    #[test]
    fn single_scattering_matches_multiflux_at_low_albedo() {
        // The second order is O(albedo) relative to the first: measured
        // 6e-4 .. 1.4e-3 at albedo 1e-3, independent of the streams (32 or
        // 64), so at albedo 1e-4 the multi-flux total equals eq. D23 to about
        // 1.5e-4 relative; tolerance 3e-4 (also above the 32-stream
        // discretisation, below 2e-5 relative for these cases).
        for (g, eta) in [(0.0, 1.0), (0.5, 1.3), (0.9, 1.0)] {
            let a = 1e-4;
            let scene = half_space(a, g, eta).unwrap();
            let mf = multiflux_diffuse(&scene, 32).unwrap();
            let r1 = single_scattering_reflectance(a, g, eta);
            assert!((mf / r1 - 1.0).abs() < 3e-4, "g {g} eta {eta}: multi-flux {mf}, eq. D23 {r1}");
        }
    }

    #[test]
    fn threshold_is_interpolated_in_log_one_minus_albedo() {
        let a = [0.9, 0.99, 0.999];
        // Off at 0.9 (20 %), fine at 0.99 (0 %): the crossing at half way in log(1 - a).
        let t = threshold_albedo(&a, &[0.2, 0.0, 0.0]).unwrap().unwrap();
        assert!((t - (1.0 - 10f64.powf(-1.5))).abs() < 1e-12);
        assert_eq!(threshold_albedo(&a, &[0.0, 0.05, 0.0]), Ok(None));
        assert_eq!(threshold_albedo(&a, &[0.2, 0.2, 0.2]), Err(()));
    }
}
