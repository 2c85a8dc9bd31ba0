//! The scene file's phase functions and particles (docs/scene-file.md):
//! every kind, per-channel values, and the refusals, each naming its key.

use km_core::mie::{Complex, Particles, SizeDistribution, particle_optics};
use km_core::phase::{Phase, PhaseFunction};
use km_core::{CoreError, Scene};

fn scene(t: &str) -> Scene {
    Scene::from_toml_str(t).unwrap_or_else(|e| panic!("{e}\n{t}"))
}

fn refusal(t: &str) -> (String, String) {
    match Scene::from_toml_str(t) {
        Err(CoreError::Scene { key, message, .. }) => (key, message),
        other => panic!("expected a scene error, got {other:?}\n{t}"),
    }
}

fn layer(phase: &str) -> String {
    format!("[[layer]]\ntau = 1.0\nalbedo = 0.9\n{phase}\n")
}

#[test]
fn every_kind_parses() {
    let p = |t: &str| scene(&layer(t)).channels()[0].layers()[0].phase().clone();
    assert_eq!(p("g = 0.5"), Phase::henyey_greenstein(0.5).unwrap());
    assert_eq!(p("phase = { kind = \"hg\", g = 0.5 }"), Phase::henyey_greenstein(0.5).unwrap());
    assert_eq!(p("phase = { kind = \"isotropic\" }"), Phase::Isotropic);
    let t = p("phase = { kind = \"two-term-hg\", g1 = 0.9, g2 = -0.3, weight = 0.8 }");
    assert!((t.g() - (0.72 - 0.06)).abs() < 1e-15 && t.kind() == "two-term-hg");
    let r = p("phase = { kind = \"rayleigh\" }");
    assert_eq!(r.legendre_moment(2), 0.1);
    let r = p("phase = { kind = \"rayleigh\", depolarisation = 0.0279 }");
    assert!((r.legendre_moment(2) - 0.9721 / (5.0 * 2.0279)).abs() < 1e-15);
    let rm = p("phase = { kind = \"reynolds-mccormick\", g = 0.8, alpha = 0.5 }");
    assert!((rm.g() - 0.8).abs() < 1e-12, "alpha = 1/2 is HG: {}", rm.g());
    let l = p("phase = { kind = \"legendre\", moments = [0.7, 0.5, 0.3] }");
    assert_eq!((l.kind(), l.legendre_moment(3), l.legendre_moment(4)), ("legendre", 0.3, 0.0));
    let tab = p("phase = { kind = \"table\", theta_deg = [0, 90, 180], p = [3, 1, 1] }");
    assert_eq!(tab.kind(), "table");
    assert!((tab.eval(1.0) / tab.eval(0.0) - 3.0).abs() < 1e-12);
    let tab2 = p("phase = { kind = \"table\", cos_theta = [1, 0, -1], p = [3, 1, 1] }");
    for c in [-1.0, -0.3, 0.0, 0.5, 1.0] {
        assert!((tab.eval(c) - tab2.eval(c)).abs() < 1e-15, "{c}");
    }
}

/// A sub-table `[layer.phase]` is the same as the inline table.
#[test]
fn sub_table_form() {
    let a = scene(
        "[[layer]]\ntau = 1\nalbedo = 0.9\n[layer.phase]\nkind = \"two-term-hg\"\ng1 = 0.9\ng2 = -0.2\nweight = 0.7\n",
    );
    let b = scene(&layer("phase = { kind = \"two-term-hg\", g1 = 0.9, g2 = -0.2, weight = 0.7 }"));
    assert_eq!(a, b);
}

/// Per-channel values: scalar lists and one moment list per channel.
#[test]
fn per_channel_values() {
    let s = scene(&layer(
        "phase = { kind = \"two-term-hg\", g1 = [0.9, 0.8], g2 = -0.3, weight = 0.8 }",
    ));
    assert_eq!(s.channels().len(), 2);
    let s = scene(&layer(
        "phase = { kind = \"legendre\", moments = [[0.5, 0.2], [0.6, 0.3], [0.7, 0.4]] }",
    ));
    assert_eq!(s.channels().len(), 3);
    assert_eq!(s.channels()[2].layers()[0].g(), 0.7);
    let (key, msg) = refusal(&format!(
        "{}[[layer]]\ntau = 1\nalbedo = 0.5\ng = [0.1, 0.2]\n",
        layer("phase = { kind = \"legendre\", moments = [[0.5], [0.6], [0.7]] }")
    ));
    assert!(key.contains("g") && msg.contains("list of 2 values"), "{key}: {msg}");
}

#[test]
fn refusals_name_their_key() {
    let cases: &[(&str, &str, &str)] = &[
        ("g = 0.5\nphase = { kind = \"rayleigh\" }", "layer[1].g", "not both"),
        ("phase = { kind = \"mie\" }", "layer[1].phase.kind", "unknown kind"),
        ("phase = { kind = \"hg\", g = 0.5, h = 1 }", "layer[1].phase.h", "unknown key"),
        (
            "phase = { kind = \"two-term-hg\", g1 = 0.9, g2 = 0.1 }",
            "layer[1].phase.weight",
            "missing",
        ),
        ("phase = { kind = \"hg\", g = 1.0 }", "layer[1].phase.g", "|g| < 1"),
        (
            "phase = { kind = \"legendre\", moments = [0.5, 1.5] }",
            "layer[1].phase.moments",
            "|chi_l| <= 1",
        ),
        (
            "phase = { kind = \"table\", cos_theta = [1, 0.5], p = [1, 1] }",
            "layer[1].phase.p",
            "span",
        ),
        (
            "phase = { kind = \"table\", cos_theta = [1, -1], p = [1, -1] }",
            "layer[1].phase.p",
            ">= 0",
        ),
        (
            "phase = { kind = \"table\", cos_theta = [1, -1], theta_deg = [0, 180], p = [1, 1] }",
            "layer[1].phase.theta_deg",
            "not both",
        ),
        ("phase = \"rayleigh\"", "layer[1].phase", "expected a table"),
    ];
    for (t, key, words) in cases {
        let (k, m) = refusal(&layer(t));
        assert_eq!(&k, key, "{t}: {m}");
        assert!(m.contains(words), "{t}: {m}");
    }
    let (k, m) = refusal("[[layer]]\npreset = \"marble\"\nphase = { kind = \"rayleigh\" }\n");
    assert_eq!(k, "layer[1].phase", "{m}");
}

const PAINT: &str = "[spectrum]\nwavelengths_nm = [450, 550, 650]\n[[layer]]\nthickness = 20.0\nsigma_a = 0.001\nn = 1.5\n";

/// A layer of particles: sigma_s and sigma_a from Mie theory per channel
/// (eq. M14), the host's absorption scaled by the volume it keeps (eq. M18).
#[test]
fn particles_give_the_layer_its_optics() {
    let s = scene(&format!(
        "{PAINT}particles = {{ radius_um = 0.12, n = [2.8, 2.7, 2.65], k = 0.0, volume_fraction = 0.2 }}\n"
    ));
    for (ch, (wl, n)) in [(450.0, 2.8), (550.0, 2.7), (650.0, 2.65)].iter().enumerate() {
        let l = &s.channels()[ch].layers()[0];
        let p = Particles {
            index: Complex::new(*n, 0.0),
            volume_fraction: 0.2,
            distribution: SizeDistribution::Mono { radius_um: 0.12 },
        };
        let o = particle_optics(&p, 1.5, *wl).unwrap();
        assert_eq!(l.sigma_s(), o.sigma_s);
        assert!((l.sigma_a() - 0.001 * 0.8).abs() < 1e-18, "{}", l.sigma_a());
        assert_eq!(l.phase().kind(), "mie");
        assert!((l.g() - o.g).abs() < 1e-15);
    }
}

/// Two populations: sigma_s adds, the phase function is their
/// sigma_s-weighted mean (eq. M15); absorbing particles add sigma_a.
#[test]
fn populations_mix() {
    let one = "{ radius_um = 0.12, n = 2.7, volume_fraction = 0.15 }";
    let two = "{ radius_um = 0.05, n = 1.9, k = 0.4, volume_fraction = 0.01 }";
    let s = scene(&format!("{PAINT}particles = [{one}, {two}]\n"));
    let a = scene(&format!("{PAINT}particles = {one}\n"));
    let b = scene(&format!("{PAINT}particles = {two}\n"));
    let (l, la, lb) =
        (&s.channels()[1].layers()[0], &a.channels()[1].layers()[0], &b.channels()[1].layers()[0]);
    assert!((l.sigma_s() - la.sigma_s() - lb.sigma_s()).abs() < 1e-12 * l.sigma_s());
    let host = 0.001 * (1.0 - 0.16);
    let particles_a = (la.sigma_a() - 0.001 * 0.85) + (lb.sigma_a() - 0.001 * 0.99);
    assert!((l.sigma_a() - host - particles_a).abs() < 1e-12, "{}", l.sigma_a());
    let g = (la.sigma_s() * la.g() + lb.sigma_s() * lb.g()) / (la.sigma_s() + lb.sigma_s());
    assert!((l.g() - g).abs() < 1e-12);
}

#[test]
fn lognormal_by_sigma_or_gsd() {
    let a = scene(&format!(
        "{PAINT}particles = {{ n = 2.7, volume_fraction = 0.2, distribution = {{ lognormal = {{ median_um = 0.1, sigma = 0.3 }} }} }}\n"
    ));
    let b = scene(&format!(
        "{PAINT}particles = {{ n = 2.7, volume_fraction = 0.2, distribution = {{ lognormal = {{ median_um = 0.1, gsd = {} }} }} }}\n",
        0.3f64.exp()
    ));
    let (la, lb) = (&a.channels()[0].layers()[0], &b.channels()[0].layers()[0]);
    assert!((la.sigma_s() - lb.sigma_s()).abs() < 1e-12 * la.sigma_s());
}

#[test]
fn particle_refusals() {
    let cases: &[(&str, &str, &str)] = &[
        (
            "particles = { radius_um = 0.1, n = 2.7, volume_fraction = 1.2 }",
            "layer[1].particles.volume_fraction",
            "(0, 1)",
        ),
        (
            "particles = { n = 2.7, volume_fraction = 0.1 }",
            "layer[1].particles.radius_um",
            "missing",
        ),
        (
            "particles = { radius_um = 0.1, n = 2.7, volume_fraction = 0.1, shape = 1 }",
            "layer[1].particles.shape",
            "unknown key",
        ),
        (
            "particles = { radius_um = 0.1, n = 2.7, volume_fraction = 0.1, distribution = { lognormal = { median_um = 0.1, sigma = 0.3 } } }",
            "layer[1].particles.radius_um",
            "median",
        ),
        (
            "particles = { n = 2.7, volume_fraction = 0.1, distribution = { lognormal = { median_um = 0.1 } } }",
            "layer[1].particles.distribution.lognormal.sigma",
            "gsd",
        ),
        (
            "particles = { radius_um = 0.1, n = 2.7, k = -1, volume_fraction = 0.1 }",
            "layer[1].particles.k",
            ">= 0",
        ),
        (
            "particles = [{ radius_um = 0.1, n = 2.7, volume_fraction = 0.6 }, { radius_um = 0.1, n = 2.7, volume_fraction = 0.6 }]",
            "layer[1].particles[1]",
            "add up",
        ),
        (
            "sigma_s = 1.0\nparticles = { radius_um = 0.1, n = 2.7, volume_fraction = 0.1 }",
            "layer[1].sigma_s",
            "particles",
        ),
        (
            "particles = { radius_um = 5000.0, n = 2.7, volume_fraction = 0.1 }",
            "layer[1].particles",
            "size parameter",
        ),
    ];
    for (t, key, words) in cases {
        let (k, m) = refusal(&format!("{PAINT}{t}\n"));
        assert_eq!(&k, key, "{t}: {m}");
        assert!(m.contains(words), "{t}: {m}");
    }
    // Without wavelengths Mie theory has no size parameter.
    let (k, m) = refusal(
        "[[layer]]\nthickness = 1\nparticles = { radius_um = 0.1, n = 2.7, volume_fraction = 0.1 }\n",
    );
    assert!(k == "layer[1].particles" && m.contains("wavelengths_nm"), "{k}: {m}");
}

/// The tissue keys take a phase function with `mu_s` (kept, not dropped);
/// `mu_s_prime` needs `g` and is refused beside `phase`; particles refuse
/// the tissue keys and the file's `units` (their lengths are micrometres).
#[test]
fn tissue_keys_units_and_phase() {
    let s =
        scene("[[layer]]\nmu_a = 0.1\nmu_s = 10\nthickness = 1\nphase = { kind = \"rayleigh\" }\n");
    let l = &s.channels()[0].layers()[0];
    assert_eq!(l.phase().kind(), "rayleigh");
    assert!((l.sigma_s() - 10.0).abs() < 1e-12);
    let (key, msg) = refusal(
        "[[layer]]\nmu_a = 0.1\nmu_s_prime = 1\nthickness = 1\nphase = { kind = \"rayleigh\" }\n",
    );
    assert!(key.ends_with(".g") && msg.contains("mu_s_prime"), "{key}: {msg}");
    let particles = "particles = { radius_um = 0.5, n = 1.5, volume_fraction = 0.01 }";
    let (key, _) = refusal(&format!(
        "[spectrum]\nwavelengths_nm = [550]\n[[layer]]\nthickness = 10\nmu_a = 0.1\n{particles}\n"
    ));
    assert!(key.ends_with("mu_a"), "{key}");
    let (key, msg) = refusal(&format!(
        "units = \"mm\"\n[spectrum]\nwavelengths_nm = [550]\n[[layer]]\nthickness = 10\n{particles}\n"
    ));
    assert!(key.ends_with("particles") && msg.contains("units"), "{key}: {msg}");
}
