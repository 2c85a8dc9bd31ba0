//! BRDF lobes against roughness (docs/rough.md §9): a rough clear coat over
//! a pigment layer, and a rough lacquer over gold, in the plane of
//! incidence, from km's Monte Carlo (an independent method; the multi-flux
//! method gives these lobes too, docs/rough.md §7); the smooth stack's
//! multi-flux BRDF (its mirror part a delta, given apart) is the reference
//! curve.

use std::time::Instant;

use km::Solver;
use km_core::{Scene, Solution};

use crate::context::Ctx;
use crate::data::Csv;
use crate::methods;
use crate::report::Section;
use km_plot::chart::{LineChart, Mark, Series, format_number};

/// The roughnesses of the figures (GGX `alpha` of the top face).
pub const ALPHAS: [f64; 4] = [0.05, 0.1, 0.2, 0.4];

/// Incidence of the beam, degrees.
pub const THETA_I: f64 = 45.0;

/// The two stacks of the figures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LobeStack {
    /// A clear coat (n 1.5, thickness 0.1, non-absorbing, rough top) over a
    /// pigment layer (`sigma_s` 10, `sigma_a` 0.5, `g` 0.3, thickness 1,
    /// n 1.5) over a black substrate.
    CoatOverPigment,
    /// A lacquer (n 1.5, `sigma_a` 0.1, thickness 1, non-scattering, rough
    /// top) over a smooth gold substrate at 550 nm.
    LacquerOverGold,
}

impl LobeStack {
    /// Both stacks, in report order.
    pub const ALL: [LobeStack; 2] = [LobeStack::CoatOverPigment, LobeStack::LacquerOverGold];

    /// File stem of the figure and its CSV.
    pub fn stem(&self) -> &'static str {
        match self {
            LobeStack::CoatOverPigment => "rough-lobes-coat",
            LobeStack::LacquerOverGold => "rough-lobes-gold",
        }
    }

    /// What it is, for captions.
    pub fn description(&self) -> &'static str {
        match self {
            LobeStack::CoatOverPigment => {
                "clear coat (n 1.5, thickness 0.1, clear, rough top) over a pigment layer \
                 (sigma_s 10, sigma_a 0.5, g 0.3, thickness 1, n 1.5) over black"
            }
            LobeStack::LacquerOverGold => {
                "lacquer (n 1.5, sigma_a 0.1, no scattering, thickness 1, rough top) over smooth \
                 gold (Palik via Luxpop, 550 nm)"
            }
        }
    }

    /// The scene file of the stack with top-face roughness `alpha` (0:
    /// smooth) and these exit directions.
    pub fn toml(&self, alpha: f64, exits: &[[f64; 2]]) -> String {
        let dirs: Vec<String> = exits.iter().map(|d| format!("[{:?}, {:?}]", d[0], d[1])).collect();
        let rough = if alpha > 0.0 { format!("roughness = {alpha:?}\n") } else { String::new() };
        let body = match self {
            LobeStack::CoatOverPigment => format!(
                "[[layer]]\nsigma_a = 0.0\nsigma_s = 0.0\nthickness = 0.1\nn = 1.5\n{rough}\
                 [[layer]]\nsigma_a = 0.5\nsigma_s = 10.0\nthickness = 1.0\ng = 0.3\nn = 1.5\n\
                 [substrate]\nkind = \"black\"\n"
            ),
            LobeStack::LacquerOverGold => format!(
                "[spectrum]\nwavelengths_nm = [550.0]\n\
                 [[layer]]\nsigma_a = 0.1\nsigma_s = 0.0\nthickness = 1.0\nn = 1.5\n{rough}\
                 [substrate]\nkind = \"conductor\"\nmetal = \"Au\"\n"
            ),
        };
        format!(
            "[light]\ntheta_deg = {THETA_I:?}\n{body}[output]\ndirections_deg = [{}]\n",
            dirs.join(", ")
        )
    }

    /// The scene.
    ///
    /// # Errors
    /// Scene-file errors (none for these constants).
    pub fn scene(&self, alpha: f64, exits: &[[f64; 2]]) -> anyhow::Result<Scene> {
        Ok(Scene::from_toml_str(&self.toml(alpha, exits))?)
    }
}

/// Exit directions in the plane of incidence, `-theta_max..theta_max` in
/// steps of `step` degrees (negative: back towards the source, `phi = 0`;
/// positive: the mirror side, `phi = 180`). Returns the directions and
/// their signed plane angles.
pub fn plane_exits(step: f64, theta_max: f64) -> (Vec<[f64; 2]>, Vec<f64>) {
    let n = (theta_max / step).round() as i64;
    let mut dirs = Vec::new();
    let mut psi = Vec::new();
    for k in -n..=n {
        let t = k as f64 * step;
        dirs.push([t.abs(), if k > 0 { 180.0 } else { 0.0 }]);
        psi.push(t);
    }
    (dirs, psi)
}

/// Cone half-angle (degrees) of the Monte Carlo bins for roughness `alpha`:
/// a quarter of the lobe's half width at half maximum in exit angle (about
/// `2 * 0.64 alpha` radians, `74 alpha` degrees, for GGX), between 1 and 5
/// degrees. A cone mean at a peak lies about `0.41 (cone / half width)^2`,
/// 2.6 %, below the point value (the GGX peak's curvature, averaged over a
/// disc); the ratio, hence this bias, is the same for every `alpha` up to
/// the bounds.
pub fn cone_for(alpha: f64) -> f64 {
    (74.0 * alpha / 4.0).clamp(1.0, 5.0)
}

/// One Monte Carlo lobe.
#[derive(Debug, Clone, PartialEq)]
pub struct Lobe {
    /// Roughness of the top face.
    pub alpha: f64,
    /// Cone half-angle of the bins, degrees.
    pub cone_deg: f64,
    /// Photons.
    pub samples: u64,
    /// BRDF per exit direction, 1/sr.
    pub brdf: Vec<f64>,
    /// Its standard errors.
    pub stderr: Vec<f64>,
    /// Wall time, seconds.
    pub seconds: f64,
}

impl Lobe {
    /// Index of the largest value.
    pub fn peak_index(&self) -> usize {
        (0..self.brdf.len()).max_by(|&a, &b| self.brdf[a].total_cmp(&self.brdf[b])).unwrap_or(0)
    }
    /// The largest value.
    pub fn peak(&self) -> f64 {
        self.brdf.get(self.peak_index()).copied().unwrap_or(f64::NAN)
    }
    /// The value at the exit direction nearest to plane angle `at` (degrees)
    /// and its standard error.
    pub fn at(&self, psi: &[f64], at: f64) -> (f64, f64) {
        let i = (0..psi.len().min(self.brdf.len()))
            .min_by(|&a, &b| (psi[a] - at).abs().total_cmp(&(psi[b] - at).abs()))
            .unwrap_or(0);
        (
            self.brdf.get(i).copied().unwrap_or(f64::NAN),
            self.stderr.get(i).copied().unwrap_or(f64::NAN),
        )
    }
    /// Standard error at the peak over the peak.
    pub fn peak_rel_stderr(&self) -> f64 {
        let i = self.peak_index();
        self.stderr.get(i).copied().unwrap_or(f64::NAN) / self.peak()
    }
    /// Full width at half maximum (degrees of plane angle `psi`), the half
    /// maximum taken above `floor` (the smooth body under the lobe; 0 for
    /// none), interpolated linearly between exit directions.
    pub fn fwhm(&self, psi: &[f64], floor: &[f64]) -> f64 {
        let f = |i: usize| self.brdf[i] - floor.get(i).copied().unwrap_or(0.0);
        let p = self.peak_index();
        let half = 0.5 * f(p);
        let mut lo = psi[0];
        for i in (0..p).rev() {
            if f(i) <= half {
                lo = psi[i] + (psi[i + 1] - psi[i]) * (half - f(i)) / (f(i + 1) - f(i));
                break;
            }
        }
        let mut hi = psi[psi.len() - 1];
        for i in p + 1..psi.len() {
            if f(i) <= half {
                hi = psi[i - 1] + (psi[i] - psi[i - 1]) * (f(i - 1) - half) / (f(i - 1) - f(i));
                break;
            }
        }
        hi - lo
    }
}

/// The Monte Carlo lobe of `stack` at roughness `alpha`, in cones of
/// [`cone_for`]`(alpha)`.
///
/// # Errors
/// Solver errors.
pub fn mc_lobe(
    stack: LobeStack,
    alpha: f64,
    exits: &[[f64; 2]],
    samples: u64,
    seed: u64,
) -> anyhow::Result<Lobe> {
    mc_lobe_in_cones(stack, alpha, exits, samples, seed, cone_for(alpha))
}

/// As [`mc_lobe`], in cones of half-angle `cone_deg`.
///
/// # Errors
/// Solver errors (a cone outside (0, 45] degrees among them).
pub fn mc_lobe_in_cones(
    stack: LobeStack,
    alpha: f64,
    exits: &[[f64; 2]],
    samples: u64,
    seed: u64,
    cone_deg: f64,
) -> anyhow::Result<Lobe> {
    let scene = stack.scene(alpha, exits)?;
    let opts = km::McOptions { bin_half_angle_deg: cone_deg, ..methods::mc_options(samples, seed) };
    let t = Instant::now();
    let sol = km::MethodOptions::Mc(opts).solve_unplanned(&scene)?;
    let seconds = t.elapsed().as_secs_f64();
    let brdf = first_brdf(&sol);
    let stderr = methods::stderr_list(&sol, "brdf").unwrap_or_else(|| vec![f64::NAN; brdf.len()]);
    Ok(Lobe { alpha, cone_deg, samples, brdf, stderr, seconds })
}

/// The smooth stack (`alpha = 0`) by multi-flux at `streams`: its BRDF
/// (the smooth part) and its mirror reflectance (the delta, apart).
///
/// # Errors
/// Solver errors.
pub fn smooth_multiflux(
    stack: LobeStack,
    exits: &[[f64; 2]],
    streams: usize,
) -> anyhow::Result<(Vec<f64>, f64)> {
    let scene = stack.scene(0.0, exits)?;
    let sol = methods::solve(methods::Method::Multiflux { streams }, &scene)?;
    let spec = sol.channels.first().map_or(f64::NAN, |c| c.reflectance_specular);
    Ok((first_brdf(&sol), spec))
}

fn first_brdf(sol: &Solution) -> Vec<f64> {
    sol.channels.first().map(|c| c.brdf.clone()).unwrap_or_default()
}

/// Photons per lobe at each run size: the full size brings the standard
/// error at every peak below 2 % of it (docs/rough.md §9); the quick size
/// a few seconds in all.
fn samples(ctx: &Ctx, stack: LobeStack) -> u64 {
    match stack {
        LobeStack::CoatOverPigment => ctx.size.pick(2_000, 30_000, 2_000_000),
        LobeStack::LacquerOverGold => ctx.size.pick(5_000, 100_000, 500_000),
    }
}

/// Streams of the multi-flux reference.
fn streams(ctx: &Ctx) -> usize {
    ctx.size.pick(16, 32, 64)
}

/// The recipe: both figures, their CSV files and the section.
///
/// # Errors
/// Solver, drawing or file errors.
pub fn recipe(ctx: &mut Ctx) -> anyhow::Result<Section> {
    let (exits, psi) = plane_exits(2.5, 80.0);
    let mut sec = Section::new("BRDF lobes against roughness: clear coat and lacquer over gold");
    sec.text(format!(
        "The BRDF in the plane of incidence (beam at {THETA_I:.0} degrees, exit angle -80..80 \
         degrees, + on the mirror side) of two coated stacks whose top face is rough (GGX, alpha \
         {}). The lobes are km's Monte Carlo (an independent method; the multi-flux \
         method gives them too, docs/rough.md §7), in cone bins of a quarter of each \
         lobe's half width (1 to 5 degrees: a cone mean at a peak lies about 2.6 % below the \
         point value), with one standard error as bars. The smooth stack (alpha = 0) is the \
         multi-flux BRDF: its mirror reflection is a delta, not drawn (its weight is in the \
         caption). As alpha grows, the peak at the mirror direction falls and widens (by about 4 \
         times in height and 2 in width per doubling of alpha over a lacquer on gold); towards \
         grazing on the mirror side the rougher faces reflect more. Away from the mirror \
         direction the clear coat's curves meet the smooth body at small alpha and lie below \
         it at large alpha (on the back side, 0 to 60 degrees, about 2 % at alpha 0.1 and 17 % \
         at 0.4 in the full run): the face's single-scattering loss (docs/rough.md \
         table R1), met on the way in and on the way out, grows with alpha. The test \
         km-bench/tests/rough_lobes.rs checks the fall and widening, and that at alpha 0.01 the \
         body is the smooth multi-flux body within three standard errors.",
        ALPHAS.map(|a| a.to_string()).join(", ")
    ));
    let mut headline = Vec::new();
    for stack in LobeStack::ALL {
        let n = samples(ctx, stack);
        let ns = streams(ctx);
        let (smooth, spec) = smooth_multiflux(stack, &exits, ns)?;
        let mut lobes = Vec::new();
        for (k, &alpha) in ALPHAS.iter().enumerate() {
            lobes.push(mc_lobe(stack, alpha, &exits, n, ctx.seed + k as u64)?);
        }
        let worst = lobes.iter().map(Lobe::peak_rel_stderr).fold(0.0, f64::max);
        let secs: f64 = lobes.iter().map(|l| l.seconds).sum();
        write_csv(ctx, stack, &exits, &psi, &smooth, &lobes, ns)?;
        write_chart(ctx, stack, &psi, &smooth, &lobes, ns)?;
        let mirror: Vec<(f64, f64)> = lobes.iter().map(|l| l.at(&psi, THETA_I)).collect();
        let peaks: Vec<String> = mirror.iter().map(|m| format_number(m.0)).collect();
        let peaks_se: Vec<String> = mirror
            .iter()
            .map(|m| format!("{} ± {}", format_number(m.0), format_number(m.1)))
            .collect();
        sec.figure(
            stack.stem(),
            format!(
                "BRDF lobes, {}; beam at {THETA_I:.0} deg. Monte Carlo {n} photons per alpha \
                 (seeds {}..{}), cones {} deg half-angle, bars 1 s.e.; s.e. at each curve's largest \
                 value at most {:.1} % of it; {:.1} s for the four runs. BRDF at the mirror \
                 direction {} (1/sr). alpha = 0: {}",
                stack.description(),
                ctx.seed,
                ctx.seed + ALPHAS.len() as u64 - 1,
                lobes.iter().map(|l| format_number(l.cone_deg)).collect::<Vec<_>>().join(", "),
                100.0 * worst,
                secs,
                peaks_se.join(", "),
                if smooth.iter().any(|&v| v > 0.0) {
                    format!(
                        "multi-flux {ns} streams, the smooth part; its mirror delta (R = {}) is \
                         left out.",
                        format_number(spec)
                    )
                } else {
                    format!(
                        "the smooth stack reflects only a mirror delta (R = {}, multi-flux {ns} \
                         streams): no curve.",
                        format_number(spec)
                    )
                },
            ),
        );
        headline.push(format!(
            "{}: mirror BRDF {} for alpha {}, s.e. <= {:.1} %",
            stack.stem().trim_start_matches("rough-lobes-"),
            peaks.join(" > "),
            ALPHAS.map(|a| a.to_string()).join(", "),
            100.0 * worst
        ));
    }
    ctx.headline = headline.join("; ");
    Ok(sec)
}

fn write_csv(
    ctx: &Ctx,
    stack: LobeStack,
    exits: &[[f64; 2]],
    psi: &[f64],
    smooth: &[f64],
    lobes: &[Lobe],
    streams: usize,
) -> anyhow::Result<()> {
    let mut cols: Vec<String> =
        ["theta_deg", "phi_deg", "psi_deg", "brdf_smooth_multiflux"].map(String::from).to_vec();
    for l in lobes {
        cols.push(format!("brdf_mc_alpha_{}", l.alpha));
        cols.push(format!("stderr_mc_alpha_{}", l.alpha));
    }
    let refs: Vec<&str> = cols.iter().map(String::as_str).collect();
    let mut csv = Csv::new(&refs);
    csv.comment(format!("BRDF lobes in the plane of incidence: {}", stack.description()));
    csv.comment(format!(
        "beam at {THETA_I} deg; psi > 0 on the mirror side; smooth stack by multi-flux {streams} \
         streams (mirror delta left out); Monte Carlo per alpha: {}",
        lobes
            .iter()
            .map(|l| format!(
                "alpha {} {} photons cone {} deg {:.2} s",
                l.alpha, l.samples, l.cone_deg, l.seconds
            ))
            .collect::<Vec<_>>()
            .join("; ")
    ));
    for (i, d) in exits.iter().enumerate() {
        let mut row = vec![d[0], d[1], psi[i], smooth.get(i).copied().unwrap_or(f64::NAN)];
        for l in lobes {
            row.push(l.brdf.get(i).copied().unwrap_or(f64::NAN));
            row.push(l.stderr.get(i).copied().unwrap_or(f64::NAN));
        }
        csv.push_nums(&row);
    }
    ctx.csv(stack.stem(), &mut csv)
}

fn write_chart(
    ctx: &Ctx,
    stack: LobeStack,
    psi: &[f64],
    smooth: &[f64],
    lobes: &[Lobe],
    streams: usize,
) -> anyhow::Result<()> {
    let pts = |v: &[f64]| -> Vec<(f64, f64)> {
        psi.iter().zip(v).filter(|p| *p.1 > 0.0).map(|(&x, &y)| (x, y)).collect()
    };
    let mut series = Vec::new();
    if smooth.iter().any(|&v| v > 0.0) {
        series.push(Series::new(
            format!("alpha 0, multi-flux {streams} (mirror delta left out)"),
            pts(smooth),
            Mark::Line,
            0,
        ));
    }
    for (k, l) in lobes.iter().enumerate() {
        let (p, e): (Vec<_>, Vec<_>) = psi
            .iter()
            .zip(&l.brdf)
            .zip(&l.stderr)
            .filter(|((_, y), _)| **y > 0.0)
            .map(|((&x, &y), &s)| ((x, y), s))
            .unzip();
        series.push(
            Series::new(
                format!("alpha {}, Monte Carlo ({} deg cones)", l.alpha, format_number(l.cone_deg)),
                p,
                Mark::LinePoints,
                k + 1,
            )
            .with_y_err(e),
        );
    }
    let chart = LineChart {
        title: format!(
            "BRDF lobes against roughness: {}",
            match stack {
                LobeStack::CoatOverPigment => "clear coat over pigment",
                LobeStack::LacquerOverGold => "lacquer over gold",
            }
        ),
        x_label: format!("exit angle in the plane (deg; + = mirror side; beam at {THETA_I:.0})"),
        y_label: "BRDF (1/sr)".into(),
        y_log: true,
        x_range: Some((-80.0, 80.0)),
        series,
        ..Default::default()
    };
    ctx.chart(stack.stem(), &chart)
}
