//! The radiance inside a stack with a rough top (docs/field.md §2a, eq.
//! D14a): the multi-flux answer against km's Monte Carlo (sampled facets,
//! an independent implementation) at one depth and eight directions,
//! the refracted peak of a GGX 0.1 face among them.

use km::Method;
use km::field::{FieldMethod, FieldOptions, field};
use km_core::Scene;

const STACK: &str = "[light]\ntheta_deg = 30.0\n[[layer]]\nthickness = 1.0\nsigma_s = 0.9\n\
    sigma_a = 0.1\ng = 0.5\nn = 1.5\nroughness = 0.1\n[substrate]\nkind = \"lambertian\"\n\
    albedo = 0.5\n";
const DEPTH: f64 = 0.3;
/// The refracted beam's direction inside (sin 30 / 1.5 = sin 19.47).
const PEAK: [f64; 2] = [19.47, 180.0];
const CONE_DEG: f64 = 2.0;

fn multiflux(dirs: &[[f64; 2]], streams: usize) -> Vec<f64> {
    let scene = Scene::from_toml_str(STACK).unwrap();
    let mut opts = FieldOptions { directions: Some(dirs.to_vec()), ..Default::default() };
    opts.multiflux.streams = Some(streams);
    let f = field(&scene, Some(&[DEPTH]), &opts).unwrap();
    f.inside.unwrap().radiance[0][0].clone()
}

/// The mean of the multi-flux point values over the cone of half-angle
/// `CONE_DEG` around `PEAK` (8 Gauss radii x 32 azimuths, small angles).
fn cone_mean() -> f64 {
    let (x, w) = km_core::quadrature::gauss_legendre(8);
    let (mut dirs, mut weights) = (Vec::new(), Vec::new());
    for (xi, wi) in x.iter().zip(&w) {
        let r = 0.5 * CONE_DEG * (xi + 1.0);
        for k in 0..32 {
            let a = k as f64 * std::f64::consts::TAU / 32.0;
            let dphi = r * a.sin() / PEAK[0].to_radians().sin();
            dirs.push([PEAK[0] + r * a.cos(), PEAK[1] + dphi]);
            weights.push(0.5 * CONE_DEG * wi * r);
        }
    }
    let v = multiflux(&dirs, 24);
    v.iter().zip(&weights).map(|(v, w)| v * w).sum::<f64>() / weights.iter().sum::<f64>()
}

/// Away from the peak every value within `max(3.5 sigma, 1 %)` of the Monte
/// Carlo (4 x 10^6 photons, 2-degree cones) plus the multi-flux change from
/// 16 to 24 streams; at the peak, where a cone's mean is far from the point
/// value, the multi-flux cone mean within `max(3.5 sigma, 1 %)` (3.5: nine
/// comparisons of several tests' worth, as in rough_directions.rs).
/// Measured (seed 1): |z| at most 2.05; the peak 89.468 against 89.597 +-
/// 0.064. Without the exact single rough path (the truncated series alone)
/// the value opposite the peak reads -0.080 here (24 streams).
#[test]
fn radiance_inside_under_a_rough_face_agrees_with_monte_carlo() {
    let dirs = [
        [0.0, 0.0],
        [19.47, 0.0],
        [25.0, 0.0],
        [40.0, 90.0],
        [60.0, 0.0],
        [150.0, 0.0],
        [120.0, 90.0],
        PEAK,
    ];
    let (coarse, fine) = (multiflux(&dirs, 16), multiflux(&dirs, 24));
    let scene = Scene::from_toml_str(STACK).unwrap();
    let mut opts = FieldOptions {
        method: FieldMethod(Method::Mc),
        directions: Some(dirs.to_vec()),
        mc_cone_deg: Some(CONE_DEG),
        ..Default::default()
    };
    opts.mc.samples = 4_000_000;
    opts.mc.seed = 1;
    let mc = field(&scene, Some(&[DEPTH]), &opts).unwrap().inside.unwrap();
    let (m, s) = (&mc.radiance[0][0], &mc.stderr.unwrap()[0][0]);
    for (k, d) in dirs.iter().enumerate() {
        let (f, disc) =
            if *d == PEAK { (cone_mean(), 0.0) } else { (fine[k], (fine[k] - coarse[k]).abs()) };
        let allowed = (3.5 * s[k]).max(0.01 * m[k]) + disc;
        assert!(f > 0.0, "{d:?}: {f}");
        assert!(
            (f - m[k]).abs() <= allowed,
            "{d:?}: multi-flux {f} Monte Carlo {} +- {}",
            m[k],
            s[k]
        );
    }
}
