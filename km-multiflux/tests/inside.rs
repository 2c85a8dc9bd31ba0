//! Radiance at user directions inside the stack (`km_multiflux::inside`,
//! docs/field.md §2a): against the solver's own exit radiances at the faces,
//! the node radiances of `internal_field`, the depth profile's fluence and
//! net flux, and a closed form.

use std::f64::consts::PI;

use km_core::Scene;
use km_core::quadrature::gauss_legendre;
use km_multiflux::depth::DepthField;
use km_multiflux::inside::inside_radiance;
use km_multiflux::{MultifluxOptions, internal_field, solve};

fn scene(t: &str) -> Scene {
    Scene::from_toml_str(t).unwrap()
}

/// Matched indices (no refraction at any face), a beam at 30 degrees: the
/// up-going radiance at depth 0 is the BRDF and the down-going one at the
/// bottom the BTDF the solver gives at the same directions (both from the
/// same operators, grouped differently by the adding: only rounding, 1e-10
/// relative, separates them). Without delta-M (no single-scattering
/// correction in the BRDF, which the radiance inside does not apply):
/// isotropic, g = 0.5 and two layers.
#[test]
fn faces_equal_the_exit_radiances() {
    let scenes = [
        "[light]\ntheta_deg = 30.0\n[[layer]]\nsigma_a = 0.3\nsigma_s = 2.0\nthickness = 1.0\n\
         [substrate]\nkind = \"transparent\"\nn = 1.0\n",
        "[light]\ntheta_deg = 30.0\n[[layer]]\nsigma_a = 0.3\nsigma_s = 2.0\nthickness = 1.0\n\
         g = 0.5\n[substrate]\nkind = \"transparent\"\nn = 1.0\n",
        "[light]\ntheta_deg = 40.0\n[[layer]]\nsigma_a = 0.1\nsigma_s = 1.0\nthickness = 0.7\n\
         g = 0.8\n[[layer]]\nsigma_a = 0.5\nsigma_s = 3.0\nthickness = 0.4\ng = 0.2\n\
         [substrate]\nkind = \"transparent\"\nn = 1.0\n",
    ];
    let exits = [[0.0, 0.0], [20.0, 45.0], [45.0, 180.0], [70.0, 300.0]];
    for (k, t) in scenes.iter().enumerate() {
        let s = scene(&format!("{t}[output]\ndirections_deg = {exits:?}\n"));
        let o = MultifluxOptions { streams: Some(8), delta_m: false, ..Default::default() };
        let sol = solve(&s, &o).unwrap();
        let res = &sol.channels[0];
        let (brdf, btdf) = (&res.brdf, &res.btdf);
        let total: f64 = s.channels()[0].layers().iter().map(|l| l.thickness()).sum();
        let up: Vec<[f64; 2]> = exits.iter().map(|d| [180.0 - d[0], d[1]]).collect();
        let ch = &s.channels()[0];
        let top = inside_radiance(ch, &o, &[0.0], &up).unwrap();
        let bottom = inside_radiance(ch, &o, &[total], &exits).unwrap();
        for j in 0..exits.len() {
            for (got, want, what) in
                [(top.radiance[0][j], brdf[j], "BRDF"), (bottom.radiance[0][j], btdf[j], "BTDF")]
            {
                let d = (got - want).abs() / want.abs().max(1e-3);
                assert!(d < 1e-10, "scene {k}, {what} at {:?}: {got} vs {want}", exits[j]);
            }
        }
    }
}

/// Under a Fresnel top face (n = 1.5, no delta-M), the radiance leaving
/// into the air is the up-going radiance just below the face times the
/// face's transmittance `1 - R_F(mu)` and `(n0 / n1)^2` (radiance over n^2
/// is conserved across the face): the BRDF at 30 degrees in air against
/// the radiance inside at the refracted angle (rounding only: 1e-10).
#[test]
fn top_face_refracts_the_radiance_inside() {
    let exits: [[f64; 2]; 3] = [[0.0, 0.0], [30.0, 90.0], [60.0, 180.0]];
    let t = format!(
        "[light]\ntheta_deg = 20.0\n[[layer]]\nsigma_a = 0.2\nsigma_s = 2.0\nthickness = 1.0\n\
         g = 0.6\nn = 1.5\n[output]\ndirections_deg = {exits:?}\n"
    );
    let s = scene(&t);
    let o = MultifluxOptions { streams: Some(12), delta_m: false, ..Default::default() };
    let brdf = solve(&s, &o).unwrap().channels[0].brdf.clone();
    let n1 = 1.5;
    for (j, d) in exits.iter().enumerate() {
        let st = d[0].to_radians().sin() / n1;
        let theta_in = st.asin().to_degrees();
        let r = inside_radiance(&s.channels()[0], &o, &[0.0], &[[180.0 - theta_in, d[1]]]).unwrap();
        let mu0 = d[0].to_radians().cos();
        let rf = km_core::fresnel::reflectance(mu0, 1.0, n1);
        let want = brdf[j];
        let got = r.radiance[0][0] * (1.0 - rf) / (n1 * n1);
        assert!((got - want).abs() < 1e-10 * want.abs(), "{d:?}: {got} vs {want}");
    }
}

/// At the nodes of the medium, the order-0 radiance is the node radiance of
/// `internal_field` (the same streams; the probe at a node cosine
/// integrates the source function that the node's own equation solves:
/// only rounding of the two groupings of the adding and of the node cosine
/// passed through degrees: measured 1.1e-10 of the largest radiance, at the
/// interface between the layers; bound 1e-9). Fourier order 0 only
/// (`max_fourier_order = 0`) under a beam; diffuse light; index steps.
/// The discrete-ordinate radiance is compared (`radiance - correction`:
/// the single-scattering correction is not in the node radiances), and the
/// beams, not yet scattered where a layer is corrected, with those of the
/// same stack without delta-M (true optical depths).
#[test]
fn node_directions_equal_the_node_radiances() {
    let mut worst = 0.0f64;
    let scenes = [
        "[light]\ntheta_deg = 30.0\n[[layer]]\nsigma_a = 0.2\nsigma_s = 1.0\nthickness = 0.5\n\
         g = 0.6\nn = 1.5\n[[layer]]\nsigma_a = 0.05\nsigma_s = 2.0\nthickness = 1.0\ng = 0.2\n\
         n = 1.3\n[substrate]\nkind = \"transparent\"\nn = 1.2\n",
        "[light]\nkind = \"diffuse\"\n[[layer]]\nsigma_a = 0.2\nsigma_s = 2.0\nthickness = 1.0\n\
         g = 0.5\nn = 1.4\n[substrate]\nkind = \"lambertian\"\nalbedo = 0.5\n",
    ];
    for (k, t) in scenes.iter().enumerate() {
        let s = scene(t);
        let ch = &s.channels()[0];
        let o =
            MultifluxOptions { streams: Some(8), max_fourier_order: Some(0), ..Default::default() };
        let total: f64 = ch.layers().iter().map(|l| l.thickness()).sum();
        for z in [0.0, 0.3, 0.5, 0.9, 1.5].map(|z: f64| z.min(total)) {
            let f = internal_field(ch, &o, z, 0).unwrap();
            let mut dirs = Vec::new();
            for &mu in &f.mu {
                let t = mu.acos().to_degrees();
                dirs.push([t, 0.0]);
                dirs.push([180.0 - t, 0.0]);
            }
            let r = inside_radiance(ch, &o, &[z], &dirs).unwrap();
            let ordinates: Vec<f64> =
                r.radiance[0].iter().zip(&r.correction[0]).map(|(v, c)| v - c).collect();
            let scale = f.down.iter().chain(&f.up).fold(0.0f64, |a, b| a.max(b.abs()));
            for i in 0..f.mu.len() {
                let pairs = [(ordinates[2 * i], f.down[i]), (ordinates[2 * i + 1], f.up[i])];
                for (got, want) in pairs {
                    worst = worst.max((got - want).abs() / scale);
                    assert!(
                        (got - want).abs() < 1e-9 * scale,
                        "scene {k}, z {z}, node {i}: {got} vs {want}"
                    );
                }
            }
            let clear = MultifluxOptions { delta_m: false, ..o.clone() };
            let f = internal_field(ch, &clear, z, 0).unwrap();
            assert!((r.beam_down[0] - f.beam_down).abs() < 1e-12);
            assert!((r.beam_up[0] - f.beam_up).abs() < 1e-12);
        }
    }
    eprintln!("worst node difference {worst:e} of the largest radiance");
}

/// `integral I mu dw` plus the beams is the net flux `F(z)` and `integral I
/// dw` plus the beams' `F / mu_b` the fluence `phi(z)` of the depth profile,
/// with Gauss–Legendre in `mu` on each hemisphere and the trapezoidal rule
/// in azimuth (exact for the cosine series of fewer orders than points),
/// each hemisphere split at the critical cosines of the medium (where the
/// radiance jumps). The quadrature error is measured: with 16 and 32 points
/// per piece, the 32-point integral must lie within the difference of the
/// two of the reference (the error falls by 7-8 per doubling) and within
/// 2e-5 of it.
#[test]
fn angular_integrals_give_flux_and_fluence() {
    let scenes: [(&str, f64); 2] = [
        (
            "[light]\ntheta_deg = 30.0\n[[layer]]\nsigma_a = 0.2\nsigma_s = 1.0\nthickness = 0.5\n\
          g = 0.6\nn = 1.5\n[[layer]]\nsigma_a = 0.05\nsigma_s = 2.0\nthickness = 1.0\n\
          g = 0.2\nn = 1.3\n[substrate]\nkind = \"transparent\"\nn = 1.2\n",
            30.0,
        ),
        (
            "[light]\nkind = \"diffuse\"\n[[layer]]\nsigma_a = 0.2\nsigma_s = 2.0\n\
          thickness = 1.0\ng = 0.5\nn = 1.4\n[substrate]\nkind = \"lambertian\"\n\
          albedo = 0.5\n",
            0.0,
        ),
    ];
    for (k, (t, theta)) in scenes.iter().enumerate() {
        let s = scene(t);
        let ch = &s.channels()[0];
        let o = MultifluxOptions { streams: Some(16), ..Default::default() };
        let depths = [0.0, 0.25, 0.5, 1.0, 1.5]
            .map(|z: f64| z.min(ch.layers().iter().map(|l| l.thickness()).sum()));
        let prof = DepthField::new(ch, &o).unwrap().profile(&depths).unwrap();
        let mut got = Vec::new();
        for nq in [16usize, 32] {
            let naz = 48;
            let (x, w) = gauss_legendre(nq);
            // Per depth its medium's critical cosines (the radiance jumps
            // there): Gauss–Legendre on each piece of [0, 1] between them.
            let mut per_depth = Vec::new();
            for z in depths {
                let nz = medium_at(ch, z);
                let mut cuts = vec![0.0, 1.0];
                for nj in indices(ch) {
                    if nj < nz {
                        cuts.push((1.0 - (nj / nz).powi(2)).sqrt());
                    }
                }
                cuts.sort_by(f64::total_cmp);
                cuts.dedup();
                let (mut dz, mut wz) = (Vec::new(), Vec::new());
                for c in cuts.windows(2) {
                    let (mid, half) = (0.5 * (c[0] + c[1]), 0.5 * (c[1] - c[0]));
                    for (xi, wi) in x.iter().zip(&w) {
                        let mu = mid + half * xi;
                        let t = mu.acos().to_degrees();
                        for a in 0..naz {
                            let phi = 360.0 * a as f64 / naz as f64;
                            let dw = half * wi * 2.0 * PI / naz as f64;
                            dz.push([t, phi]);
                            wz.push((dw, mu));
                            dz.push([180.0 - t, phi]);
                            wz.push((dw, -mu));
                        }
                    }
                }
                per_depth.push((dz, wz));
            }
            for (kz, z) in depths.iter().enumerate() {
                let (dirs, wts) = &per_depth[kz];
                let r = inside_radiance(ch, &o, &[*z], dirs).unwrap();
                let kz0 = kz;
                let kz = 0;
                let (mut fl, mut ph) = (r.beam_down[kz] - r.beam_up[kz], 0.0);
                let mu_b = {
                    let n = medium_at(ch, *z);
                    let s0 = theta.to_radians().sin();
                    (1.0f64 - (s0 / n).powi(2)).sqrt()
                };
                ph += (r.beam_down[kz] + r.beam_up[kz]) / mu_b;
                for (v, (dw, mu)) in r.radiance[kz].iter().zip(wts) {
                    fl += v * dw * mu;
                    ph += v * dw;
                }
                got.push((fl, ph));
                eprintln!(
                    "scene {k}, nq {nq}, z {z}: F {fl} vs {} ({:e}), phi {ph} vs {} ({:e})",
                    prof.net_flux[kz0],
                    fl - prof.net_flux[kz0],
                    prof.fluence[kz0],
                    ph - prof.fluence[kz0]
                );
            }
        }
        let nd = depths.len();
        for kz in 0..nd {
            let ((f16, p16), (f32, p32)) = (got[kz], got[nd + kz]);
            for (coarse, fine, want, what) in
                [(f16, f32, prof.net_flux[kz], "F"), (p16, p32, prof.fluence[kz], "phi")]
            {
                let err = (fine - want).abs();
                assert!(
                    err <= (coarse - fine).abs() && err <= 2e-5 * want.abs(),
                    "scene {k}, depth {}: {what} {fine} vs {want} (16 points: {coarse})",
                    depths[kz]
                );
            }
        }
    }
}

/// The refractive index of the medium at depth `z` (the layer above at an interface).
fn medium_at(ch: &km_core::MonoScene, z: f64) -> f64 {
    let mut top = 0.0;
    for l in ch.layers() {
        if z <= top + l.thickness() {
            return l.n();
        }
        top += l.thickness();
    }
    ch.layers().last().unwrap().n()
}

/// Every refractive index of the scene (ambient, layers, a clear substrate).
fn indices(ch: &km_core::MonoScene) -> Vec<f64> {
    let mut v = vec![ch.ambient_n()];
    v.extend(ch.layers().iter().map(|l| l.n()));
    if let km_core::Substrate::Transparent { n } = ch.substrate() {
        v.push(n);
    }
    v
}

/// A clear absorbing slab (no scattering, matched indices) on a Lambertian
/// floor of albedo 0.6 under a beam at 40 degrees: inside, the down-going
/// diffuse radiance is 0, the up-going one is the floor's
/// `rho exp(-sigma_a D / mu0) / pi` attenuated along the path to the floor,
/// `exp(-sigma_a (D - z) / |mu|)`, at every angle and azimuth, and the beam
/// is Beer–Lambert's (exact; rounding only, 1e-12).
#[test]
fn clear_slab_on_a_lambertian_floor_is_exact() {
    let s = scene(
        "[light]\ntheta_deg = 40.0\n[[layer]]\nsigma_a = 0.7\nsigma_s = 0.0\nthickness = 1.3\n\
         [substrate]\nkind = \"lambertian\"\nalbedo = 0.6\n",
    );
    let ch = &s.channels()[0];
    let (sa, d, rho) = (0.7f64, 1.3f64, 0.6f64);
    let mu0 = 40f64.to_radians().cos();
    let dirs = [[10.0, 0.0], [100.0, 0.0], [135.0, 70.0], [170.0, 180.0], [179.0, 10.0]];
    let depths = [0.0, 0.4, 1.0, 1.3];
    for streams in [4, 16] {
        let o = MultifluxOptions { streams: Some(streams), ..Default::default() };
        let r = inside_radiance(ch, &o, &depths, &dirs).unwrap();
        for (k, &z) in depths.iter().enumerate() {
            assert!((r.beam_down[k] - (-sa * z / mu0).exp()).abs() < 1e-12);
            for (j, dir) in dirs.iter().enumerate() {
                let mu = dir[0].to_radians().cos();
                let want = if mu > 0.0 {
                    0.0
                } else {
                    rho * (-sa * d / mu0).exp() / PI * (-sa * (d - z) / mu.abs()).exp()
                };
                let got = r.radiance[k][j];
                assert!(
                    (got - want).abs() < 1e-12,
                    "{streams} streams, z {z}, {dir:?}: {got} vs {want}"
                );
            }
        }
    }
}

/// Requests the function refuses, with the reason.
#[test]
fn bad_requests_are_refused() {
    let s = scene("[[layer]]\ntau = 1.0\nalbedo = 0.5\n");
    let ch = &s.channels()[0];
    let o = MultifluxOptions::default();
    for (depths, dirs) in [
        (vec![], vec![[0.0, 0.0]]),
        (vec![0.5], vec![]),
        (vec![2.0], vec![[0.0, 0.0]]),
        (vec![f64::NAN], vec![[0.0, 0.0]]),
        (vec![0.5], vec![[90.0, 0.0]]),
        (vec![0.5], vec![[181.0, 0.0]]),
        (vec![0.5], vec![[10.0, f64::INFINITY]]),
    ] {
        assert!(inside_radiance(ch, &o, &depths, &dirs).is_err(), "{depths:?} {dirs:?}");
    }
}

/// The single-scattering correction inside (docs/field.md eq. D17) in one
/// layer of matched index (nothing reflects): at depth `z` the down-going
/// correction is the lone-layer formula of `PeakCorrection::radiance` for
/// the layer above `z` (scaled optical thickness `tau*(z)`), the up-going
/// one that of the layer below `z` lit by the beam left at `z`,
/// `exp(-tau*(z)/mu_b)` (eq. C2 and 14 of docs/multiflux.md, the same path
/// integrals in closed form: 1e-12 of the largest value allows rounding
/// only), the peak's second order (eq. D18, eq. 5b–5d there) included
/// within its cone. HG g = 0.9 at 8 streams (16 moments kept, f =
/// 0.9^16), a beam at 30 degrees, directions on both sides of the plane of
/// incidence (the beam's own among them, where the peak makes the
/// correction large and the second order applies); the beam is the
/// unscattered one, `exp(-sigma_t z / mu_b)`.
#[test]
fn single_scattering_correction_equals_the_lone_layer_formula() {
    let s = scene(
        "[light]\ntheta_deg = 30.0\n[[layer]]\nsigma_a = 0.1\nsigma_s = 2.0\nthickness = 1.0\n\
         g = 0.9\n",
    );
    let ch = &s.channels()[0];
    let o = MultifluxOptions { streams: Some(8), ..Default::default() };
    // 22 and 38 degrees inside the second order's 10-degree cone, 45
    // outside it (not on its edge, where the term switches off).
    let dirs = [
        [30.0, 180.0],
        [22.0, 180.0],
        [38.0, 180.0],
        [45.0, 180.0],
        [35.0, 60.0],
        [140.0, 0.0],
        [160.0, 180.0],
    ];
    let depths = [0.0, 0.4, 1.0];
    let r = inside_radiance(ch, &o, &depths, &dirs).unwrap();
    let (omega, sigma_t) = (2.0 / 2.1, 2.1);
    let c = km_multiflux::correction::PeakCorrection::new(
        km_core::phase::Phase::henyey_greenstein(0.9).unwrap(),
        omega,
        16,
        true,
    );
    let factor = 1.0 - omega * c.f();
    let mu_b = 30f64.to_radians().cos();
    let mut largest = 0.0f64;
    let mut worst = 0.0f64;
    for (k, &z) in depths.iter().enumerate() {
        let (above, below) = (factor * sigma_t * z, factor * sigma_t * (1.0 - z));
        assert!((r.beam_down[k] - (-sigma_t * z / mu_b).exp()).abs() < 1e-12, "z {z}");
        assert_eq!(r.beam_up[k], 0.0);
        for (j, d) in dirs.iter().enumerate() {
            let mu_x = d[0].to_radians().cos().abs();
            let want = if d[0] < 90.0 {
                c.radiance(mu_b, mu_x, d[1], above).1
            } else {
                (-above / mu_b).exp() * c.radiance(mu_b, mu_x, d[1], below).0
            };
            let got = r.correction[k][j];
            largest = largest.max(want.abs());
            worst = worst.max((got - want).abs());
            eprintln!("z {z} {d:?}: {got:.6e} vs {want:.6e}");
        }
    }
    assert!(largest > 1.0, "the correction must matter here: {largest}");
    assert!(worst <= 1e-12 * largest, "worst {worst:e} of {largest:e}");
}
