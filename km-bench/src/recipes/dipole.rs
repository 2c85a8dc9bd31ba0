//! The dipole where it applies: the radially resolved diffuse reflectance
//! `Rd(r)` of a half-space under a pencil beam, dipole (Jensen et al. 2001)
//! against the Monte Carlo tracer (MCML's `Rd(r)`), and the totals against
//! the multi-flux solver.

use km_core::Substrate;

use crate::context::Ctx;
use crate::data::Csv;
use crate::methods::{self, Method};
use crate::report::{Section, Table};
use crate::scenes::slab;
use km_plot::chart::{LineChart, Mark, Series, format_number};

/// `Rd(r)`: dipole against Monte Carlo, and totals against multi-flux.
///
/// # Errors
/// Solver, drawing or file errors.
pub fn recipe(ctx: &mut Ctx) -> anyhow::Result<Section> {
    let albedo = 0.99;
    let n = 1.3;
    // Half-space, unit extinction, isotropic, index 1.3, normal incidence.
    let scene =
        slab(f64::INFINITY, albedo, 0.0, n, 0.0, Substrate::Transparent { n: 1.0 }, vec![])?;
    let samples = ctx.size.pick(2_000u64, 100_000, 10_000_000);
    let bins = km_montecarlo::RadialBins { dr: 0.25, count: 40 };
    let mc = km_montecarlo::radial_profile(&scene, &methods::mc_options(samples, ctx.seed), bins)?;
    let dip = km_dipole::profile(&scene, &mc.r, &Default::default())?;
    let (rd_mc, se_mc, rd_dip) = (&mc.rd[0], &mc.stderr[0], &dip[0]);
    let mut csv = Csv::new(&["r", "rd_mc", "rd_mc_stderr", "rd_dipole"]);
    csv.comment(format!(
        "Rd(r) of a half-space, sigma_t = 1, albedo {albedo}, g = 0, n = {n}, pencil beam at normal incidence; \
         Monte Carlo {samples} photons, seed {}, annuli dr = {}",
        ctx.seed, bins.dr
    ));
    for i in 0..mc.r.len() {
        csv.push_nums(&[mc.r[i], rd_mc[i], se_mc[i], rd_dip[i]]);
    }
    ctx.csv("dipole-rd", &mut csv)?;
    let pts =
        |v: &[f64]| -> Vec<(f64, f64)> { mc.r.iter().copied().zip(v.iter().copied()).collect() };
    let chart = LineChart {
        title: format!("Rd(r): dipole vs Monte Carlo (albedo {albedo}, n = {n})"),
        // sigma_t = 1: the unit of length is the mean free path 1/sigma_t.
        x_label: "r (mean free paths 1/sigma_t)".into(),
        y_label: "Rd(r) (per mean free path^2)".into(),
        y_log: true,
        series: vec![
            Series::new("dipole (multiple scattering)", pts(rd_dip), Mark::Line, 0),
            Series::new(
                format!("Monte Carlo {samples:.0e} (all orders, ± 1 s.e.)"),
                pts(rd_mc),
                Mark::Points,
                3,
            )
            .with_y_err(se_mc.clone()),
        ],
        ..Default::default()
    };
    ctx.chart("dipole-rd", &chart)?;
    // Totals: diffuse reflectance by each method.
    let mut t = Table::new(&["method", "diffuse reflectance R - R_specular", "wall time (s)"]);
    for m in [
        Method::Dipole,
        Method::Multiflux { streams: methods::reference_streams(ctx.size) },
        Method::TwoFlux,
    ] {
        let (s, secs) = methods::timed(m, &scene, methods::repeats(m))?;
        let c = &s.channels[0];
        t.push(vec![
            m.to_string(),
            format_number(c.reflectance - c.reflectance_specular),
            format_number(secs),
        ]);
    }
    let c = &mc.solution.channels[0];
    t.push(vec![
        format!("Monte Carlo {samples:.0e}"),
        format!(
            "{} +- {}",
            format_number(c.reflectance - c.reflectance_specular),
            format_number(methods::stderr_of(&mc.solution, "reflectance").unwrap_or(f64::NAN))
        ),
        format_number(mc.solution.seconds),
    ]);
    let mut sec = Section::new("The dipole where it applies");
    sec.text(format!(
        "A half-space (albedo {albedo}, isotropic, index {n}) under a pencil beam at normal \
         incidence: the radially resolved diffuse reflectance of the dipole (Jensen et al. 2001; \
         multiple scattering only) against the Monte Carlo tracer (all scattering orders, \
         annuli of width {} mean free paths). The dipole is accurate a few mean free paths \
         from the beam and misses the single-scattering peak near r = 0. The table compares \
         the total diffuse reflectance of every method that treats the case.",
        bins.dr
    ))
    .figure("dipole-rd", "Rd(r): dipole against Monte Carlo")
    .table(t);
    ctx.headline = format!("Rd(r) on {} annuli, MC {samples:.0e}", mc.r.len());
    Ok(sec)
}
