//! Rough faces' exit directions: the multi-flux BRDF and BTDF (cells that
//! carry the spread beam, eq. R14'; the single rough path exact, eq. R18 of
//! docs/rough.md) against km's Monte Carlo (sampled facets, an independent
//! implementation, eq. R17) on stacks that cover the range: alpha
//! 0.02-0.4, n 1.33-1.5, g 0-0.9, tau 0.5-10, rough top over a smooth
//! bottom, rough on both faces, a rough metal floor under a smooth coat.

use km::{Method, MethodOptions, Options};
use km_core::Scene;

/// The stacks and their exit directions (degrees).
fn stacks() -> Vec<(&'static str, String)> {
    let out = |dirs: &str| format!("[output]\ndirections_deg = {dirs}\n");
    vec![
        (
            "clear coat GGX 0.3 over a rough conductor",
            "[light]\ntheta_deg = 30.0\n[[layer]]\ntau = 1.0\nalbedo = 0.9\ng = 0.5\nn = 1.5\n\
             roughness = 0.3\n[substrate]\nkind = \"conductor\"\nn = 0.35\nk = 2.7\nroughness = 0.2\n"
                .to_string()
                + &out("[[0.0, 0.0], [30.0, 0.0], [30.0, 180.0], [50.0, 0.0], [60.0, 180.0], [45.0, 90.0], [15.0, 180.0]]"),
        ),
        (
            "water layer rough on both faces, in air",
            "[light]\ntheta_deg = 45.0\n[[layer]]\ntau = 0.5\nalbedo = 0.95\ng = 0.7\nn = 1.33\n\
             roughness = 0.2\ndistribution = \"beckmann\"\n[substrate]\nkind = \"transparent\"\n\
             n = 1.0\nroughness = 0.4\n"
                .to_string()
                + &out("[[0.0, 0.0], [20.0, 0.0], [45.0, 0.0], [45.0, 180.0], [30.0, 90.0], [70.0, 0.0], [10.0, 180.0]]"),
        ),
        (
            "glass slab GGX 0.1 on top, smooth below, in air",
            "[light]\ntheta_deg = 30.0\n[[layer]]\ntau = 0.5\nalbedo = 0.9\ng = 0.0\nn = 1.5\n\
             roughness = 0.1\n[substrate]\nkind = \"transparent\"\nn = 1.0\n"
                .to_string()
                + &out("[[0.0, 0.0], [30.0, 0.0], [50.0, 0.0], [60.0, 90.0], [10.0, 180.0], [75.0, 180.0]]"),
        ),
        (
            "smooth lacquer over rough aluminium",
            "[spectrum]\nwavelengths_nm = [550.0]\n[light]\ntheta_deg = 20.0\n[[layer]]\ntau = 0.3\nalbedo = 0.8\ng = 0.9\nn = 1.5\n\
             [substrate]\nkind = \"conductor\"\nmetal = \"Al\"\nroughness = 0.25\n"
                .to_string()
                + &out("[[0.0, 0.0], [20.0, 180.0], [30.0, 180.0], [40.0, 180.0], [30.0, 0.0], [45.0, 90.0]]"),
        ),
        (
            "thick forward-scattering layer, GGX 0.15 top, over gold",
            "[spectrum]\nwavelengths_nm = [600.0]\n[light]\ntheta_deg = 40.0\n[[layer]]\ntau = 10.0\nalbedo = 0.99\ng = 0.9\nn = 1.4\n\
             roughness = 0.15\n[substrate]\nkind = \"conductor\"\nmetal = \"Au\"\n"
                .to_string()
                + &out("[[0.0, 0.0], [20.0, 180.0], [40.0, 0.0], [60.0, 90.0], [30.0, 90.0], [75.0, 180.0]]"),
        ),
        // Below alpha 0.1 a solve with exit directions spreads the beam too
        // (eq. R14'); a solve of the totals alone keeps its delta (eq. R14).
        (
            "glass slab GGX 0.05 on top, smooth below, in air",
            "[light]\ntheta_deg = 30.0\n[[layer]]\ntau = 0.5\nalbedo = 0.9\ng = 0.0\nn = 1.5\n\
             roughness = 0.05\n[substrate]\nkind = \"transparent\"\nn = 1.0\n"
                .to_string()
                + &out("[[0.0, 0.0], [50.0, 0.0], [60.0, 90.0], [10.0, 180.0], [75.0, 180.0], [45.0, 90.0]]"),
        ),
        (
            "clear coat GGX 0.02 over a Lambertian ground",
            "[light]\ntheta_deg = 30.0\n[[layer]]\ntau = 1.0\nalbedo = 0.9\ng = 0.5\nn = 1.5\n\
             roughness = 0.02\n[substrate]\nkind = \"lambertian\"\nalbedo = 0.5\n"
                .to_string()
                + &out("[[0.0, 0.0], [45.0, 0.0], [60.0, 90.0], [15.0, 180.0], [60.0, 180.0], [45.0, 90.0]]"),
        ),
    ]
}

fn multiflux(scene: &Scene, streams: usize) -> km_core::ChannelResult {
    let o = km_multiflux::MultifluxOptions { streams: Some(streams), ..Default::default() };
    km::solve(scene, &Options::from(MethodOptions::Multiflux(o))).unwrap().channels[0].clone()
}

/// Four directions at angular distance `r` (degrees) around `d`.
fn ring(d: [f64; 2], r: f64) -> [[f64; 2]; 4] {
    if d[0] < 2.0 * r {
        return [0.0, 90.0, 180.0, 270.0].map(|p| [r, p]);
    }
    let dp = r / d[0].to_radians().sin();
    [[d[0] - r, d[1]], [d[0] + r, d[1]], [d[0], d[1] - dp], [d[0], d[1] + dp]]
}

/// The multi-flux values at the scene's directions and their means over
/// cones of half-angle `r` degrees, from the value at the axis and on a ring
/// of four at the cone's edge: a disc's mean is `f + r^2/8 lap f`, a ring's
/// `f + r^2/4 lap f`, so the cone's is their average to second order.
fn multiflux_cones(text: &str, streams: usize, r: f64) -> km_core::ChannelResult {
    let scene = Scene::from_toml_str(text).unwrap();
    let dirs = scene.channels()[0].directions_deg().to_vec();
    let mut all = dirs.clone();
    for d in &dirs {
        all.extend(ring(*d, r));
    }
    let head = text.split("[output]").next().unwrap();
    let wide =
        Scene::from_toml_str(&format!("{head}[output]\ndirections_deg = {all:?}\n")).unwrap();
    let mut ch = multiflux(&wide, streams);
    let n = dirs.len();
    for v in [&mut ch.brdf, &mut ch.btdf] {
        if v.len() < n {
            continue;
        }
        let cones: Vec<f64> = (0..n)
            .map(|k| {
                let rim = v[n + 4 * k..n + 4 * k + 4].iter().sum::<f64>() / 4.0;
                0.5 * (v[k] + rim)
            })
            .collect();
        *v = cones;
    }
    ch
}

/// The standard errors a difference may reach: about 100 comparisons
/// (totals and directions of seven stacks), so that noise alone fails one of
/// them with a probability of about 5 % (two-sided, 4.7e-4 each). With 3
/// the glass slab's BRDF at (10, 180) (alpha 0.05) failed at -3.05 sigma
/// with seed 11; seeds 5 and 7 read it 0.35 and 0.46 sigma below the
/// multi-flux value.
const Z: f64 = 3.5;

/// BRDF and BTDF at every direction within `max(Z sigma, 1 %)` of the Monte
/// Carlo (4 x 10^7 photons, cones of 1.5 degrees half-angle) plus the
/// multi-flux discretisation error (the change from 16 to 24 streams);
/// totals within `Z` sigma plus that change. The multi-flux values are the
/// cones' means too, from the axis and a ring of four at the cone's edge
/// ([`multiflux_cones`]): at a lobe's peak or on its flank a point value
/// differs from a 1.5-degree cone's mean by percents (the water layer's
/// transmitted peak: 1.2 %; 10 degrees from the glass slab's refracted peak
/// at alpha 0.1: 2.3 %). The table printed is the one in docs/rough.md §7.
#[test]
#[ignore = "several minutes: cargo test --release -p km-bench --test rough_directions -- --ignored --nocapture"]
fn multiflux_exit_directions_agree_with_monte_carlo_on_rough_stacks() {
    let cone = 1.5;
    let mut worst = 0.0f64;
    for (name, text) in stacks() {
        let scene = Scene::from_toml_str(&text).unwrap();
        let (coarse, fine) = (multiflux_cones(&text, 16, cone), multiflux_cones(&text, 24, cone));
        let mut mc_opts = MethodOptions::new(Method::Mc);
        if let MethodOptions::Mc(m) = &mut mc_opts {
            m.samples = 40_000_000;
            m.seed = 11;
        }
        let mc =
            km::solve(&scene, &Options::from(mc_opts).with_cone(cone)).unwrap().channels[0].clone();
        let se = mc.stderr.clone().unwrap();
        eprintln!("{name}");
        let totals = [
            ("R", fine.reflectance, coarse.reflectance, mc.reflectance, se.reflectance.unwrap()),
            (
                "T",
                fine.transmittance,
                coarse.transmittance,
                mc.transmittance,
                se.transmittance.unwrap(),
            ),
        ];
        for (q, f, c, m, s) in totals {
            eprintln!("  {q}: multi-flux {f:.5} (16: {c:.5}), Monte Carlo {m:.5} +- {s:.5}");
            assert!((f - m).abs() <= Z * s + (f - c).abs() + 1e-12, "{name} {q}");
        }
        let sides = [
            ("BRDF", &fine.brdf, &coarse.brdf, &mc.brdf, se.brdf.clone().unwrap()),
            ("BTDF", &fine.btdf, &coarse.btdf, &mc.btdf, se.btdf.clone().unwrap_or_default()),
        ];
        for (q, f, c, m, s) in sides {
            for (k, d) in scene.channels()[0].directions_deg().iter().enumerate() {
                if m[k] == 0.0 && f[k].abs() < 1e-12 {
                    continue;
                }
                let allowed = (Z * s[k]).max(0.01 * m[k]) + (f[k] - c[k]).abs();
                let z = (f[k] - m[k]) / s[k];
                worst = worst.max(z.abs());
                eprintln!(
                    "  {q} {d:?}: multi-flux {:.5} (16: {:.5}), Monte Carlo {:.5} +- {:.5}, z {z:+.2}",
                    f[k], c[k], m[k], s[k]
                );
                assert!((f[k] - m[k]).abs() <= allowed, "{name} {q} {d:?}");
            }
        }
    }
    eprintln!("largest |z| {worst:.2}");
}
