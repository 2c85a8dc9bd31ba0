//! A white paint from Mie theory: a film of rutile (TiO2) spheres in a
//! resin of index 1.5, over a black and over a white ground, solved by
//! every method that treats it, and its Kubelka–Munk `K` and `S` from the
//! two-flux inverse of the multi-flux answer (docs/mie.md §5).
//!
//! The particles enter through the scene file's `particles` key (Mie theory
//! of independent spheres, docs/mie.md eq. M14–M18); rutile's index is
//! DeVore's (1951) dispersion formula for the ordinary and extraordinary
//! rays, averaged as `(2 n_o + n_e) / 3` (eq. M19).

use km::{
    DipoleOptions, DirectionSetOptions, KmMapping, KmModel, KmOptions, MultifluxOptions, Solver,
};
use km_core::{Scene, Solution};
use km_inverse::kubelka::{Film, Saunderson, Specular, from_black_white, reflectance_over_ground};

use crate::context::{Ctx, Size};
use crate::data::Csv;
use crate::report::{Section, Table};
use km_plot::chart::{LineChart, Mark, Series, format_number};

/// Vacuum wavelengths of the scenes, nm.
pub const WAVELENGTHS_NM: [f64; 3] = [450.0, 550.0, 650.0];
/// The wavelength of the charts and of the Monte Carlo runs, nm.
pub const CHART_NM: f64 = 550.0;
/// Index of the resin (the particles' host and the film's surface).
pub const HOST_N: f64 = 1.5;
/// Absorption coefficient of the resin, 1/µm (a lightly tinted binder:
/// rutile is taken as non-absorbing, so without it `K` would be zero).
pub const HOST_SIGMA_A: f64 = 0.002;
/// Imaginary part of rutile's index used (see [`rutile_index`]).
pub const RUTILE_K: f64 = 0.0;
/// Film thickness, µm.
pub const THICKNESS_UM: f64 = 20.0;
/// Reflectance of the white ground (a Lambertian reflector under the film,
/// the white half of a drawdown chart); the black ground reflects nothing.
pub const WHITE_GROUND: f64 = 0.8;
/// Volume fractions of rutile.
pub const VOLUME_FRACTIONS: [f64; 3] = [0.1, 0.2, 0.3];

/// Rutile's ordinary and extraordinary indices and their average
/// `(n_o, n_e, (2 n_o + n_e) / 3)` at `lambda_nm`, by DeVore's dispersion
/// formulas (J. R. DeVore, "Refractive indices of rutile and sphalerite",
/// J. Opt. Soc. Am. 41, 416–419 (1951); fitted to his prism measurements
/// over 0.43–1.53 µm), `lambda` in µm:
///
/// ```text
/// n_o^2 = 5.913 + 0.2441 / (lambda^2 - 0.0803)
/// n_e^2 = 7.197 + 0.3322 / (lambda^2 - 0.0843)                         (M19)
/// ```
///
/// The average weights the two ordinary axes of a randomly oriented
/// crystal twice. The imaginary part is [`RUTILE_K`] = 0: rutile is
/// transparent over DeVore's range, and rutile's absorption edge lies near
/// 3.0 eV, about 410 nm (Pascual, Camassel & Mathieu, Phys. Rev. Lett. 39, 1490
/// (1977)), below the wavelengths used here.
pub fn rutile_index(lambda_nm: f64) -> (f64, f64, f64) {
    let l2 = (lambda_nm * 1e-3).powi(2);
    let n_o = (5.913 + 0.2441 / (l2 - 0.0803)).sqrt();
    let n_e = (7.197 + 0.3322 / (l2 - 0.0843)).sqrt();
    (n_o, n_e, (2.0 * n_o + n_e) / 3.0)
}

/// What lies under the film.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ground {
    /// A perfect absorber.
    Black,
    /// A Lambertian reflector of albedo [`WHITE_GROUND`].
    White,
    /// No ground: the paint fills the half-space below the surface.
    Opaque,
}

impl Ground {
    /// The ground's reflectance as the two-flux inverse takes it.
    pub fn reflectance(self) -> f64 {
        match self {
            Ground::Black | Ground::Opaque => 0.0,
            Ground::White => WHITE_GROUND,
        }
    }
}

/// The scene file of the film: rutile spheres of `radius_um` at volume
/// fraction `fv` in the resin, [`THICKNESS_UM`] thick (a half-space for
/// [`Ground::Opaque`]), light at normal incidence from air, at `wavelengths`.
pub fn scene_text(radius_um: f64, fv: f64, ground: Ground, wavelengths: &[f64]) -> String {
    let list = |v: &[f64]| v.iter().map(|x| format!("{x:?}")).collect::<Vec<_>>().join(", ");
    let n: Vec<f64> = wavelengths.iter().map(|&l| rutile_index(l).2).collect();
    let (thickness, substrate) = match ground {
        Ground::Black => (format!("{THICKNESS_UM:?}"), "kind = \"black\"".to_string()),
        Ground::White => (
            format!("{THICKNESS_UM:?}"),
            format!("kind = \"lambertian\"\nalbedo = {WHITE_GROUND:?}"),
        ),
        Ground::Opaque => ("\"inf\"".to_string(), "kind = \"black\"".to_string()),
    };
    format!(
        "[light]\ntheta_deg = 0.0\n[spectrum]\nwavelengths_nm = [{}]\n[[layer]]\n\
         thickness = {thickness}\nsigma_a = {HOST_SIGMA_A:?}\nn = {HOST_N:?}\n\
         particles = {{ radius_um = {radius_um:?}, n = [{}], k = {RUTILE_K:?}, \
         volume_fraction = {fv:?} }}\n[substrate]\n{substrate}\n",
        list(wavelengths),
        list(&n),
    )
}

/// The scene of [`scene_text`].
///
/// # Errors
/// The scene reader's (never for the recipe's constants).
pub fn scene(
    radius_um: f64,
    fv: f64,
    ground: Ground,
    wavelengths: &[f64],
) -> anyhow::Result<Scene> {
    Ok(Scene::from_toml_str(&scene_text(radius_um, fv, ground, wavelengths))?)
}

/// Saunderson's correction of the film's surface as the scene solvers
/// build it: `k1` the Fresnel reflectance at normal incidence from air,
/// `k2` the hemispherical internal one, specular reflection included in
/// the reading (the solvers' `reflectance` is the total).
///
/// # Errors
/// Never for [`HOST_N`].
pub fn surface() -> anyhow::Result<Saunderson> {
    Ok(Saunderson::fresnel(HOST_N, Specular::Included)?)
}

/// `K` and `S` (1/µm) of the film from its total reflectances over the black
/// and the white ground: Saunderson's correction to internal reflectances
/// (docs/inverse-km.md eq. I9), then Kubelka's two-ground inverse (eq. I5–I7).
///
/// # Errors
/// Readings no two-flux film produces (the inverse names them).
pub fn invert(r_black: f64, r_white: f64) -> anyhow::Result<Film> {
    let c = surface()?;
    let (ib, iw) = (c.internal_from_measured(r_black)?, c.internal_from_measured(r_white)?);
    Ok(from_black_white(
        ib,
        Ground::Black.reflectance(),
        iw,
        Ground::White.reflectance(),
        THICKNESS_UM,
    )?)
}

/// The two-flux forward model of `film` over `ground`, as a total
/// reflectance (Kubelka 1948 eq. 11, then Saunderson's eq. I8); an opaque
/// film gives `R_inf`.
///
/// # Errors
/// Those of the forward model (never for a film from [`invert`]).
pub fn forward(film: &Film, ground: Ground) -> anyhow::Result<f64> {
    let x = if ground == Ground::Opaque { f64::INFINITY } else { THICKNESS_UM };
    let internal = reflectance_over_ground(film.k, film.s, x, ground.reflectance())?;
    Ok(surface()?.measured_from_internal(internal)?)
}

/// The multi-flux solve at `streams` Gauss nodes per hemisphere.
///
/// # Errors
/// The solver's.
pub fn multiflux(scene: &Scene, streams: usize) -> anyhow::Result<Solution> {
    Ok(MultifluxOptions { streams: Some(streams), ..Default::default() }.solve_unplanned(scene)?)
}

/// The Kubelka–Munk solvers of the report: four-flux (the library's
/// default) and two-flux, both with Gate's mapping
/// `K = 2 sigma_a`, `S = 3/4 sigma_s (1 - g)` (docs/two-flux.md eq. K14).
pub fn km_options(model: KmModel) -> KmOptions {
    KmOptions { mapping: KmMapping::Gate1974, model }
}

/// One point of the sweep at one wavelength.
#[derive(Debug, Clone)]
pub struct Point {
    /// Sphere radius, µm.
    pub radius_um: f64,
    /// Volume fraction.
    pub fv: f64,
    /// Wavelength, nm.
    pub wavelength_nm: f64,
    /// Scattering coefficient of the layer (Mie), 1/µm.
    pub sigma_s: f64,
    /// Absorption coefficient of the layer, 1/µm.
    pub sigma_a: f64,
    /// Asymmetry parameter of the phase function.
    pub g: f64,
    /// Multi-flux total reflectance over black and over white.
    pub r_mf: [f64; 2],
    /// The same at half the streams (the convergence check).
    pub r_mf_half: [f64; 2],
    /// Four-flux and two-flux KM (Gate mapping), over black and white.
    pub r_four: [f64; 2],
    /// Two-flux KM (Gate mapping), over black and white.
    pub r_two: [f64; 2],
    /// Direction set, over black and white (NaN when not run).
    pub r_ds: [f64; 2],
    /// `K`, `S` from the two-flux inverse of `r_mf`.
    pub film: Film,
    /// Relative change of `S` when inverted from `r_mf_half` instead: how
    /// much the multi-flux truncation moves it (NaN if that inverse fails).
    pub s_change: f64,
}

/// The sizes of the sweep.
#[derive(Debug, Clone)]
pub struct Plan {
    /// Radii, µm.
    pub radii: Vec<f64>,
    /// Streams of the multi-flux solver (checked against half as many).
    pub streams: usize,
    /// Directions of the direction-set solver.
    pub directions: usize,
    /// Radii of the Monte Carlo runs.
    pub mc_radii: Vec<f64>,
    /// Photons per Monte Carlo run.
    pub photons: u64,
}

impl Plan {
    /// The sweep of a run size.
    pub fn of(size: Size) -> Plan {
        // Radii in hundredths of a micrometre (exact decimals in the files).
        let step: f64 = size.pick(10.0, 5.0, 1.25);
        let count = ((30.0 - 5.0) / step).round() as usize;
        Plan {
            radii: (0..=count).map(|i| (5.0 + step * i as f64) / 100.0).collect(),
            streams: size.pick(8, 16, 32),
            directions: size.pick(40, 100, 200),
            mc_radii: size.pick(
                vec![0.15],
                vec![0.1, 0.2, 0.3],
                vec![0.05, 0.1, 0.15, 0.2, 0.25, 0.3],
            ),
            photons: size.pick(500, 10_000, 200_000),
        }
    }
}

/// Reflectances of a two-channel-per-ground solve: `[black, white]` per wavelength.
fn totals(black: &Solution, white: &Solution) -> Vec<[f64; 2]> {
    black
        .channels
        .iter()
        .zip(&white.channels)
        .map(|(b, w)| [b.reflectance, w.reflectance])
        .collect()
}

/// Every deterministic method at one radius and volume fraction, at every
/// wavelength of [`WAVELENGTHS_NM`].
///
/// # Errors
/// Solver or inverse errors.
pub fn sweep_point(radius_um: f64, fv: f64, plan: &Plan) -> anyhow::Result<Vec<Point>> {
    let wl = &WAVELENGTHS_NM;
    let (sb, sw) =
        (scene(radius_um, fv, Ground::Black, wl)?, scene(radius_um, fv, Ground::White, wl)?);
    let mf = totals(&multiflux(&sb, plan.streams)?, &multiflux(&sw, plan.streams)?);
    let half = totals(&multiflux(&sb, plan.streams / 2)?, &multiflux(&sw, plan.streams / 2)?);
    let four = km_options(KmModel::FourFlux);
    let two = km_options(KmModel::TwoFlux);
    let r_four = totals(&four.solve_unplanned(&sb)?, &four.solve_unplanned(&sw)?);
    let r_two = totals(&two.solve_unplanned(&sb)?, &two.solve_unplanned(&sw)?);
    let ds = DirectionSetOptions { directions: plan.directions };
    let r_ds = totals(&ds.solve_unplanned(&sb)?, &ds.solve_unplanned(&sw)?);
    let mut out = Vec::with_capacity(wl.len());
    for (i, &wavelength_nm) in wl.iter().enumerate() {
        let layer = &sb.channels()[i].layers()[0];
        let film = invert(mf[i][0], mf[i][1]).map_err(|e| {
            anyhow::anyhow!("r = {radius_um} um, f_v = {fv}, {wavelength_nm} nm: {e:#}")
        })?;
        out.push(Point {
            radius_um,
            fv,
            wavelength_nm,
            sigma_s: layer.sigma_s(),
            sigma_a: layer.sigma_a(),
            g: layer.g(),
            r_mf: mf[i],
            r_mf_half: half[i],
            r_four: r_four[i],
            r_two: r_two[i],
            r_ds: r_ds[i],
            s_change: invert(half[i][0], half[i][1])
                .map(|h| (h.s - film.s).abs() / film.s)
                .unwrap_or(f64::NAN),
            film,
        });
    }
    Ok(out)
}

/// A Monte Carlo run at [`CHART_NM`]: total reflectance and its standard error.
///
/// # Errors
/// The tracer's.
pub fn monte_carlo(
    radius_um: f64,
    fv: f64,
    ground: Ground,
    photons: u64,
    seed: u64,
) -> anyhow::Result<(f64, f64, f64)> {
    let s = scene(radius_um, fv, ground, &[CHART_NM])?;
    let sol = crate::methods::mc_options(photons, seed).solve_unplanned(&s)?;
    let se = crate::methods::stderr_of(&sol, "reflectance").unwrap_or(f64::NAN);
    Ok((sol.channels[0].reflectance, se, sol.seconds))
}

/// The paint film: R against particle size by every method, and `K`, `S`.
///
/// # Errors
/// Solver, inverse, drawing or file errors.
pub fn recipe(ctx: &mut Ctx) -> anyhow::Result<Section> {
    let plan = Plan::of(ctx.size);
    let t0 = std::time::Instant::now();
    let mut points = Vec::new();
    for &fv in &VOLUME_FRACTIONS {
        for &r in &plan.radii {
            points.extend(sweep_point(r, fv, &plan)?);
        }
    }
    let deterministic_s = t0.elapsed().as_secs_f64();
    // Monte Carlo at the chart's wavelength, f_v = 0.2, both grounds.
    let mc_fv = 0.2;
    let mc = mc_runs(&plan, mc_fv, ctx.seed)?;
    let opaque = opaque_runs(&plan, mc_fv, &points)?;
    write_csvs(ctx, &plan, &points, &mc, mc_fv)?;
    let at_chart: Vec<&Point> = points.iter().filter(|p| p.wavelength_nm == CHART_NM).collect();
    draw_charts(ctx, &plan, &at_chart, &mc, mc_fv)?;
    let (ks, methods_t, opaque_t, worst_z) = tables(&at_chart, &mc, &opaque, mc_fv);
    let conv = points
        .iter()
        .flat_map(|p| (0..2).map(move |i| (p.r_mf[i] - p.r_mf_half[i]).abs()))
        .fold(0.0, f64::max);
    let round_trip = points
        .iter()
        .flat_map(|p| {
            [(Ground::Black, p.r_mf[0]), (Ground::White, p.r_mf[1])]
                .map(|(g, r)| forward(&p.film, g).map(|f| (f - r).abs()).unwrap_or(f64::NAN))
        })
        .fold(0.0, f64::max);
    let best = |fv: f64| {
        at_chart
            .iter()
            .filter(|p| p.fv == fv)
            .max_by(|a, b| a.film.s.total_cmp(&b.film.s))
            .map(|p| (p.radius_um, p.film.s))
            .unwrap_or((f64::NAN, f64::NAN))
    };
    let found =
        Found { mc_fv, conv, round_trip, best: [best(0.1).0, best(0.2).0, best(0.3).0], worst_z };
    let sec = section(&plan, &found, [ks, methods_t, opaque_t]);
    ctx.headline = format!(
        "{} radii x {} f_v x {} wavelengths in {:.1} s; S peaks at r = {} um (f_v 0.2); \
         round trip {:.0e}; MC within {worst_z:.1} s.e.",
        plan.radii.len(),
        VOLUME_FRACTIONS.len(),
        WAVELENGTHS_NM.len(),
        deterministic_s,
        format_number(best(0.2).0),
        round_trip
    );
    Ok(sec)
}

/// One Monte Carlo run of the recipe: radius (um), ground, R, its standard
/// error, seconds.
type McRun = (f64, Ground, f64, f64, f64);

/// The opaque paint at one radius (um): multi-flux R, the dipole's R, and
/// `R_inf` of the inverted `K/S`.
type Opaque = (f64, f64, f64, f64);

/// What the report's text quotes besides the tables.
#[derive(Clone, Copy)]
struct Found {
    /// The volume fraction of the Monte Carlo runs.
    mc_fv: f64,
    /// The largest change of any R from half the streams.
    conv: f64,
    /// The largest |two-flux forward of the inverted K, S - multi-flux R|.
    round_trip: f64,
    /// The radius of the largest S at f_v = 0.1, 0.2, 0.3 (um).
    best: [f64; 3],
    /// The largest |MC - MF| in standard errors.
    worst_z: f64,
}

/// Monte Carlo at the chart's wavelength, volume fraction `mc_fv`, over
/// both grounds, at the plan's radii.
fn mc_runs(plan: &Plan, mc_fv: f64, base_seed: u64) -> anyhow::Result<Vec<McRun>> {
    let mut mc = Vec::new();
    for (k, &r) in plan.mc_radii.iter().enumerate() {
        for (j, ground) in [Ground::Black, Ground::White].into_iter().enumerate() {
            let seed = base_seed.wrapping_add(100 * k as u64 + j as u64);
            let (v, se, secs) = monte_carlo(r, mc_fv, ground, plan.photons, seed)?;
            mc.push((r, ground, v, se, secs));
        }
    }
    Ok(mc)
}

/// The opaque film (half-space): multi-flux, the dipole and `R_inf` of the
/// inverted `K/S`, at the Monte Carlo radii.
fn opaque_runs(plan: &Plan, mc_fv: f64, points: &[Point]) -> anyhow::Result<Vec<Opaque>> {
    let mut opaque = Vec::new();
    for &r in &plan.mc_radii {
        let s = scene(r, mc_fv, Ground::Opaque, &[CHART_NM])?;
        let mf = multiflux(&s, plan.streams)?.channels[0].reflectance;
        let dip = DipoleOptions::default().solve_unplanned(&s)?.channels[0].reflectance;
        let film = points.iter().find(|p| {
            p.wavelength_nm == CHART_NM && p.fv == mc_fv && (p.radius_um - r).abs() < 1e-12
        });
        let r_inf = match film {
            Some(p) => forward(&p.film, Ground::Opaque)?,
            None => f64::NAN,
        };
        opaque.push((r, mf, dip, r_inf));
    }
    Ok(opaque)
}

/// The CSV of every point (`paint-points`) and of the Monte Carlo runs (`paint-mc`).
fn write_csvs(
    ctx: &mut Ctx,
    plan: &Plan,
    points: &[Point],
    mc: &[McRun],
    mc_fv: f64,
) -> anyhow::Result<()> {
    // CSV of every point.
    let mut csv = Csv::new(&[
        "radius_um",
        "volume_fraction",
        "wavelength_nm",
        "sigma_s_per_um",
        "sigma_a_per_um",
        "g",
        "r_black_multiflux",
        "r_white_multiflux",
        "r_black_multiflux_half_streams",
        "r_white_multiflux_half_streams",
        "r_black_four_flux",
        "r_white_four_flux",
        "r_black_two_flux",
        "r_white_two_flux",
        "r_black_direction_set",
        "r_white_direction_set",
        "k_per_um",
        "s_per_um",
    ]);
    csv.comment(format!(
        "rutile spheres (DeVore 1951, (2 n_o + n_e)/3, k = {RUTILE_K}) in resin n = {HOST_N}, \
         sigma_a = {HOST_SIGMA_A} /um, film {THICKNESS_UM} um over black and over a Lambertian \
         white of {WHITE_GROUND}, normal incidence from air; R total (specular included); \
         multi-flux {} streams (check: {}), direction set {} directions; K, S from the \
         two-flux inverse (Saunderson n = {HOST_N}, Kubelka 1948) of the multi-flux R",
        plan.streams,
        plan.streams / 2,
        plan.directions
    ));
    for p in points {
        csv.push_nums(&[
            p.radius_um,
            p.fv,
            p.wavelength_nm,
            p.sigma_s,
            p.sigma_a,
            p.g,
            p.r_mf[0],
            p.r_mf[1],
            p.r_mf_half[0],
            p.r_mf_half[1],
            p.r_four[0],
            p.r_four[1],
            p.r_two[0],
            p.r_two[1],
            p.r_ds[0],
            p.r_ds[1],
            p.film.k,
            p.film.s,
        ]);
    }
    ctx.csv("paint-points", &mut csv)?;
    let mut mc_csv = Csv::new(&["radius_um", "ground", "r_mc", "r_mc_stderr", "seconds"]);
    mc_csv.comment(format!(
        "Monte Carlo at {CHART_NM} nm, f_v = {mc_fv}, {} photons per run, base seed {}",
        plan.photons, ctx.seed
    ));
    for (r, g, v, se, secs) in mc {
        mc_csv.push(vec![
            format!("{r:e}"),
            format!("{g:?}").to_lowercase(),
            format!("{v:e}"),
            format!("{se:e}"),
            format!("{secs:e}"),
        ]);
    }
    ctx.csv("paint-mc", &mut mc_csv)?;
    Ok(())
}

/// The charts of R against radius over each ground, and of K and S.
fn draw_charts(
    ctx: &mut Ctx,
    plan: &Plan,
    at_chart: &[&Point],
    mc: &[McRun],
    mc_fv: f64,
) -> anyhow::Result<()> {
    // Charts of R against radius, one per ground.
    for (gi, ground, name) in [(0, Ground::Black, "black"), (1, Ground::White, "white")] {
        let mut series = Vec::new();
        for (c, &fv) in VOLUME_FRACTIONS.iter().enumerate() {
            let pts =
                at_chart.iter().filter(|p| p.fv == fv).map(|p| (p.radius_um, p.r_mf[gi])).collect();
            series.push(Series::new(
                format!("multi-flux {} streams, f_v = {fv}", plan.streams),
                pts,
                Mark::Line,
                c,
            ));
        }
        let marks = |f: &dyn Fn(&Point) -> f64| -> Vec<(f64, f64)> {
            at_chart.iter().map(|p| (p.radius_um, f(p))).collect()
        };
        series.push(Series::new("four-flux KM (Gate)", marks(&|p| p.r_four[gi]), Mark::Points, 3));
        series.push(Series::new("two-flux KM (Gate)", marks(&|p| p.r_two[gi]), Mark::Points, 4));
        series.push(Series::new(
            format!("direction set {}", plan.directions),
            marks(&|p| p.r_ds[gi]),
            Mark::Points,
            5,
        ));
        let mine: Vec<_> = mc.iter().filter(|m| m.1 == ground).collect();
        series.push(
            Series::new(
                format!("Monte Carlo {:.0e}, f_v = {mc_fv} (± 1 s.e.)", plan.photons as f64),
                mine.iter().map(|m| (m.0, m.2)).collect(),
                Mark::Points,
                7,
            )
            .with_y_err(mine.iter().map(|m| m.3).collect()),
        );
        let chart = LineChart {
            title: format!(
                "Rutile in resin, {THICKNESS_UM} um over {name}{}: R at {CHART_NM} nm",
                if ground == Ground::White { format!(" ({WHITE_GROUND})") } else { String::new() }
            ),
            x_label: "sphere radius (um)".into(),
            y_label: "total reflectance R".into(),
            series,
            ..Default::default()
        };
        ctx.chart(&format!("paint-r-{name}"), &chart)?;
    }
    // K and S against radius.
    let mut series = Vec::new();
    for (c, &fv) in VOLUME_FRACTIONS.iter().enumerate() {
        let of = |f: &dyn Fn(&Point) -> f64| -> Vec<(f64, f64)> {
            at_chart.iter().filter(|p| p.fv == fv).map(|p| (p.radius_um, f(p))).collect()
        };
        series.push(Series::new(format!("S, f_v = {fv}"), of(&|p| p.film.s), Mark::LinePoints, c));
        series.push(Series::new(format!("K, f_v = {fv}"), of(&|p| p.film.k), Mark::Dashed, c));
    }
    ctx.chart(
        "paint-ks",
        &LineChart {
            title: format!("K and S from the two-flux inverse of multi-flux R ({CHART_NM} nm)"),
            x_label: "sphere radius (um)".into(),
            y_label: "K, S (1/um)".into(),
            y_log: true,
            series,
            ..Default::default()
        },
    )?;
    Ok(())
}

/// The report's tables (K and S; every method where Monte Carlo ran; the
/// opaque paint) and the largest |MC - MF| in standard errors.
fn tables(
    at_chart: &[&Point],
    mc: &[McRun],
    opaque: &[Opaque],
    mc_fv: f64,
) -> (Table, Table, Table, f64) {
    // Tables.
    let mut ks = Table::new(&[
        "radius (um)",
        "f_v",
        "R black",
        "R white",
        "K (1/um)",
        "S (1/um)",
        "K / (2 sigma_a)",
        "S / (3/4 sigma_s (1 - g))",
        "g",
        "S change at half the streams",
    ]);
    for p in at_chart {
        ks.push(vec![
            format_number(p.radius_um),
            format_number(p.fv),
            format!("{:.4}", p.r_mf[0]),
            format!("{:.4}", p.r_mf[1]),
            format!("{:.3e}", p.film.k),
            format!("{:.4}", p.film.s),
            format!("{:.3}", p.film.k / (2.0 * p.sigma_a)),
            format!("{:.3}", p.film.s / (0.75 * p.sigma_s * (1.0 - p.g))),
            format!("{:.3}", p.g),
            format!("{:.1e}", p.s_change),
        ]);
    }
    let mut methods_t = Table::new(&[
        "radius (um)",
        "ground",
        "multi-flux",
        "Monte Carlo ± s.e.",
        "(MC - MF) / s.e.",
        "four-flux KM",
        "two-flux KM",
        "direction set",
    ]);
    let mut worst_z: f64 = 0.0;
    for (r, ground, v, se, _) in mc {
        let gi = usize::from(*ground == Ground::White);
        let Some(p) = at_chart.iter().find(|p| p.fv == mc_fv && (p.radius_um - r).abs() < 1e-12)
        else {
            continue;
        };
        let z = (v - p.r_mf[gi]) / se;
        worst_z = worst_z.max(z.abs());
        methods_t.push(vec![
            format_number(*r),
            format!("{ground:?}").to_lowercase(),
            format!("{:.4}", p.r_mf[gi]),
            format!("{v:.4} ± {se:.1e}"),
            format!("{z:.2}"),
            format!("{:.4}", p.r_four[gi]),
            format!("{:.4}", p.r_two[gi]),
            format!("{:.4}", p.r_ds[gi]),
        ]);
    }
    let mut opaque_t =
        Table::new(&["radius (um)", "multi-flux", "dipole", "R_inf of the inverted K/S"]);
    for (r, mf, dip, kinf) in opaque {
        opaque_t.push(vec![
            format_number(*r),
            format!("{mf:.4}"),
            format!("{dip:.4}"),
            format!("{kinf:.4}"),
        ]);
    }
    (ks, methods_t, opaque_t, worst_z)
}

/// The report's section: what was computed and how, the figures and the tables.
fn section(plan: &Plan, found: &Found, [ks, methods_t, opaque_t]: [Table; 3]) -> Section {
    let Found { mc_fv, conv, round_trip, best, worst_z } = *found;
    let (n_o, n_e, n_avg) = rutile_index(CHART_NM);
    let mut sec = Section::new("A white paint from Mie theory: rutile in resin");
    sec.text(format!(
        "A film {THICKNESS_UM} µm thick of rutile (TiO2) spheres in a resin of index {HOST_N}, \
         at volume fractions {} and radii {}–{} µm, lit at normal incidence from air, over a \
         black ground and over a white one (Lambertian, albedo {WHITE_GROUND}): the pair of \
         a drawdown chart, from which the two-flux inverse takes K and S. The spheres' \
         scattering, absorption and phase function come from Mie theory through the scene \
         file's `particles` key (docs/mie.md). Rutile's index is DeVore's (1951) dispersion \
         formula, ordinary and extraordinary rays averaged as (2 n_o + n_e)/3 (at {CHART_NM} \
         nm: n_o = {n_o:.4}, n_e = {n_e:.4}, mean {n_avg:.4}); its imaginary part is taken as \
         {RUTILE_K} (rutile's absorption edge lies near 410 nm, below the wavelengths \
         {WAVELENGTHS_NM:?} nm). The resin absorbs sigma_a = {HOST_SIGMA_A} per µm (a lightly \
         tinted binder; without it K would be zero). Mie theory of independent spheres is an \
         approximation at these volume fractions: at 20–30 % the spheres are a few radii \
         apart and their dependent scattering (crowding, which lowers the scattering per \
         sphere) is not modelled.",
        VOLUME_FRACTIONS.map(|f| format!("{}", f)).join(", "),
        format_number(plan.radii[0]),
        format_number(plan.radii[plan.radii.len() - 1]),
    ))
    .text(format!(
        "Methods: the multi-flux solver at {} streams per hemisphere (the largest change of \
         any R from {} streams: {:.1e}), the direction-set solver at {} directions, the \
         four-flux and two-flux Kubelka–Munk solvers with Gate's mapping K = 2 sigma_a, S = \
         3/4 sigma_s (1 - g), and Monte Carlo ({:.0e} photons per run) at {CHART_NM} nm and \
         f_v = {mc_fv} at radii {:?} µm. The dipole needs a semi-infinite medium: it is \
         compared on the same paint filling a half-space (last table), not on the film.",
        plan.streams,
        plan.streams / 2,
        conv,
        plan.directions,
        plan.photons as f64,
        plan.mc_radii,
    ))
    .figure_data(
        "paint-r-black",
        "Total reflectance against sphere radius, film over black (Monte Carlo: paint-mc.csv)",
        "paint-points",
    )
    .figure_data(
        "paint-r-white",
        "Total reflectance against sphere radius, film over white (Monte Carlo: paint-mc.csv)",
        "paint-points",
    )
    .text(format!(
        "K and S (per µm) are the two-flux inverse of the multi-flux reflectances: \
         Saunderson's correction for the film's surface (k1 = 0.04, k2 the hemispherical \
         Fresnel reflectance from inside, n = {HOST_N}; specular included) to internal \
         reflectances, then Kubelka's two-ground solution (docs/inverse-km.md eq. I5–I9). The \
         two-flux forward model with these K and S gives back the multi-flux R to {:.1e}. \
         Near opacity the two readings differ little and S is sensitive to them: the \
         last column gives the relative change of S when inverted from the multi-flux answer \
         at half the streams. S is largest at r = {} µm (f_v = 0.1), {} µm (0.2), {} µm (0.3); the ratios to Gate's \
         mapping show how far the diffusion-theory constants are from the film's effective \
         ones.",
        round_trip,
        format_number(best[0]),
        format_number(best[1]),
        format_number(best[2]),
    ))
    .figure_data("paint-ks", "K and S against sphere radius", "paint-points")
    .table(ks)
    .text(format!(
        "Every method at f_v = {mc_fv}, {CHART_NM} nm, where Monte Carlo ran (the largest \
         |MC - MF| is {worst_z:.2} standard errors):"
    ))
    .table(methods_t)
    .text(format!(
        "The same paint as an opaque half-space (f_v = {mc_fv}, {CHART_NM} nm): multi-flux, \
         the dipole, and the R_inf that the inverted K/S predicts (Kubelka–Munk eq. I2 with \
         Saunderson's correction):"
    ))
    .table(opaque_t);
    sec
}

#[cfg(test)]
mod tests {
    use super::*;

    /// DeVore's formulas (M19) at the sodium D line give rutile's standard
    /// indices n_o = 2.613, n_e = 2.909 (the mineralogical tables, e.g.
    /// Deer, Howie & Zussman, *An Introduction to the Rock-Forming
    /// Minerals*, 2nd ed. 1992): within 1e-3 (three-decimal rounding plus
    /// the fit of the formula to DeVore's prism data, a few 1e-4).
    #[test]
    fn devore_gives_rutile_at_the_sodium_line() {
        let (n_o, n_e, mean) = rutile_index(589.3);
        assert!((n_o - 2.613).abs() < 1e-3, "{n_o}");
        assert!((n_e - 2.909).abs() < 1e-3, "{n_e}");
        assert!((mean - (2.0 * n_o + n_e) / 3.0).abs() < 1e-15);
    }

    /// The two-flux forward model with the inverted K, S gives back the
    /// multi-flux reflectances it was inverted from. The inverse is
    /// algebraic (docs/inverse-km.md eq. I5–I9): only rounding, magnified by
    /// 1/(R_white - R_black) (up to ~1e3 here), so 1e-9 is a wide bound.
    #[test]
    fn inverted_k_s_reproduce_the_multiflux_reflectance() {
        let plan = Plan { radii: vec![], ..Plan::of(Size::Tiny) };
        for (r, fv) in [(0.05, 0.1), (0.15, 0.2), (0.3, 0.3)] {
            for p in sweep_point(r, fv, &plan).unwrap() {
                for (i, g) in [Ground::Black, Ground::White].into_iter().enumerate() {
                    let back = forward(&p.film, g).unwrap();
                    assert!(
                        (back - p.r_mf[i]).abs() < 1e-9,
                        "r {r}, f_v {fv}, {} nm, {g:?}: {back} vs {}",
                        p.wavelength_nm,
                        p.r_mf[i]
                    );
                }
            }
        }
    }

    /// Inverting the two-flux KM solver's own answer (Gate's mapping, the
    /// scene's Fresnel surface) recovers that mapping, K = 2 sigma_a and
    /// S = 3/4 sigma_s (1 - g): the inverse's Saunderson constants and
    /// units are those of the scene solver's forward model. Rounding only
    /// (relative 1e-9, as above).
    #[test]
    fn inverting_the_two_flux_solver_recovers_gates_mapping() {
        let two = km_options(KmModel::TwoFlux);
        for (r, fv) in [(0.1, 0.1), (0.25, 0.3)] {
            let sb = scene(r, fv, Ground::Black, &WAVELENGTHS_NM).unwrap();
            let sw = scene(r, fv, Ground::White, &WAVELENGTHS_NM).unwrap();
            let rt = totals(&two.solve_unplanned(&sb).unwrap(), &two.solve_unplanned(&sw).unwrap());
            for (i, l) in sb.channels().iter().map(|c| &c.layers()[0]).enumerate() {
                let film = invert(rt[i][0], rt[i][1]).unwrap();
                let (k, s) = (2.0 * l.sigma_a(), 0.75 * l.sigma_s() * (1.0 - l.g()));
                assert!((film.k / k - 1.0).abs() < 1e-9, "r {r}, f_v {fv}: K {} vs {k}", film.k);
                assert!((film.s / s - 1.0).abs() < 1e-9, "r {r}, f_v {fv}: S {} vs {s}", film.s);
            }
        }
    }

    /// Monte Carlo against the multi-flux solver at one radius and both
    /// grounds: within 3 standard errors plus the multi-flux truncation at
    /// 32 streams (its change from 16 streams, measured below, is added).
    #[test]
    fn monte_carlo_agrees_with_multiflux() {
        let (r, fv) = (0.3, 0.2);
        for (j, g) in [Ground::Black, Ground::White].into_iter().enumerate() {
            let s = scene(r, fv, g, &[CHART_NM]).unwrap();
            let mf = multiflux(&s, 32).unwrap().channels[0].reflectance;
            let trunc = (mf - multiflux(&s, 16).unwrap().channels[0].reflectance).abs();
            let (v, se, _) = monte_carlo(r, fv, g, 40_000, 11 + j as u64).unwrap();
            eprintln!("{g:?}: MC {v} +- {se}, multi-flux {mf} (truncation {trunc:.1e})");
            assert!((v - mf).abs() < 3.0 * se + trunc, "{g:?}: MC {v} +- {se} vs {mf}");
        }
    }
}
