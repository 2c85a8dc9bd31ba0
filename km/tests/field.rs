//! The depth field of `km::field`: multi-flux phi(z) and A(z) against Monte
//! Carlo's depth bins on six scenes, against diffusion and transport theory
//! deep in a diffusive half-space, and the request's errors.

use km::field::{FieldMethod, FieldOptions, field};
use km::{McOptions, Method, MultifluxOptions};
use km_core::Scene;
use km_montecarlo::depth::{DepthQuantity, depth_field};
use km_multiflux::depth::DepthField;

fn scene(t: &str) -> Scene {
    Scene::from_toml_str(t).unwrap()
}

/// Six scenes: index steps (top and between layers), g from 0 to 0.95,
/// oblique incidence, a Lambertian substrate, three layers. Each with its
/// bin width (every interface on a bin edge) and bin count (down to the
/// bottom of the stack).
const SCENES: [(&str, f64, usize); 6] = [
    ("[[layer]]\nsigma_a = 0.5\nsigma_s = 2.0\ng = 0.0\nn = 1.4\nthickness = 2.0\n", 0.2, 10),
    (
        "[light]\ntheta_deg = 30.0\n[[layer]]\nsigma_a = 0.3\nsigma_s = 4.0\ng = 0.5\nn = 1.5\n\
         thickness = 1.0\n[substrate]\nkind = \"transparent\"\nn = 1.2\n",
        0.1,
        10,
    ),
    ("[[layer]]\nsigma_a = 0.2\nsigma_s = 10.0\ng = 0.9\nn = 1.37\nthickness = 1.0\n", 0.1, 10),
    ("[[layer]]\nsigma_a = 0.1\nsigma_s = 20.0\ng = 0.95\nn = 1.33\nthickness = 1.0\n", 0.1, 10),
    (
        "[[layer]]\nsigma_a = 0.4\nsigma_s = 3.0\ng = 0.7\nn = 1.4\nthickness = 1.0\n\
         [substrate]\nkind = \"lambertian\"\nalbedo = 0.8\n",
        0.1,
        10,
    ),
    (
        "[[layer]]\nsigma_a = 1.0\nsigma_s = 5.0\ng = 0.8\nn = 1.5\nthickness = 0.4\n\
         [[layer]]\nsigma_a = 0.2\nsigma_s = 8.0\ng = 0.3\nn = 1.3\nthickness = 0.6\n\
         [[layer]]\nsigma_a = 0.5\nsigma_s = 2.0\ng = 0.0\nn = 1.45\nthickness = 0.4\n",
        0.1,
        14,
    ),
];

/// The z-scores `(mc - mf) / se` of phi and A in every bin but the first,
/// the multi-flux reference averaged over each bin (8-point Gauss–Legendre).
fn z_scores(text: &str, dz: f64, nz: usize, samples: u64, streams: usize) -> Vec<f64> {
    let s = scene(text);
    let mc = depth_field(&s, &McOptions { samples, ..Default::default() }, dz, nz).unwrap();
    let mo = MultifluxOptions { streams: Some(streams), ..Default::default() };
    let mf = DepthField::new(&s.channels()[0], &mo).unwrap();
    let total = mf.thickness();
    let at = |z: f64, q: usize| {
        let p = mf.profile(&[z.min(total)]).unwrap();
        if q == 0 { p.fluence[0] } else { p.absorbed[0] }
    };
    let mut out = mc.z_scores(0, DepthQuantity::Phi, |z| at(z, 0))[1..].to_vec();
    out.extend(&mc.z_scores(0, DepthQuantity::A, |z| at(z, 1))[1..]);
    out
}

/// Every bin but the first within 4 standard errors on all six scenes, at
/// 20,000 photons (a few seconds; the standard errors are 1-3 % of the
/// values, while the 24-stream multi-flux field is converged far below
/// that). 4 is the family-wise bound of the ~130 scores: for a false alarm
/// in 1 % of seeds each may exceed its bound with probability 0.01 / 130,
/// |z| < 3.95 (Bonferroni); a bound of 3 on every score fails for an
/// unbiased tracer in about one seed in six (measured: 2 of 12 seeds, worst
/// |z| 3.12 and 3.03). The run's seed is fixed, so the test is
/// deterministic; the sum of squares bounds a bias hiding under the bound:
/// mean z^2 below 2 (its expectation is 1 for an unbiased tracer; phi and A
/// of one bin carry the same photons, so the scores are correlated).
#[test]
fn multiflux_phi_and_a_match_monte_carlo() {
    let mut all = Vec::new();
    for (k, (t, dz, nz)) in SCENES.iter().enumerate() {
        let zs = z_scores(t, *dz, *nz, 20_000, 24);
        let worst = zs.iter().fold(0.0f64, |m, z| m.max(z.abs()));
        eprintln!("scene {k}: worst |z| {worst:.2}");
        assert!(zs.iter().all(|z| z.is_finite()), "scene {k}: {zs:?}");
        assert!(worst < 4.0, "scene {k}: {zs:?}");
        all.extend(zs);
    }
    let chi2 = all.iter().map(|z| z * z).sum::<f64>() / all.len() as f64;
    eprintln!("mean z^2 over {} scores: {chi2:.2}", all.len());
    assert!(chi2 < 2.0, "{chi2}");
}

/// The same at 10^6 photons (standard errors 0.1-0.4 %): the multi-flux field
/// at 48 streams stays within 3 sigma in every bin but the first, and the
/// mean z^2 below 2. About a minute on one core:
/// `cargo test -p km --test field -- --ignored`.
#[test]
#[ignore]
fn multiflux_phi_and_a_match_monte_carlo_at_a_million_photons() {
    let mut all = Vec::new();
    for (k, (t, dz, nz)) in SCENES.iter().enumerate() {
        let zs = z_scores(t, *dz, *nz, 1_000_000, 48);
        let worst = zs.iter().fold(0.0f64, |m, z| m.max(z.abs()));
        eprintln!("scene {k}: worst |z| {worst:.2}");
        assert!(worst < 4.0, "scene {k}: {zs:?}");
        all.extend(zs);
    }
    let chi2 = all.iter().map(|z| z * z).sum::<f64>() / all.len() as f64;
    eprintln!("mean z^2 over {} scores: {chi2:.2}", all.len());
    assert!(chi2 < 2.0, "{chi2}");
}

/// Deep in a diffusive half-space (isotropic, albedo 1/1.01) phi decays as
/// the slowest transport mode `exp(-k sigma_t z)`, with `k` the root of
/// Case's equation `(omega / 2k) ln((1 + k)/(1 - k)) = 1`: the multi-flux
/// decay rate between 10 and 16 diffusion lengths matches it to 1e-6 (16
/// streams resolve the slowest mode; its higher modes have died out by
/// e^-60). Diffusion's `mu_eff = sqrt(3 sigma_a sigma_t')` is within
/// 1 % (its own error at this albedo is about 0.4 (1 - omega) relative).
#[test]
fn deep_field_decays_as_diffusion_and_transport_say() {
    let (sa, ss) = (0.01, 1.0);
    let s = scene(&format!(
        "[[layer]]\nsigma_a = {sa}\nsigma_s = {ss}\nthickness = \"inf\"\n[output]\n\
         depths = [60.0, 90.0]\n"
    ));
    let o = FieldOptions {
        multiflux: MultifluxOptions { streams: Some(16), ..Default::default() },
        ..Default::default()
    };
    let f = field(&s, None, &o).unwrap();
    let (p1, p2) = (f.fluence[0][0], f.fluence[0][1]);
    let rate = (p1 / p2).ln() / 30.0;
    let st = sa + ss;
    let omega = ss / st;
    // Case's equation by bisection on (0, 1).
    let g = |k: f64| omega / (2.0 * k) * ((1.0 + k) / (1.0 - k)).ln() - 1.0;
    let (mut lo, mut hi) = (1e-9, 1.0 - 1e-15);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if g(mid) > 0.0 { hi = mid } else { lo = mid }
    }
    let exact = 0.5 * (lo + hi) * st;
    let mu_eff = (3.0 * sa * st).sqrt();
    eprintln!("decay rate {rate:.8}, transport {exact:.8}, diffusion {mu_eff:.8}");
    assert!((rate / exact - 1.0).abs() < 1e-6, "{rate} vs {exact}");
    assert!((rate / mu_eff - 1.0).abs() < 0.01, "{rate} vs {mu_eff}");
    // And A = sigma_a phi.
    assert!((f.absorbed[0][0] - sa * p1).abs() < 1e-15 * p1.max(1.0));
}

#[test]
fn every_method_answers_or_refuses_with_the_reason() {
    let s = scene(
        "[[layer]]\nsigma_a = 0.3\nsigma_s = 3.0\ng = 0.5\nn = 1.4\nthickness = 1.0\n\
         [output]\ndepths = { step = 0.25, max = 1.0 }\n",
    );
    let o = |m| FieldOptions {
        method: FieldMethod(m),
        mc: McOptions { samples: 20_000, ..Default::default() },
        ..Default::default()
    };
    let mf = field(&s, None, &o(Method::Multiflux)).unwrap();
    let km = field(&s, None, &o(Method::Km)).unwrap();
    let mc = field(&s, None, &o(Method::Mc)).unwrap();
    for f in [&mf, &km, &mc] {
        assert_eq!(f.depths, vec![0.0, 0.25, 0.5, 0.75, 1.0]);
        assert_eq!(f.fluence[0].len(), 5);
        assert_eq!(f.absorptance_layers[0].len(), 1);
    }
    assert!(mc.stderr.is_some() && mf.stderr.is_none());
    // The layer absorptance of multi-flux and Monte Carlo agree: at 2e4
    // photons the binomial standard error of a fraction near 0.4 is 0.0035,
    // so 0.02 is above 5 se; the two-flux one is another model, not compared.
    let (a_mf, a_mc) = (mf.absorptance_layers[0][0], mc.absorptance_layers[0][0]);
    assert!((a_mf - a_mc).abs() < 0.02, "{a_mf} vs {a_mc}");
    let e = field(&s, None, &o(Method::DirectionSet)).unwrap_err().to_string();
    assert!(e.contains("no depth-resolved field"), "{e}");
    // The dipole's field is that of a half-space: a slab is refused, as
    // `km solve --method dipole` refuses it.
    let e = field(&s, None, &o(Method::Dipole)).unwrap_err().to_string();
    assert!(e.contains("semi-infinite"), "{e}");
    let e = field(&s, Some(&[]), &o(Method::Multiflux)).unwrap_err().to_string();
    assert!(e.contains("[output] depths"), "{e}");
    for m in [Method::Multiflux, Method::Km, Method::Mc] {
        let e = field(&s, Some(&[1.5]), &o(m)).unwrap_err().to_string();
        assert!(e.contains("stack"), "{m}: {e}");
        assert!(field(&s, Some(&[-1.0]), &o(m)).is_err());
    }
}
