//! The seed paper's example of §4.4 (seed 000, fig. 8–10): its scene,
//! loaded once from `examples/seed-three-layers.toml`, its three "layers"
//! alone and combined (fig. 9), and the truncation study of the adding
//! formula (fig. 10), on the direction-set mode of km-multiflux.

use std::f64::consts::PI;

use anyhow::anyhow;
use km_core::fresnel::{diffuse_reflectance, reflectance};
use km_core::{Layer, Light, MonoScene, Scene, Substrate};
use km_multiflux::direction_set::{
    Combine, Distribution, Incidence, MatchedSets, StackResponse, brdf_for_incidence,
    interface_operators,
};

/// The scene file of the seed's §4.4 example: a smooth interface of index
/// 1.3, a coating `sigma_a = 0.1`, `sigma_s = 0.4` of thickness
/// `1 / (2 sigma_t) = 1`, isotropic (the seed names no `g`: an assumption),
/// over a Lambertian reflector of albedo 0.8, lit at 45 degrees.
pub const SEED_SCENE_FILE: &str = include_str!("../../examples/seed-three-layers.toml");

/// The seed's §4.4 scene as read from [`SEED_SCENE_FILE`] (its output
/// directions included).
///
/// # Panics
/// Never: the file is part of the build and a test reads it.
pub fn seed_scene_file() -> Scene {
    Scene::from_toml_str(SEED_SCENE_FILE).expect("examples/seed-three-layers.toml is valid")
}

/// The seed's §4.4 scene as one channel, without output directions.
pub fn seed_scene() -> MonoScene {
    let first = seed_scene_file().split_first().0.clone();
    first.with_directions(Vec::new()).expect("no direction is a valid list")
}

/// The seed's coating layer (the scene file's only layer).
pub fn seed_layer() -> Layer {
    seed_scene().layers()[0].clone()
}

/// The polar angle of the seed's light, degrees.
pub fn seed_theta_deg() -> f64 {
    match seed_scene().light() {
        Light::Collimated { theta_deg } => theta_deg,
        Light::Diffuse => unreachable!("the seed's light is collimated"),
    }
}

/// The seed's scene with another stack and substrate (light and ambient kept).
fn with_stack(
    seed: &MonoScene,
    layers: Vec<Layer>,
    substrate: Substrate,
) -> Result<MonoScene, km_core::CoreError> {
    MonoScene::new(seed.light(), seed.ambient_n(), layers, substrate, Vec::new())
}

/// The seed's example of §4.4 (fig. 8–9): each of its three "layers" lit
/// alone at 45° and the three combined.
#[derive(Debug, Clone, PartialEq)]
pub struct SeedExample {
    /// (a) the air/coating interface alone (n = 1 -> 1.3): mirror reflection
    /// and refracted transmission into the coating.
    pub interface: StackResponse,
    /// (b) the scattering coating alone, index-matched (light at 45° in it).
    pub layer: StackResponse,
    /// (c) the Lambertian substrate (albedo 0.8) alone.
    pub lambertian: StackResponse,
    /// (d) interface + coating + Lambertian substrate combined (exact adding).
    pub combined: StackResponse,
}

/// Seed 000 §4.4, fig. 9 (a)–(d), on about `n_target` directions.
///
/// # Errors
/// Numerical failure.
pub fn seed_example_3_layers(n_target: usize) -> anyhow::Result<SeedExample> {
    let coat = seed_layer();
    let matched = coat.with_n(1.0)?;
    let seed = seed_scene();
    let n = coat.n();
    let clear = Layer::new(0.0, 0.0, 0.0, 0.0, n)?;
    let interface = with_stack(&seed, vec![clear], Substrate::Transparent { n })?;
    let layer = with_stack(&seed, vec![matched], Substrate::Transparent { n: 1.0 })?;
    let ground = seed.substrate();
    let lambertian = with_stack(&seed, vec![Layer::new(0.0, 0.0, 0.0, 0.0, 1.0)?], ground)?;
    let combined = with_stack(&seed, vec![coat], ground)?;
    Ok(SeedExample {
        interface: brdf_for_incidence(&interface, n_target, Combine::Exact)?,
        layer: brdf_for_incidence(&layer, n_target, Combine::Exact)?,
        lambertian: brdf_for_incidence(&lambertian, n_target, Combine::Exact)?,
        combined: brdf_for_incidence(&combined, n_target, Combine::Exact)?,
    })
}

/// Relative RMS differences of a truncated adding against the exact one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RmsError {
    /// Over the node radiances of reflection and transmission, delta parts
    /// included (`rms(approx - exact) / rms(exact)`): the seed's measure, whose
    /// denominator is dominated by the mirror and unscattered nodes.
    pub with_delta: f64,
    /// Over the reflected node radiances only, mirror node included.
    pub with_delta_brdf: f64,
    /// The same as `with_delta` over the smooth parts only.
    pub smooth: f64,
    /// Over the smooth BRDF alone.
    pub smooth_brdf: f64,
    /// Absolute error of the total reflectance.
    pub reflectance: f64,
    /// Absolute error of the total transmittance.
    pub transmittance: f64,
}

/// The seed's 2-layer truncation study (§4.4, fig. 10).
#[derive(Debug, Clone, PartialEq)]
pub struct TruncationStudy {
    /// Interface + coating over a clear half-space of index 1.3, exact adding.
    pub exact: StackResponse,
    /// 0th-order truncation `(1 - R_rr)^-1 ~ 1` (seed eq. 21).
    pub order0: StackResponse,
    /// 1st-order truncation `(1 - R_rr)^-1 ~ 1 + R_rr`.
    pub order1: StackResponse,
    /// Errors of the 0th order.
    pub rms0: RmsError,
    /// Errors of the 1st order.
    pub rms1: RmsError,
    /// Spectral radius of `R_rr = R21^(2) R12^(1)` (coating top reflection after
    /// the interface's inside reflection): the Neumann series' ratio.
    pub rr_spectral_radius: f64,
    /// Flux-weighted norm of `R_rr` for diffuse light inside: the fraction of
    /// an isotropic upward flux returned upward after one round trip.
    pub rr_diffuse: f64,
    /// Fresnel reflectance at 45° from air into n = 1.3 (~0.024).
    pub fresnel_45_outside: f64,
    /// Fresnel reflectance at 45° from inside n = 1.3 towards air (~0.093).
    pub fresnel_45_inside: f64,
    /// Hemispherical (diffuse) reflectance of the interface from inside (TIR included).
    pub fresnel_diffuse_inside: f64,
    /// Kubelka–Munk reflectance of the coating alone (seed eq. 10; the seed's 0.26).
    pub km_reflectance: f64,
}

fn rms_error(a: &StackResponse, e: &StackResponse) -> RmsError {
    let cat = |r: &StackResponse, smooth: bool| -> Vec<f64> {
        let pick = |d: &Distribution| if smooth { d.value.clone() } else { d.node_value.clone() };
        let mut v = pick(&r.reflected);
        if let Some(t) = &r.transmitted {
            v.extend(pick(t));
        }
        v
    };
    let rel = |x: &[f64], y: &[f64]| -> f64 {
        let num: f64 = x.iter().zip(y).map(|(p, q)| (p - q) * (p - q)).sum();
        let den: f64 = y.iter().map(|q| q * q).sum();
        (num / den).sqrt()
    };
    RmsError {
        with_delta: rel(&cat(a, false), &cat(e, false)),
        with_delta_brdf: rel(&a.reflected.node_value, &e.reflected.node_value),
        smooth: rel(&cat(a, true), &cat(e, true)),
        smooth_brdf: rel(&a.reflected.value, &e.reflected.value),
        reflectance: a.reflectance - e.reflectance,
        transmittance: a.transmittance - e.transmittance,
    }
}

/// Seed 000 §4.4, fig. 10: the interface + coating system (transmission into a
/// clear half-space of the coating's index, so the transmitted distribution
/// is visible), exact adding against the 0th and 1st-order Neumann
/// truncations, on about `n_target` directions.
///
/// # Errors
/// Numerical failure.
pub fn seed_truncation_study(n_target: usize) -> anyhow::Result<TruncationStudy> {
    let coat = seed_layer();
    let seed = seed_scene();
    let (n, theta_deg) = (coat.n(), seed_theta_deg());
    let scene = with_stack(&seed, vec![coat.clone()], Substrate::Transparent { n })?;
    let exact = brdf_for_incidence(&scene, n_target, Combine::Exact)?;
    let order0 = brdf_for_incidence(&scene, n_target, Combine::Neumann(0))?;
    let order1 = brdf_for_incidence(&scene, n_target, Combine::Neumann(1))?;
    // R_rr = R21^(2) R12^(1): coating top reflection times interface inside reflection.
    let inc = Incidence { n: scene.ambient_n(), theta_deg };
    let sets = MatchedSets::new(n_target, &[scene.ambient_n(), n], Some(inc))?;
    let inside = sets.set(n)?;
    let iface = interface_operators(sets.set(1.0)?, inside)?;
    let slab = inside.layer_operators(&coat)?;
    let rr = &slab.r_top * &iface.r_bottom;
    let ev = rr.eigenvalues().map_err(|e| anyhow!("eigenvalues of R_rr: {e:?}"))?;
    let rr_spectral_radius = ev.iter().map(|z| z.norm()).fold(0.0, f64::max);
    // Isotropic upward radiance 1/pi inside: upward flux after one round trip.
    let m = inside.len();
    let up: Vec<f64> = (0..m).map(|i| (0..m).map(|j| rr[(i, j)] / PI).sum::<f64>()).collect();
    let (mu, w) = (inside.mu(), inside.weights());
    let flux_in: f64 = (0..m).map(|j| mu[j] * w[j] / PI).sum();
    let flux_out: f64 = (0..m).map(|i| mu[i] * w[i] * up[i]).sum();
    let c45 = theta_deg.to_radians().cos();
    Ok(TruncationStudy {
        rms0: rms_error(&order0, &exact),
        rms1: rms_error(&order1, &exact),
        exact,
        order0,
        order1,
        rr_spectral_radius,
        rr_diffuse: flux_out / flux_in,
        fresnel_45_outside: reflectance(c45, 1.0, n),
        fresnel_45_inside: reflectance(c45, n, 1.0),
        fresnel_diffuse_inside: diffuse_reflectance(n, 1.0),
        km_reflectance: kubelka_munk_reflectance(coat.sigma_a(), coat.sigma_s(), coat.thickness()),
    })
}

/// Kubelka–Munk reflectance of a slab over a black background in the seed's
/// form (seed 000 eq. 10): `a = sigma_t / sigma_s`, `b = sqrt(a^2 - 1)`,
/// `R = sinh(b sigma_s z0) / (a sinh(b sigma_s z0) + b cosh(b sigma_s z0))`.
fn kubelka_munk_reflectance(sigma_a: f64, sigma_s: f64, z0: f64) -> f64 {
    let a = (sigma_a + sigma_s) / sigma_s;
    let b = (a * a - 1.0).sqrt();
    let x = b * sigma_s * z0;
    x.sinh() / (a * x.sinh() + b * x.cosh())
}
