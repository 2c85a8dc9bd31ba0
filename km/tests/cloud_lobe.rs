//! The water cloud's forward lobe (docs/phase.md §5): Monte Carlo, which
//! samples the exact phase function (the inverse cumulative table of eq.
//! P18, chi-square tested), against the multi-flux solver averaged over the
//! same cones (`Options::with_cone`), and against DISORT's point values.
//!
//! The cloud is that of km-multiflux/tests/phase_disort.rs on DISORT's own
//! inputs (km-multiflux/tests/data/phase_disort.json: tau 5, its albedo and
//! 1069 Legendre moments of Mie droplets, effective radius 10 um at 550 nm):
//! an index-matched layer on a clear half-space, light at 30 degrees, so the
//! transmitted beam leaves at (30, 180). Directions are named by their angle
//! from that beam and the side they lie on.

use km::{McOptions, MethodOptions, MultifluxOptions, Options, Scene};
use serde_json::Value;

fn f(v: &Value) -> f64 {
    v.as_f64().expect("number")
}

/// The water-cloud case of the DISORT reference.
fn cloud() -> Value {
    let path =
        format!("{}/../km-multiflux/tests/data/phase_disort.json", env!("CARGO_MANIFEST_DIR"));
    let d: Value =
        serde_json::from_str(&std::fs::read_to_string(path).expect("data")).expect("json");
    assert_eq!(f(&d["theta0_deg"]), 30.0);
    let c = d["cases"].as_array().unwrap()[2].clone();
    assert_eq!(c["name"], "water-cloud");
    c
}

/// `[theta, phi]` (degrees) of the transmitted direction `delta` degrees
/// from the beam (30, 180), turned by `around` degrees about it: 0 toward
/// larger theta in the plane of incidence, 180 toward smaller theta, 90 out
/// of the plane.
fn off_beam(delta: f64, around: f64) -> [f64; 2] {
    let (t0, d, a) = (30f64.to_radians(), delta.to_radians(), around.to_radians());
    // The beam, and the unit vectors of growing theta and of the normal to
    // the plane of incidence, in the frame of the lower hemisphere.
    let beam = [-t0.sin(), 0.0, t0.cos()];
    let (et, ep) = ([-t0.cos(), 0.0, -t0.sin()], [0.0, -1.0, 0.0]);
    let v: [f64; 3] =
        std::array::from_fn(|i| d.cos() * beam[i] + d.sin() * (a.cos() * et[i] + a.sin() * ep[i]));
    [v[2].clamp(-1.0, 1.0).acos().to_degrees(), v[1].atan2(v[0]).to_degrees().rem_euclid(360.0)]
}

/// The cloud as a `legendre` layer (DISORT's inputs) with exit directions
/// `dirs`.
fn scene(c: &Value, dirs: &[[f64; 2]]) -> Scene {
    let moments: Vec<String> =
        c["moments"].as_array().unwrap()[1..].iter().map(|m| format!("{:e}", f(m))).collect();
    let dirs: Vec<String> = dirs.iter().map(|d| format!("[{:.12}, {:.12}]", d[0], d[1])).collect();
    Scene::from_toml_str(&format!(
        "[light]\ntheta_deg = 30.0\n[[layer]]\ntau = {}\nalbedo = {}\nphase = {{ kind = \
         \"legendre\", moments = [{}] }}\n[output]\ndirections_deg = [{}]\n",
        f(&c["tau"]),
        f(&c["albedo"]),
        moments.join(", "),
        dirs.join(", ")
    ))
    .unwrap()
}

/// Monte Carlo BTDF cone means of half-angle `cone` and their standard errors.
fn monte_carlo(scene: &Scene, samples: u64, seed: u64, cone: f64) -> (Vec<f64>, Vec<f64>) {
    let o = McOptions { samples, seed, max_events: None, ..Default::default() };
    let sol = km::solve(scene, &Options::from(o).with_cone(cone)).unwrap();
    let ch = &sol.channels[0];
    (ch.btdf.clone(), ch.stderr.as_ref().unwrap().btdf.clone().unwrap())
}

/// Multi-flux BTDF at `streams`: cone means of half-angle `cone`, or point
/// values.
fn multiflux(scene: &Scene, streams: usize, cone: Option<f64>) -> Vec<f64> {
    let o =
        MethodOptions::Multiflux(MultifluxOptions { streams: Some(streams), ..Default::default() });
    let o = cone.map_or(Options::from(o.clone()), |c| Options::from(o).with_cone(c));
    km::solve(scene, &o).unwrap().channels[0].btdf.clone()
}

/// The lobe directions (angle from the beam, turn about it): the beam, 2,
/// 5, 10 and 15 degrees from it in the plane of incidence (5 on both sides)
/// and 5 and 10 degrees out of it.
const LOBE: [(f64, f64); 8] = [
    (0.0, 0.0),
    (2.0, 0.0),
    (5.0, 0.0),
    (5.0, 180.0),
    (10.0, 0.0),
    (15.0, 0.0),
    (5.0, 90.0),
    (10.0, 90.0),
];

/// Multi-flux cone means (3-degree cones, 96 streams) within 3 standard
/// errors of Monte Carlo (16 million photons: standard errors 0.12 % on the
/// beam to 0.47 % at 15 degrees from it) and within 1 % (the issue's
/// target) at all eight directions of the forward lobe, including 5 degrees
/// from the beam in the plane of incidence on both sides, which the
/// truncation of eq. 4b (docs/multiflux.md; the cloud keeps `3N/2` moments)
/// brings in: with `2N` kept they were off by -0.8 % and +1.2 % at 96
/// streams, 4 and 7 standard errors (docs/phase.md §5). 3 standard errors:
/// what Monte Carlo's noise allows when the multi-flux value is the truth
/// (a normal deviate beyond 3 sigma: 1 in 370 per value); the multi-flux
/// point values are converged to less than that (96 against 128 streams:
/// at most 0.2 % from 4 degrees off the beam on, docs/phase.md §5). Not
/// asserted: the default 32 streams, whose cone means within 5 degrees of
/// the beam are still off by up to 2.7 % (the cones reach 2 degrees from
/// the beam, where the nodes do not resolve the peak; docs/phase.md §5).
#[test]
fn lobe_cone_means_agree_with_monte_carlo() {
    let c = cloud();
    let dirs: Vec<[f64; 2]> = LOBE.iter().map(|&(d, a)| off_beam(d, a)).collect();
    let s = scene(&c, &dirs);
    let (mc, se) = monte_carlo(&s, 16_000_000, 21, 3.0);
    let fl = multiflux(&s, 96, Some(3.0));
    for (i, &(d, a)) in LOBE.iter().enumerate() {
        let rel = fl[i] / mc[i] - 1.0;
        println!(
            "{d} deg (turn {a}): mc {:.5} +- {:.5}, multiflux {:.5} ({rel:+.4})",
            mc[i], se[i], fl[i]
        );
        assert!(
            (fl[i] - mc[i]).abs() < 3.0 * se[i],
            "{d}/{a}: {} +- {} vs {}",
            mc[i],
            se[i],
            fl[i]
        );
        assert!(rel.abs() < 0.01, "{d}/{a}: off by {:.2} %", 100.0 * rel);
    }
}

/// DISORT's point values in the lobe (5 and 10 degrees from the beam:
/// (25, 180) and (40, 180)) against Monte Carlo extrapolated to a point:
/// cone means of half-angle 1, 1.5, 2 and 3 degrees (1e8, 6e7, 4e7, 2e7
/// photons) fitted by `f + b alpha^2 + c alpha^4` (weighted least squares;
/// the bias of a cone is even in `alpha`, docs/montecarlo.md §6; without
/// the `alpha^4` term the fit fails, chi-square 6 for 2 degrees of
/// freedom). DISORT within 3 standard errors of the extrapolated point; the
/// multi-flux point values printed beside (docs/phase.md §5). About 3 CPU minutes:
/// `cargo test -p km --test cloud_lobe -- --ignored --nocapture`.
#[test]
#[ignore]
fn disort_points_in_the_lobe_against_monte_carlo() {
    let c = cloud();
    let dirs = [[25.0, 180.0], [40.0, 180.0]];
    let s = scene(&c, &dirs);
    let cones = [(1.0, 100_000_000u64), (1.5, 60_000_000), (2.0, 40_000_000), (3.0, 20_000_000)];
    let runs: Vec<(Vec<f64>, Vec<f64>)> =
        cones.iter().map(|&(a, n)| monte_carlo(&s, n, 9, a)).collect();
    let points: Vec<Vec<f64>> = [32, 64, 96].iter().map(|&n| multiflux(&s, n, None)).collect();
    for (i, d) in dirs.iter().enumerate() {
        // Normal equations of the fit in (1, alpha^2, alpha^4), weights 1/se^2.
        let mut m = [[0.0f64; 4]; 3];
        for (&(a, _), (v, e)) in cones.iter().zip(&runs) {
            let (x, w) = ([1.0, a * a, a.powi(4)], 1.0 / (e[i] * e[i]));
            for r in 0..3 {
                for k in 0..3 {
                    m[r][k] += w * x[r] * x[k];
                }
                m[r][3] += w * x[r] * v[i];
            }
        }
        let (value, se) = intercept(m);
        let want = c["radiances"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| f(&r[0]) == d[0] && f(&r[1]) == d[1] && r[2] == "t")
            .map(|r| f(&r[3]))
            .unwrap();
        let km: Vec<String> = points.iter().map(|p| format!("{:.5}", p[i])).collect();
        println!(
            "{d:?}: Monte Carlo point {value:.5} +- {se:.5}, DISORT {want:.5}, multi-flux at \
             32/64/96 streams {}",
            km.join(" / ")
        );
        assert!((want - value).abs() < 3.0 * se, "{d:?}: DISORT {want} vs {value} +- {se}");
    }
}

/// The intercept of a 3 x 3 least-squares system (augmented normal
/// equations) and its standard error: `x_0` and `sqrt((N^-1)_00)`.
fn intercept(m: [[f64; 4]; 3]) -> (f64, f64) {
    let det = |a: [[f64; 3]; 3]| {
        a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
            - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
            + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
    };
    let n: [[f64; 3]; 3] = std::array::from_fn(|r| std::array::from_fn(|k| m[r][k]));
    let mut n0 = n;
    (0..3).for_each(|r| n0[r][0] = m[r][3]);
    let d = det(n);
    let cofactor = n[1][1] * n[2][2] - n[1][2] * n[2][1];
    (det(n0) / d, (cofactor / d).sqrt())
}
