//! Scene entry points for the command line: [`solve`] (`km solve --method
//! dipole`) and [`profile`] (`km profile`).
//!
//! What a scene must be (otherwise a [`DipoleError`] names the problem):
//! exactly one layer, of infinite thickness (a half-space), with
//! `sigma_s > 0` in every channel. The substrate is irrelevant below a
//! half-space and is ignored.
//!
//! What is reported, per channel (eq. D18 of `docs/diffusion.md`), with
//! `eta = n_layer / n_ambient`:
//!
//! * collimated light at `theta`: `reflectance_specular = F_r(cos theta)`
//!   (ambient into layer), diffuse part `(1 - F_r(cos theta)) Rd` with the
//!   dipole's total `Rd` (eq. D16) of normal incidence: the angle enters
//!   only through the Fresnel transmission into the medium, as in
//!   Jensen et al. 2001;
//! * diffuse light: `reflectance_specular = F_ext` (the hemispherical
//!   reflectance of the interface seen from the ambient), diffuse part
//!   `(1 - F_ext) Rd` (every direction of incidence treated as above);
//! * `reflectance = specular + diffuse`, `transmittance = 0`,
//!   `absorptance = 1 - reflectance`; single scattering is not included
//!   (the dipole is the multiple-scattering term only);
//! * `brdf` at the output directions: `diffuse * F_t(cos theta_o) / (pi C)`,
//!   `C = 1 - F_ext(eta)`, so that `integral brdf cos dw = diffuse`; `btdf = 0`.
//!
//! [`DipoleOptions::model`] chooses the dipole of Jensen et al. 2001 (default)
//! or d'Eon's better dipole ([`crate::better_dipole`]); the rest is the same.

use std::f64::consts::PI;
use std::time::Instant;

use km_core::fresnel::{diffuse_reflectance, reflectance};
use km_core::{ChannelResult, Light, MonoScene, Scene, Solution};

use crate::better_dipole::BetterDipole;
use crate::dipole::{exit_constant_from_fdr, fresnel_transmittance, rd_radial, rd_total};
use crate::error::DipoleError;
use crate::field::DipoleField;
use crate::params::{DiffusionParams, FdrModel, fresnel_moment};

/// Which dipole.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum DipoleModel {
    /// Jensen et al. 2001 (eq. D13–D16), with the chosen [`FdrModel`].
    #[default]
    #[cfg_attr(
        feature = "clap",
        value(name = "jensen2001", help = "Jensen, Marschner, Levoy & Hanrahan 2001")
    )]
    Jensen2001,
    /// d'Eon 2012's better dipole (eq. D19–D22); it uses the exact Fresnel
    /// moments and ignores [`DipoleOptions::fdr`].
    #[cfg_attr(feature = "clap", value(name = "better", help = "d'Eon 2012, the better dipole"))]
    Better,
}

impl DipoleModel {
    /// Name used in reports and on the command line (`jensen2001`, `better`).
    pub fn name(&self) -> &'static str {
        match self {
            DipoleModel::Jensen2001 => "jensen2001",
            DipoleModel::Better => "better",
        }
    }
}

impl std::str::FromStr for DipoleModel {
    type Err = String;
    /// `jensen2001` (or `jensen`, `classic`) or `better` (or `deon2012`).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().as_str() {
            "jensen2001" | "jensen" | "classic" => Ok(DipoleModel::Jensen2001),
            "better" | "deon2012" | "better-dipole" => Ok(DipoleModel::Better),
            other => {
                Err(format!("unknown dipole model \"{other}\" (expected jensen2001 or better)"))
            }
        }
    }
}

/// Options of the dipole method.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DipoleOptions {
    /// How `F_dr` (hence `A`) is computed; default [`FdrModel::Exact`].
    pub fdr: FdrModel,
    /// Which dipole; default [`DipoleModel::Jensen2001`].
    pub model: DipoleModel,
}

/// The medium of one channel as the chosen dipole sees it, with the exit
/// normalisation `C` of its BRDF (eq. D17).
enum Medium {
    Classic(DiffusionParams, f64),
    Better(BetterDipole, f64),
}

/// Fresnel integrals per relative index `eta` (channels usually share it):
/// `(eta, exact F_dr, F_dr of the chosen model, C_2 if computed)`.
#[derive(Default)]
struct FresnelCache(Vec<(f64, f64, f64, Option<f64>)>);

impl FresnelCache {
    /// The entry of `eta`, computing it on first use (eq. D9, D10, D20).
    fn get(&mut self, eta: f64, opts: &DipoleOptions) -> Result<(f64, f64, f64), DipoleError> {
        let better = opts.model == DipoleModel::Better;
        if let Some(e) = self.0.iter_mut().find(|e| e.0 == eta) {
            if better && e.3.is_none() {
                e.3 = Some(fresnel_moment(eta, 2));
            }
            return Ok((e.1, e.2, e.3.unwrap_or(f64::NAN)));
        }
        let exact = FdrModel::Exact.fdr(eta)?;
        let model = if opts.fdr == FdrModel::Exact { exact } else { opts.fdr.fdr(eta)? };
        let c2 = if better { Some(fresnel_moment(eta, 2)) } else { None };
        self.0.push((eta, exact, model, c2));
        Ok((exact, model, c2.unwrap_or(f64::NAN)))
    }
}

impl Medium {
    fn new(
        mono: &MonoScene,
        channel: usize,
        opts: &DipoleOptions,
        cache: &mut FresnelCache,
    ) -> Result<Self, DipoleError> {
        let layer = half_space(mono, channel)?;
        let eta = layer.n() / mono.ambient_n();
        let (fdr_exact, fdr, c2) = match opts.model {
            // The better dipole uses the exact moments only.
            DipoleModel::Better => {
                let o = DipoleOptions { fdr: FdrModel::Exact, ..*opts };
                cache.get(eta, &o)?
            }
            DipoleModel::Jensen2001 => cache.get(eta, opts)?,
        };
        // D17: C = 1 - F_ext = eta^2 (1 - F_dr) with the exact F_dr.
        let c = exit_constant_from_fdr(eta, fdr_exact);
        let sigma_s_prime = layer.sigma_s_reduced();
        Ok(match opts.model {
            DipoleModel::Jensen2001 => Medium::Classic(
                DiffusionParams::assemble(layer.sigma_a(), sigma_s_prime, eta, fdr, opts.fdr),
                c,
            ),
            DipoleModel::Better => Medium::Better(
                BetterDipole::assemble(layer.sigma_a(), sigma_s_prime, 0.5 * fdr_exact, c2),
                c,
            ),
        })
    }
    fn exit_c(&self) -> f64 {
        match self {
            Medium::Classic(_, c) | Medium::Better(_, c) => *c,
        }
    }
    fn rd_total(&self) -> f64 {
        match self {
            Medium::Classic(p, _) => rd_total(p),
            Medium::Better(b, _) => b.rd_total(),
        }
    }
    fn rd_radial(&self, r: f64) -> f64 {
        match self {
            Medium::Classic(p, _) => rd_radial(p, r),
            Medium::Better(b, _) => b.rd_radial(r),
        }
    }
    fn fdr(&self) -> f64 {
        match self {
            Medium::Classic(p, _) => p.fdr,
            Medium::Better(b, _) => 2.0 * b.c1,
        }
    }
    fn a(&self) -> f64 {
        match self {
            Medium::Classic(p, _) => p.a,
            Medium::Better(b, _) => b.a,
        }
    }
    fn alpha_prime(&self) -> f64 {
        match self {
            Medium::Classic(p, _) => p.alpha_prime,
            Medium::Better(b, _) => b.alpha_prime,
        }
    }
    /// The diffusion field inside (eq. D24–D27).
    fn field(&self, sigma_a: f64) -> DipoleField {
        match self {
            Medium::Classic(p, _) => DipoleField::classic(p),
            Medium::Better(b, _) => DipoleField::better(b, sigma_a),
        }
    }
}

/// The half-space of a channel, checked, and its diffusion quantities.
///
/// # Errors
/// More than one layer, finite thickness, no scattering, and the errors of
/// [`DiffusionParams::from_layer`].
pub fn channel_params(
    mono: &MonoScene,
    channel: usize,
    opts: &DipoleOptions,
) -> Result<DiffusionParams, DipoleError> {
    let layer = half_space(mono, channel)?;
    DiffusionParams::from_layer(layer, mono.ambient_n(), opts.fdr)
}

/// The single half-space layer of a channel, or the reason it is not one.
fn half_space(mono: &MonoScene, channel: usize) -> Result<&km_core::Layer, DipoleError> {
    if mono.layers().len() != 1 {
        return Err(DipoleError::LayerCount { count: mono.layers().len() });
    }
    let layer = &mono.layers()[0];
    if let (Some(r), true) = (layer.roughness(), layer.n() != mono.ambient_n()) {
        return Err(DipoleError::RoughFace { alpha: r.alpha() });
    }
    if !layer.is_half_space() {
        return Err(DipoleError::FiniteThickness { layer: 1, thickness: layer.thickness() });
    }
    if layer.sigma_s() <= 0.0 {
        return Err(DipoleError::NoScattering { layer: 1, channel, sigma_s: layer.sigma_s() });
    }
    Ok(layer)
}

/// Solve a scene whose single layer is a half-space with the dipole
/// (module docs: what is reported and how).
///
/// `seconds` is the time of the computation only (no parsing, no checks of
/// the scene beyond the dipole's own).
///
/// # Errors
/// The scene is invalid or not a single scattering half-space (see
/// [`channel_params`]).
///
/// ```
/// let scene = km_core::Scene::from_toml_str(r#"
/// [[layer]]
/// preset = "marble"
/// "#).unwrap();
/// let sol = km_dipole::solve(&scene, &Default::default()).unwrap();
/// assert_eq!(sol.channels.len(), 3);
/// assert!(sol.channels[0].reflectance > 0.8);
/// ```
pub fn solve(scene: &Scene, opts: &DipoleOptions) -> Result<Solution, DipoleError> {
    // Check every channel before timing.
    for (c, mono) in scene.channels().iter().enumerate() {
        half_space(mono, c)?;
    }

    // Timed: the Fresnel integrals (once per relative index), the diffusion
    // quantities and the dipole of every channel.
    let start = Instant::now();
    let mut cache = FresnelCache::default();
    let media = scene
        .channels()
        .iter()
        .enumerate()
        .map(|(c, mono)| Medium::new(mono, c, opts, &mut cache))
        .collect::<Result<Vec<_>, _>>()?;
    let mut channels = Vec::with_capacity(media.len());
    for (mono, m) in scene.channels().iter().zip(&media) {
        channels.push(solve_channel(mono, m));
    }
    let seconds = start.elapsed().as_secs_f64();

    // Report the diffusion quantities, one per channel.
    let list = |f: &dyn Fn(&Medium) -> f64| -> Vec<f64> { media.iter().map(f).collect() };
    let fdr_model = match opts.model {
        DipoleModel::Jensen2001 => opts.fdr.name(),
        DipoleModel::Better => FdrModel::Exact.name(),
    };
    let diagnostics = km_core::solution::DipoleDiagnostics {
        model: opts.model.name(),
        fdr_model,
        fdr: list(&|m| m.fdr()),
        a: list(&|m| m.a()),
        reduced_albedo: list(&|m| m.alpha_prime()),
        rd_dipole: list(&|m| m.rd_total()),
    };
    Ok(Solution {
        method: "dipole".into(),
        channels,
        labels: scene.labels().to_vec(),
        seconds,
        notes: notes(scene),
        diagnostics: km_core::solution::Diagnostics {
            method: km_core::solution::MethodDiagnostics::Dipole(diagnostics),
            ..Default::default()
        },
        ..Default::default()
    })
}

/// One channel (eq. D16, D18).
fn solve_channel(mono: &MonoScene, m: &Medium) -> ChannelResult {
    let n_layer = mono.layers()[0].n();
    // Specular (delta) part and the fraction that enters the medium.
    let r_spec = specular(mono);
    // Multiple scattering that comes back out (normal-incidence dipole).
    let diffuse = (1.0 - r_spec) * m.rd_total();
    // Exit distribution F_t(cos theta_o) / (pi C), normalised to 1 over the hemisphere.
    let eta = n_layer / mono.ambient_n();
    let c = m.exit_c();
    let brdf = mono
        .directions_deg()
        .iter()
        .map(|d| diffuse * fresnel_transmittance(eta, d[0].to_radians().cos()) / (PI * c))
        .collect::<Vec<_>>();
    let btdf = vec![0.0; brdf.len()];
    let reflectance = r_spec + diffuse;
    ChannelResult {
        reflectance,
        reflectance_specular: r_spec,
        transmittance: 0.0,
        transmittance_direct: 0.0,
        absorptance: 1.0 - reflectance,
        brdf,
        btdf,
        absorptance_layers: Some(vec![1.0 - reflectance]),
        ..Default::default()
    }
}

/// The specular (delta) reflection of the channel's light at the surface
/// (eq. D18): `1 - r_spec` enters the medium.
fn specular(mono: &MonoScene) -> f64 {
    let n_layer = mono.layers()[0].n();
    match mono.light() {
        Light::Collimated { .. } => {
            reflectance(mono.light().mu0().unwrap_or(1.0), mono.ambient_n(), n_layer)
        }
        Light::Diffuse => diffuse_reflectance(mono.ambient_n(), n_layer),
    }
}

/// The diffusion field of a broad beam by the dipole ([`depth_field`]):
/// per channel, a value per depth, per unit incident irradiance.
#[derive(Debug, Clone, PartialEq)]
pub struct DipoleDepthField {
    /// Fluence rate `phi(z)`, diffuse and collimated (eq. D26).
    pub fluence: Vec<Vec<f64>>,
    /// Absorbed power density `A(z) = sigma_a phi(z)`, 1/length.
    pub absorbed: Vec<Vec<f64>>,
    /// Net downward flux `F(z)` (eq. D25–D26).
    pub net_flux: Vec<Vec<f64>>,
    /// Per channel, `integral_0^inf A dz` (eq. D27): the one layer's absorptance.
    pub absorptance_layers: Vec<Vec<f64>>,
}

/// `phi(z)`, `A(z)`, `F(z)` of the scene's light as a broad beam on the
/// half-space, by the dipole chosen in `opts` (eq. D24–D27 of
/// `docs/diffusion.md`), at `depths` (finite, `>= 0`), per unit incident
/// irradiance: the fraction `1 - r_spec` that enters (as [`solve`] counts
/// it) times the field per unit power entering at normal incidence (the
/// angle enters only through the Fresnel transmission, as in [`solve`]).
///
/// # Errors
/// Those of [`solve`], and a negative or non-finite depth.
///
/// ```
/// let scene = km_core::Scene::from_toml_str("[[layer]]\npreset = \"skin1\"\n").unwrap();
/// let f = km_dipole::depth_field(&scene, &[1.0, 5.0], &Default::default()).unwrap();
/// // Deep inside the fluence decays (as exp(-sigma_tr z), eq. D24).
/// assert!(f.fluence[0][0] > f.fluence[0][1]);
/// ```
pub fn depth_field(
    scene: &Scene,
    depths: &[f64],
    opts: &DipoleOptions,
) -> Result<DipoleDepthField, DipoleError> {
    if let Some(&bad) = depths.iter().find(|x| !x.is_finite() || **x < 0.0) {
        return Err(DipoleError::invalid("depths", bad, "depths must be finite and >= 0"));
    }
    let mut out = DipoleDepthField {
        fluence: Vec::new(),
        absorbed: Vec::new(),
        net_flux: Vec::new(),
        absorptance_layers: Vec::new(),
    };
    let mut cache = FresnelCache::default();
    for (c, mono) in scene.channels().iter().enumerate() {
        let m = Medium::new(mono, c, opts, &mut cache)?;
        let f = m.field(mono.layers()[0].sigma_a());
        let t_in = 1.0 - specular(mono);
        let (mut phi, mut a, mut net) = (Vec::new(), Vec::new(), Vec::new());
        for &z in depths {
            let (p, ab, n) = f.broad(z);
            phi.push(t_in * p);
            a.push(t_in * ab);
            net.push(t_in * n);
        }
        out.fluence.push(phi);
        out.absorbed.push(a);
        out.net_flux.push(net);
        out.absorptance_layers.push(vec![t_in * f.absorbed_total()]);
    }
    Ok(out)
}

/// The dipole's fluence `phi(r, z)` of a pencil beam (eq. D14, with the
/// chosen model's `D` and sources), 1/length^2, per unit power entering
/// the medium, diffuse light only: `out[channel][k][i] = phi(r[i], z[k])`.
///
/// # Errors
/// Those of [`solve`], and a negative or non-finite `r` or depth.
///
/// ```
/// let scene = km_core::Scene::from_toml_str("[[layer]]\npreset = \"skin1\"\n").unwrap();
/// let f = km_dipole::fluence_profile(&scene, &[0.5, 1.0], &[2.0], &Default::default()).unwrap();
/// assert!(f[0][0][0] > f[0][0][1]);
/// ```
pub fn fluence_profile(
    scene: &Scene,
    r: &[f64],
    depths: &[f64],
    opts: &DipoleOptions,
) -> Result<Vec<Vec<Vec<f64>>>, DipoleError> {
    if let Some(&bad) = r.iter().find(|x| !x.is_finite() || **x < 0.0) {
        return Err(DipoleError::invalid("r", bad, "distances must be finite and >= 0"));
    }
    if let Some(&bad) = depths.iter().find(|x| !x.is_finite() || **x < 0.0) {
        return Err(DipoleError::invalid("depths", bad, "depths must be finite and >= 0"));
    }
    let mut out = Vec::with_capacity(scene.channels().len());
    let mut cache = FresnelCache::default();
    for (c, mono) in scene.channels().iter().enumerate() {
        let f = Medium::new(mono, c, opts, &mut cache)?.field(mono.layers()[0].sigma_a());
        out.push(depths.iter().map(|&z| r.iter().map(|&x| f.fluence_rz(x, z)).collect()).collect());
    }
    Ok(out)
}

/// The notes of the `extra` JSON: what the numbers are and are not.
fn notes(scene: &Scene) -> Vec<String> {
    let mut notes = vec![
        "single scattering excluded: the dipole gives the multiple-scattering part only \
         (Jensen et al. 2001 add an exact single-scattering term separately)"
            .to_string(),
        "reflectance = Fresnel specular part + (1 - F_r) * Rd, with Rd the dipole's total \
         diffuse reflectance (closed form) for normal incidence"
            .to_string(),
        "brdf = diffuse part * F_t(theta_o) / (pi * C), C = 1 - F_ext(eta), which integrates \
         (with cos) to the diffuse part; btdf = 0 for a half-space"
            .to_string(),
    ];
    if scene
        .channels()
        .iter()
        .any(|m| matches!(m.light(), Light::Collimated { theta_deg } if theta_deg > 0.0))
    {
        notes.push(
            "oblique incidence: the dipole's source depth 1/sigma_t' is that of normal \
             incidence; the angle enters only through the Fresnel transmission 1 - F_r(theta)"
                .to_string(),
        );
    }
    if scene.channels().iter().any(|m| m.light() == Light::Diffuse) {
        notes.push(
            "diffuse light: specular part = hemispherical Fresnel reflectance F_ext of the \
             interface; diffuse part = (1 - F_ext) * Rd"
                .to_string(),
        );
    }
    notes
}

/// The dipole's radial diffuse reflectance `Rd(r)` (eq. D15), 1/length^2,
/// per channel, on the grid `r` (lengths in the scene's unit): the answer
/// is `out[channel][i] = Rd(r[i])`, per unit power entering the medium.
///
/// # Errors
/// Those of [`solve`], and a negative or non-finite `r`.
///
/// ```
/// let scene = km_core::Scene::from_toml_str("[[layer]]\npreset = \"skin1\"\n").unwrap();
/// let rd = km_dipole::profile(&scene, &[0.0, 1.0, 2.0], &Default::default()).unwrap();
/// assert_eq!(rd.len(), 3);
/// assert!(rd[0][0] > rd[0][1] && rd[0][1] > rd[0][2]);
/// ```
pub fn profile(
    scene: &Scene,
    r: &[f64],
    opts: &DipoleOptions,
) -> Result<Vec<Vec<f64>>, DipoleError> {
    if let Some(&bad) = r.iter().find(|x| !x.is_finite() || **x < 0.0) {
        return Err(DipoleError::invalid("r", bad, "distances must be finite and >= 0"));
    }
    let mut out = Vec::with_capacity(scene.channels().len());
    let mut cache = FresnelCache::default();
    for (c, mono) in scene.channels().iter().enumerate() {
        let m = Medium::new(mono, c, opts, &mut cache)?;
        out.push(r.iter().map(|&x| m.rd_radial(x)).collect());
    }
    Ok(out)
}
