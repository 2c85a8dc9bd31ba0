//! Part 2 of the diffusion limits: `Rd(r)` of measured materials, the
//! dipole against the Monte Carlo radial profile.

use std::time::Instant;

use km_core::Scene;
use km_core::fresnel::reflectance;

use crate::context::Ctx;
use crate::data::Csv;
use crate::methods;
use crate::report::{Section, Table};
use km_plot::chart::{LineChart, Mark, Series};

/// Part 2: `Rd(r)` of measured materials, dipole against Monte Carlo.
pub(super) fn profiles(ctx: &mut Ctx, sec: &mut Section) -> anyhow::Result<String> {
    // (name, grid radius in mm, photon factor): the less a material
    // scatters, the cheaper a photon and the fewer photons reach large r.
    let presets = [("marble", 10.0, 1u64), ("skin1", 10.0, 5), ("ketchup", 20.0, 10)];
    let base = ctx.size.pick(1_000u64, 20_000, 1_000_000);
    // Annuli: `count` of them over `r_max` mm (the preset's scale).
    let count = ctx.size.pick(20usize, 100, 200);
    let mut table = profiles_table();
    let mut worst = Vec::new();
    for (pi, &(name, r_max, factor)) in presets.iter().enumerate() {
        let samples = base * factor;
        let bins = km_montecarlo::RadialBins { dr: r_max / count as f64, count };
        let scene = Scene::from_toml_str(&format!("[[layer]]\npreset = \"{name}\"\n"))?;
        let preset = km_core::presets::lookup(name)
            .ok_or_else(|| anyhow::anyhow!("unknown preset {name}"))?;
        let t = Instant::now();
        let opts = methods::mc_options(samples, ctx.seed.wrapping_add(5000 + pi as u64));
        let mc = km_montecarlo::radial_profile(&scene, &opts, bins)?;
        let t_mc = t.elapsed().as_secs_f64();
        let t = Instant::now();
        // Per unit power entering; the tracer's Rd(r) is per incident photon.
        let entering = 1.0 - reflectance(1.0, 1.0, preset.eta);
        let dip: Vec<Vec<f64>> = km_dipole::profile(&scene, &mc.r, &Default::default())?
            .into_iter()
            .map(|v| v.into_iter().map(|x| x * entering).collect())
            .collect();
        let dip_tot = km_dipole::compare::preset_rd_total(name, Default::default())?;
        let t_dip = t.elapsed().as_secs_f64();
        let csv_times = (samples, opts.seed, t_mc, t_dip);
        let mut csv = profile_csv(name, &preset, &mc, &dip, bins.dr, csv_times);
        let stem = format!("diffusion-limits-rd-{name}");
        ctx.csv(&stem, &mut csv)?;
        let mut series = Vec::new();
        let colours = [3, 2, 0];
        for (c, ch) in ["R", "G", "B"].iter().enumerate() {
            let col = colours[c];
            let xy = |v: &[f64]| -> Vec<(f64, f64)> {
                mc.r.iter().copied().zip(v.iter().copied()).collect()
            };
            series.push(Series::new(format!("dipole {ch}"), xy(&dip[c]), Mark::Line, col));
            series.push(
                Series::new(
                    format!("Monte Carlo {ch} (± 1 s.e.)"),
                    xy(&mc.rd[c]),
                    Mark::Points,
                    col,
                )
                .with_y_err(mc.stderr[c].clone()),
            );
            let band = Band { name, ch, c, entering, dip_total: dip_tot[c], dr: bins.dr };
            let (cells, median) = profile_row(&band, &preset, &mc, &dip);
            // The headline quotes medians over enough annuli to mean one.
            if let Some((m, n)) = median.filter(|m| m.1 >= MIN_ANNULI) {
                worst.push((m, format!("{name} {ch}, {n} annuli")));
            }
            table.push(cells);
        }
        ctx.chart(&stem, &profile_chart(name, &mc, &dip, series))?;
        sec.figure(
            &stem,
            format!(
                "Rd(r) of {name}: dipole (lines) against Monte Carlo ({samples:.1e} photons per \
                 channel, points with ± 1 standard error, a bar reaching below a tenth of its point drawn one decade down to an arrow; the axis spans the Monte Carlo points, the dipole lines are cut at its bottom); MC \
                 {t_mc:.1} s"
            ),
        );
    }
    sec.text(profiles_text(count)).table(table);
    worst.sort_by(|a, b| b.0.total_cmp(&a.0));
    Ok(match worst.first() {
        Some((m, w)) if m.is_finite() => {
            format!(
                "Rd(r) beyond 1/sigma_t': median |dipole/MC - 1| at most {:.0} % ({w})",
                100.0 * m
            )
        }
        _ => format!("Rd(r) computed (no channel has {MIN_ANNULI} annuli with MC s.e. < 10 %)"),
    })
}

/// The `Rd(r)` table, its columns and no rows.
fn profiles_table() -> Table {
    Table::new(&[
        "preset",
        "channel",
        "alpha'",
        "1/sigma_t' (mm)",
        "dipole/MC, first annulus",
        "dipole/MC, power at r < 1/sigma_t'",
        "dipole/MC, power at r >= 1/sigma_t' (to the grid's end)",
        "median |dipole/MC - 1| per annulus, r >= 1/sigma_t' (MC s.e. < 10 %)",
        "total diffuse R: dipole / MC",
    ])
}

/// The text before the `Rd(r)` table (`count` annuli per profile).
fn profiles_text(count: usize) -> String {
    format!(
        "`Rd(r)` of measured materials (Jensen et al. 2001 presets, lengths in mm, `g = 0` with \
         `sigma_s = sigma_s'`, the preset's index) under a pencil beam at normal incidence: the \
         dipole `(1 - F(1)) Rd(r)` (per unit incident power, multiple scattering only) against \
         the Monte Carlo radial profile (all orders, {count} annuli over 10 mm, 20 mm for \
         ketchup). The Monte Carlo profile has a single-scattering peak near `r = 0` that the \
         dipole lacks (first-annulus column). The power columns compare `sum 2 pi r dr Rd(r)` \
         inside and beyond one transport mean free path `1/sigma_t'` (Monte Carlo standard error \
         propagated); the median is over the annuli beyond `1/sigma_t'` whose Monte Carlo \
         standard error is below 10 %. `alpha'` is the reduced albedo of the channel: the \
         lower it is, the worse diffusion."
    )
}

/// Fewest annuli a median must rest on to reach the headline.
const MIN_ANNULI: usize = 10;

/// One channel of one preset in the `Rd(r)` table.
struct Band<'a> {
    name: &'a str,
    ch: &'a str,
    c: usize,
    /// Fraction of the beam that enters (1 - Fresnel at normal incidence).
    entering: f64,
    /// The dipole's total diffuse reflectance of the channel.
    dip_total: f64,
    /// Annulus width, mm.
    dr: f64,
}

/// The table row of one channel: `Rd(r)` ratios near and beyond one
/// transport mean free path, the median per-annulus error (also returned
/// when finite), the totals' ratio.
fn profile_row(
    b: &Band,
    preset: &km_core::presets::Preset,
    mc: &km_montecarlo::RadialProfile,
    dip: &[Vec<f64>],
) -> (Vec<String>, Option<(f64, usize)>) {
    let c = b.c;
    let sp = preset.sigma_s_prime[c];
    let st = sp + preset.sigma_a[c];
    let mfp = 1.0 / st;
    let ratio0 = dip[c][0] / mc.rd[c][0];
    let mut rel: Vec<f64> = (0..mc.r.len())
        .filter(|&i| mc.r[i] >= mfp && mc.rd[c][i] > 0.0)
        .filter(|&i| mc.stderr[c][i] < 0.1 * mc.rd[c][i])
        .map(|i| (dip[c][i] / mc.rd[c][i] - 1.0).abs())
        .collect();
    rel.sort_by(f64::total_cmp);
    let median = rel.get(rel.len() / 2).copied().unwrap_or(f64::NAN);
    // Power escaping inside and beyond one transport mean free path,
    // sum of 2 pi r_i dr Rd(r_i) over the annuli (MC s.e. added in
    // quadrature, annuli taken as independent).
    let ring = |i: usize| 2.0 * std::f64::consts::PI * mc.r[i] * b.dr;
    let band = |near: bool| {
        let idx = (0..mc.r.len()).filter(|&i| (mc.r[i] < mfp) == near);
        let (mut d, mut m, mut v) = (0.0, 0.0, 0.0);
        for i in idx {
            d += ring(i) * dip[c][i];
            m += ring(i) * mc.rd[c][i];
            v += (ring(i) * mc.stderr[c][i]).powi(2);
        }
        if m > 0.0 { format!("{:.3} ± {:.3}", d / m, d / m * v.sqrt() / m) } else { "-".into() }
    };
    let mcc = &mc.solution.channels[c];
    let mc_tot = mcc.reflectance - mcc.reflectance_specular;
    let cells = vec![
        b.name.to_string(),
        b.ch.to_string(),
        format!("{:.4}", sp / st),
        format!("{mfp:.2}"),
        format!("{ratio0:.3}"),
        band(true),
        band(false),
        if median.is_finite() {
            format!("{:.1} % ({} annuli)", 100.0 * median, rel.len())
        } else {
            "- (no annulus with s.e. < 10 %)".into()
        },
        format!("{:.3}", b.entering * b.dip_total / mc_tot),
    ];
    (cells, median.is_finite().then_some((median, rel.len())))
}

/// `diffusion-limits-rd-NAME.csv`: per radius, per channel, the Monte Carlo
/// `Rd(r)`, its standard error and the dipole's; `run` is (photons, seed,
/// Monte Carlo seconds, dipole seconds).
fn profile_csv(
    name: &str,
    preset: &km_core::presets::Preset,
    mc: &km_montecarlo::RadialProfile,
    dip: &[Vec<f64>],
    dr: f64,
    run: (u64, u64, f64, f64),
) -> Csv {
    let (samples, seed, t_mc, t_dip) = run;
    let mut csv = Csv::new(&[
        "r_mm",
        "rd_mc_r",
        "rd_mc_r_stderr",
        "rd_dipole_r",
        "rd_mc_g",
        "rd_mc_g_stderr",
        "rd_dipole_g",
        "rd_mc_b",
        "rd_mc_b_stderr",
        "rd_dipole_b",
    ]);
    csv.comment(format!(
        "Rd(r) (1/mm^2, per unit incident power) of the preset \"{name}\" (Jensen et al. 2001; \
         sigma_s' in 1/mm, g = 0, eta = {}), half-space, pencil beam at normal incidence. \
         Monte Carlo {samples} photons per channel, seed {}, annuli dr = {} mm (r = annulus \
         centre); dipole (1 - F(1)) Rd(r), multiple scattering only. MC {t_mc:.2} s, dipole \
         {t_dip:.1e} s.",
        preset.eta, seed, dr
    ));
    for (i, &r) in mc.r.iter().enumerate() {
        let mut row = vec![r];
        for ((rd, se), d) in mc.rd.iter().zip(&mc.stderr).zip(dip) {
            row.extend([rd[i], se[i], d[i]]);
        }
        csv.push_nums(&row);
    }
    csv
}

/// The chart of one preset's `Rd(r)`: `series` on a log axis spanning the
/// Monte Carlo points.
fn profile_chart(
    name: &str,
    mc: &km_montecarlo::RadialProfile,
    dip: &[Vec<f64>],
    series: Vec<Series>,
) -> LineChart {
    // The y axis spans the Monte Carlo points and their error bars (an
    // open bar ends one decade below its point, so down to a twelfth of
    // the smallest point): the dipole goes on decaying far below what the tracer
    // resolves, and its lines are cut at the axis.
    let mc_pos = mc.rd.iter().flatten().copied().filter(|v| v.is_finite() && *v > 0.0);
    let (lo, hi) = mc_pos.fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    let top = dip.iter().flatten().copied().filter(|v| v.is_finite()).fold(hi, f64::max);
    LineChart {
        title: format!("Rd(r) of {name}: dipole vs Monte Carlo (R, G, B)"),
        x_label: "r (mm)".into(),
        y_label: "Rd(r) (1/mm^2)".into(),
        y_log: true,
        y_range: (lo.is_finite() && top > lo).then_some((lo / 12.0, 2.0 * top)),
        series,
        ..Default::default()
    }
}
