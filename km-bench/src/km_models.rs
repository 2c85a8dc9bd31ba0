//! # How far the closed forms are from the converged multi-flux answer
//!
//! The grid of docs/two-flux.md §13: one layer in air over a clear
//! half-space of index 1 (a free slab), lit by a collimated beam, over
//!
//! | parameter | values |
//! |---|---|
//! | albedo | 0 (clear), 0.5, 0.9, 0.99 |
//! | `g` (Henyey–Greenstein) | 0, 0.5, 0.9 |
//! | optical thickness `tau` | 0.1, 1, 10 |
//! | layer index `n` | 1, 1.33, 1.7 |
//! | incidence | 0, 45, 75 degrees |
//!
//! 324 scenes. The reference is the multi-flux solver at
//! [`REFERENCE_STREAMS`] Gauss nodes per hemisphere, checked against
//! [`CHECK_STREAMS`] (the largest difference is reported with the table).
//! [`km_errors`] measures a two-flux setting (model and mapping) on the grid,
//! [`comparison`] every setting, [`markdown`] writes the table of the note,
//! and [`estimate_stats`] measures how `model_error_estimate` bounds the
//! true error.

use km::{KmMapping, KmModel, KmOptions, Method, Options, Solver};
use km_core::{Layer, Light, MonoScene, Scene, Substrate};
use rayon::prelude::*;

/// Albedos of the grid.
pub const ALBEDOS: [f64; 4] = [0.0, 0.5, 0.9, 0.99];
/// Henyey–Greenstein asymmetries of the grid.
pub const GS: [f64; 3] = [0.0, 0.5, 0.9];
/// Optical thicknesses of the grid.
pub const TAUS: [f64; 3] = [0.1, 1.0, 10.0];
/// Layer indices of the grid (ambient and substrate: 1).
pub const INDICES: [f64; 3] = [1.0, 1.33, 1.7];
/// Incidence angles of the grid, degrees.
pub const ANGLES: [f64; 3] = [0.0, 45.0, 75.0];

/// Streams of the converged reference.
pub const REFERENCE_STREAMS: usize = 64;
/// Streams of the reference's convergence check.
pub const CHECK_STREAMS: usize = 48;

/// One scene of the grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridPoint {
    /// Single-scattering albedo.
    pub albedo: f64,
    /// Henyey–Greenstein asymmetry.
    pub g: f64,
    /// Optical thickness.
    pub tau: f64,
    /// Refractive index of the layer.
    pub n: f64,
    /// Incidence angle, degrees.
    pub theta_deg: f64,
}

impl GridPoint {
    /// The scene: the layer (`sigma_t = 1`, thickness `tau`) in air over a
    /// clear half-space of index 1, collimated light at `theta_deg`.
    ///
    /// # Errors
    /// Never for the grid's values (km-core's validation).
    pub fn scene(&self) -> anyhow::Result<Scene> {
        let layer = Layer::new(1.0 - self.albedo, self.albedo, self.tau, self.g, self.n)?;
        let light = Light::collimated(self.theta_deg)?;
        let sub = Substrate::Transparent { n: 1.0 };
        Ok(Scene::single(MonoScene::new(light, 1.0, vec![layer], sub, vec![])?))
    }
}

/// The grid over `albedos` x [`GS`] x `taus` x [`INDICES`] x [`ANGLES`],
/// albedo slowest, incidence fastest.
fn grid_over(albedos: &[f64], taus: &[f64]) -> Vec<GridPoint> {
    let mut v = Vec::new();
    for &albedo in albedos {
        for g in GS {
            for &tau in taus {
                for n in INDICES {
                    for theta_deg in ANGLES {
                        v.push(GridPoint { albedo, g, tau, n, theta_deg });
                    }
                }
            }
        }
    }
    v
}

/// The grid of the two-flux study (324 slabs).
pub fn grid() -> Vec<GridPoint> {
    grid_over(&ALBEDOS, &TAUS)
}

/// Albedos of the dipole's grid (where a diffusion model is meant to apply).
pub const DIPOLE_ALBEDOS: [f64; 4] = [0.5, 0.9, 0.99, 0.999];

/// The dipole's grid: half-spaces over [`DIPOLE_ALBEDOS`] x [`GS`] x
/// [`INDICES`] x [`ANGLES`] (108 scenes).
pub fn dipole_grid() -> Vec<GridPoint> {
    grid_over(&DIPOLE_ALBEDOS, &[f64::INFINITY])
}

/// The converged answer of one scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reference {
    /// Total reflectance.
    pub r: f64,
    /// Total transmittance.
    pub t: f64,
    /// `max(|dR|, |dT|)` between [`REFERENCE_STREAMS`] and [`CHECK_STREAMS`].
    pub spread: f64,
}

fn multiflux(scene: &Scene, streams: usize) -> anyhow::Result<(f64, f64)> {
    let o = km::MultifluxOptions { streams: Some(streams), ..Default::default() };
    let c = &o.solve_unplanned(scene)?.channels[0];
    Ok((c.reflectance, c.transmittance))
}

/// The converged multi-flux answers of `points` (in parallel).
///
/// # Errors
/// A solver refusal (none expected on the grid).
pub fn references(points: &[GridPoint]) -> anyhow::Result<Vec<Reference>> {
    points
        .par_iter()
        .map(|p| {
            let s = p.scene()?;
            let (r, t) = multiflux(&s, REFERENCE_STREAMS)?;
            let (r2, t2) = multiflux(&s, CHECK_STREAMS)?;
            Ok(Reference { r, t, spread: (r - r2).abs().max((t - t2).abs()) })
        })
        .collect()
}

/// The references as CSV (`albedo,g,tau,n,theta_deg,r,t,spread`, numbers
/// written to round trip), with a header line naming their source.
pub fn reference_csv(points: &[GridPoint], refs: &[Reference]) -> String {
    let mut s = format!(
        "# multi-flux at {REFERENCE_STREAMS} streams (spread: difference to {CHECK_STREAMS}), \
         km_bench::km_models::references\nalbedo,g,tau,n,theta_deg,r,t,spread\n"
    );
    for (p, r) in points.iter().zip(refs) {
        s.push_str(&format!(
            "{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?}\n",
            p.albedo, p.g, p.tau, p.n, p.theta_deg, r.r, r.t, r.spread
        ));
    }
    s
}

/// Read [`reference_csv`]'s text back.
///
/// # Errors
/// A line that is not eight numbers.
pub fn read_reference_csv(text: &str) -> anyhow::Result<(Vec<GridPoint>, Vec<Reference>)> {
    let (mut points, mut refs) = (Vec::new(), Vec::new());
    for line in text.lines().filter(|l| !l.starts_with('#') && !l.starts_with("albedo")) {
        let v: Vec<f64> = line.split(',').map(str::parse).collect::<Result<_, _>>()?;
        let [albedo, g, tau, n, theta_deg, r, t, spread] = v[..] else {
            anyhow::bail!("expected 8 numbers: {line}");
        };
        points.push(GridPoint { albedo, g, tau, n, theta_deg });
        refs.push(Reference { r, t, spread });
    }
    Ok((points, refs))
}

/// The errors of one setting over the grid.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelErrors {
    /// The setting, e.g. `four-flux, gate1974`.
    pub label: String,
    /// `|R - R_ref|` per scene (NaN where the setting refused the scene).
    pub err_r: Vec<f64>,
    /// `|T - T_ref|` per scene (NaN where refused).
    pub err_t: Vec<f64>,
}

/// Median and largest of the finite values.
fn median_max(v: &[f64]) -> (f64, f64) {
    let mut x: Vec<f64> = v.iter().copied().filter(|e| e.is_finite()).collect();
    if x.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    x.sort_by(f64::total_cmp);
    let m = x.len() / 2;
    let median = if x.len() % 2 == 1 { x[m] } else { 0.5 * (x[m - 1] + x[m]) };
    (median, x[x.len() - 1])
}

impl ModelErrors {
    /// Scenes the setting refused.
    pub fn refused(&self) -> usize {
        self.err_r.iter().filter(|e| !e.is_finite()).count()
    }
    /// Median and worst of `|R - R_ref|`.
    pub fn r_stats(&self) -> (f64, f64) {
        median_max(&self.err_r)
    }
    /// Median and worst of `|T - T_ref|`.
    pub fn t_stats(&self) -> (f64, f64) {
        median_max(&self.err_t)
    }
    /// The scene error `max(|dR|, |dT|)` per scene.
    pub fn scene_errors(&self) -> Vec<f64> {
        self.err_r.iter().zip(&self.err_t).map(|(r, t)| r.max(*t)).collect()
    }
    /// Mean of the scene error over the scenes solved: the criterion of the
    /// default mapping (docs/two-flux.md §13).
    pub fn mean(&self) -> f64 {
        let e: Vec<f64> = self.scene_errors().into_iter().filter(|e| e.is_finite()).collect();
        e.iter().sum::<f64>() / e.len().max(1) as f64
    }
}

/// The errors of the two-flux setting `opts` (bare solver, no estimate)
/// against `refs` over `points`.
///
/// # Errors
/// Scene construction errors (a mapping's refusal is recorded as NaN).
pub fn km_errors(
    points: &[GridPoint],
    refs: &[Reference],
    opts: KmOptions,
) -> anyhow::Result<ModelErrors> {
    let mut m = ModelErrors {
        label: format!("{}, {}", opts.model.name(), opts.mapping.name()),
        err_r: Vec::with_capacity(points.len()),
        err_t: Vec::with_capacity(points.len()),
    };
    for (p, rf) in points.iter().zip(refs) {
        match opts.solve_unplanned(&p.scene()?) {
            Ok(sol) => {
                let c = &sol.channels[0];
                m.err_r.push((c.reflectance - rf.r).abs());
                m.err_t.push((c.transmittance - rf.t).abs());
            }
            Err(_) => {
                m.err_r.push(f64::NAN);
                m.err_t.push(f64::NAN);
            }
        }
    }
    Ok(m)
}

/// The mappings compared.
pub const MAPPINGS: [KmMapping; 3] =
    [KmMapping::Seed, KmMapping::StarEtAl1988, KmMapping::Gate1974];

/// Every model and mapping on the grid: two-flux first, then four-flux.
///
/// # Errors
/// Those of [`km_errors`].
pub fn comparison(points: &[GridPoint], refs: &[Reference]) -> anyhow::Result<Vec<ModelErrors>> {
    let mut rows = Vec::new();
    for model in [KmModel::TwoFlux, KmModel::FourFlux] {
        for mapping in MAPPINGS {
            rows.push(km_errors(points, refs, KmOptions { mapping, model })?);
        }
    }
    Ok(rows)
}

/// The mapping of the four-flux rows with the least mean scene error over
/// the scenes it solves, among those that solve every scene (a default
/// must not refuse).
pub fn best_mapping(rows: &[ModelErrors]) -> Option<KmMapping> {
    MAPPINGS
        .into_iter()
        .filter_map(|m| {
            let label = format!("{}, {}", KmModel::FourFlux.name(), m.name());
            let row = rows.iter().find(|r| r.label == label)?;
            (row.refused() == 0).then(|| (m, row.mean()))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(m, _)| m)
}

/// The table of docs/two-flux.md §13: median and worst errors of `R` and
/// `T`, the mean scene error and the refusals, one row per setting.
pub fn markdown(rows: &[ModelErrors]) -> String {
    let mut s = String::from(
        "| model, mapping | median \\|dR\\| | worst \\|dR\\| | median \\|dT\\| | worst \\|dT\\| \
         | mean max(\\|dR\\|, \\|dT\\|) | refused |\n|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let ((mr, wr), (mt, wt)) = (r.r_stats(), r.t_stats());
        s.push_str(&format!(
            "| {} | {mr:.2e} | {wr:.2e} | {mt:.2e} | {wt:.2e} | {:.2e} | {} |\n",
            r.label,
            r.mean(),
            r.refused()
        ));
    }
    s
}

/// How `model_error_estimate` bounds the true error of a method's answer.
#[derive(Debug, Clone, PartialEq)]
pub struct EstimateStats {
    /// Numbers compared (`R` and `T` of every scene).
    pub count: usize,
    /// Numbers whose estimate is at least the true error.
    pub bounded: usize,
    /// Numbers whose estimate is at most ten times the true error (or
    /// where both are below [`ESTIMATE_FLOOR`]).
    pub within_10x: usize,
    /// The estimate over the true error, median over the numbers with a
    /// true error above [`ESTIMATE_FLOOR`].
    pub median_ratio: f64,
}

/// Errors below this are rounding for the statistics of [`estimate_stats`]
/// (the reference's own convergence is better than 1e-6 on the grid).
pub const ESTIMATE_FLOOR: f64 = 1e-6;

/// [`EstimateStats`] of `method` (`km` at its defaults, or the dipole) on
/// `points` through `km::solve`, against `refs`. The true error is
/// `|x - x_ref|`; an estimate "bounds" it when `est >= true - FLOOR` and is
/// "within 10x" when `est <= 10 true + FLOOR`.
///
/// # Errors
/// A solve that fails or carries no estimate.
pub fn estimate_stats(
    points: &[GridPoint],
    refs: &[Reference],
    method: Method,
) -> anyhow::Result<EstimateStats> {
    let mut s = EstimateStats { count: 0, bounded: 0, within_10x: 0, median_ratio: f64::NAN };
    let mut ratios = Vec::new();
    for (p, rf) in points.iter().zip(refs) {
        let sol = km::solve(&p.scene()?, &Options::new(method))?;
        let c = &sol.channels[0];
        let Some(est) = &c.model_error_estimate else {
            anyhow::bail!("{method} answer without model_error_estimate at {p:?}");
        };
        for (x, x_ref, e) in
            [(c.reflectance, rf.r, est.reflectance), (c.transmittance, rf.t, est.transmittance)]
        {
            let e = e.unwrap_or(f64::NAN);
            let truth = (x - x_ref).abs();
            s.count += 1;
            s.bounded += usize::from(e >= truth - ESTIMATE_FLOOR);
            s.within_10x += usize::from(e <= 10.0 * truth + ESTIMATE_FLOOR);
            if truth > ESTIMATE_FLOOR {
                ratios.push(e / truth);
            }
        }
    }
    s.median_ratio = median_max(&ratios).0;
    Ok(s)
}
