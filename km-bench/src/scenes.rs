//! Scene builders shared by the recipes: slabs given by (`tau`, albedo, `g`),
//! the seed's §4.4 example, and the plane-of-incidence output directions.

use km_core::{Layer, Light, MonoScene, Scene, Substrate};

/// Output directions `[theta, phi]` in the plane of incidence: `theta` from
/// 0 to `theta_max` (degrees) in `count` equal steps on both the back side
/// (`phi = 0`) and the mirror side (`phi = 180`). Returns the directions and,
/// for each, its signed plane angle for a reflected direction
/// ([`km_plot::chart::plane_angle`]).
pub fn plane_directions(count: usize, theta_max: f64) -> (Vec<[f64; 2]>, Vec<(f64, bool)>) {
    let mut dirs = Vec::with_capacity(2 * count);
    let mut meta = Vec::with_capacity(2 * count);
    let count = count.max(2);
    for forward in [false, true] {
        for k in 0..count {
            let t = theta_max * k as f64 / (count - 1) as f64;
            dirs.push([t, if forward { 180.0 } else { 0.0 }]);
            meta.push((t, forward));
        }
    }
    (dirs, meta)
}

/// Output directions `[theta, phi]` on a grid over the reflected
/// hemisphere: `theta = 0, step, ..., <= theta_max`, `phi = 0, 30, ..., 180`
/// (the BRDF of a rotationally symmetric stack is symmetric about the plane
/// of incidence, so half the azimuths cover it); one direction at the pole.
pub fn hemisphere_directions(theta_step: f64, theta_max: f64) -> Vec<[f64; 2]> {
    let mut dirs = vec![[0.0, 0.0]];
    let mut t = theta_step;
    while t <= theta_max + 1e-9 {
        for k in 0..=6 {
            dirs.push([t, 30.0 * k as f64]);
        }
        t += theta_step;
    }
    dirs
}

/// A one-layer scene from optical thickness, albedo and `g`, unit
/// extinction (`sigma_t = 1`, thickness `tau`), layer index `n` in air,
/// over `substrate`, lit by a collimated beam at `theta_deg`.
///
/// # Errors
/// Parameters outside their domains (km-core's validation).
pub fn slab(
    tau: f64,
    albedo: f64,
    g: f64,
    n: f64,
    theta_deg: f64,
    substrate: Substrate,
    directions_deg: Vec<[f64; 2]>,
) -> anyhow::Result<Scene> {
    let layer = Layer::new(1.0 - albedo, albedo, tau, g, n)?;
    let light = Light::collimated(theta_deg)?;
    Ok(Scene::single(MonoScene::new(light, 1.0, vec![layer], substrate, directions_deg)?))
}

/// The seed's §4.4 example (seed 000, §4.4 and fig. 8), as
/// `examples/seed-three-layers.toml` gives it ([`crate::seed`]), with these
/// output directions. `lambertian = false` gives the seed's two-layer system
/// of fig. 10 (interface + slab, clear below, index matched so that the
/// transmitted light is visible).
///
/// # Errors
/// Never for the scene file (km-core's validation).
pub fn seed_three_layers(directions_deg: Vec<[f64; 2]>, lambertian: bool) -> anyhow::Result<Scene> {
    let mut mono = crate::seed::seed_scene();
    if !lambertian {
        mono = mono.with_substrate(Substrate::Transparent { n: mono.layers()[0].n() })?;
    }
    Ok(Scene::single(mono.with_directions(directions_deg)?))
}

/// A named scene of the accuracy-versus-time study.
#[derive(Debug, Clone)]
pub struct StudyScene {
    /// Short name (file stems, table rows).
    pub name: &'static str,
    /// What it is, for the report.
    pub description: &'static str,
    /// The scene (with plane-of-incidence output directions).
    pub scene: Scene,
}

/// The scenes of the accuracy-versus-time study: thin and thick,
/// isotropic and `g = 0.9`, with and without interface and substrate.
///
/// # Errors
/// Never for these constants.
pub fn study_scenes(directions: usize) -> anyhow::Result<Vec<StudyScene>> {
    let (d, _) = plane_directions(directions, 80.0);
    let clear = Substrate::Transparent { n: 1.0 };
    Ok(vec![
        StudyScene {
            name: "thin-iso",
            description: "tau = 0.5, albedo 0.9, isotropic, no interface, clear below, 30 deg",
            scene: slab(0.5, 0.9, 0.0, 1.0, 30.0, clear, d.clone())?,
        },
        StudyScene {
            name: "thick-g09",
            description: "tau = 10, albedo 0.99, g = 0.9, no interface, clear below, 30 deg",
            scene: slab(10.0, 0.99, 0.9, 1.0, 30.0, clear, d.clone())?,
        },
        StudyScene {
            name: "fresnel-lambert",
            description: "tau = 2, albedo 0.8, g = 0.5, n = 1.5, Lambertian 0.5 below, 45 deg",
            scene: slab(
                2.0,
                0.8,
                0.5,
                1.5,
                45.0,
                Substrate::Lambertian { albedo: 0.5 },
                d.clone(),
            )?,
        },
        StudyScene {
            name: "half-space",
            description: "semi-infinite, albedo 0.99, g = 0, n = 1.3, normal incidence (dipole applies)",
            scene: slab(f64::INFINITY, 0.99, 0.0, 1.3, 0.0, clear, d)?,
        },
    ])
}
