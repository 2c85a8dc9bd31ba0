//! Phase functions other than Henyey–Greenstein against converged DISORT
//! (tests/data/phase_disort.json: cdisort 2.1.3 at 256 streams with every
//! Legendre moment and its intensity correction, written by
//! km-bench/scripts/phase_disort.py): a Rayleigh layer, a two-term
//! Henyey–Greenstein tissue layer and a water cloud of Mie droplets
//! (effective radius 10 um at 550 nm, ~1070 moments from miepython).
//!
//! The solver is compared on DISORT's own inputs: the cloud as a `legendre`
//! layer with the reference's moments, albedo and optical thickness. km's
//! Mie theory (the scene's `particles`) is compared separately with the
//! reference's moments, within the size quadrature's own uncertainty: for
//! these nearly lossless droplets (k = 2e-9) the ripple structure makes the
//! trapezoidal sum over radii converge slowly (miepython: g moves by 5.6e-5
//! from 2401 to 9601 radii; km stops at its work bound with a change of
//! 5e-5 in the cross sections).

use km_core::Scene;
use km_multiflux::{MultifluxOptions, solve};
use serde_json::Value;

/// The light's polar angle of every case.
const THETA0_DEG: f64 = 30.0;

fn data() -> Value {
    let path = format!("{}/tests/data/phase_disort.json", env!("CARGO_MANIFEST_DIR"));
    let d: Value =
        serde_json::from_str(&std::fs::read_to_string(path).expect("data")).expect("json");
    assert_eq!(f(&d["theta0_deg"]), THETA0_DEG);
    d
}

fn f(v: &Value) -> f64 {
    v.as_f64().expect("number")
}

/// The km scene of a case on DISORT's inputs: the cloud as a layer of the
/// reference's optical thickness, albedo and Legendre moments.
fn case_scene(c: &Value) -> Scene {
    let text = c["scene"].as_str().unwrap();
    if !text.contains("THICKNESS") {
        return Scene::from_toml_str(text).unwrap();
    }
    let moments: Vec<String> =
        c["moments"].as_array().unwrap()[1..].iter().map(|m| format!("{:e}", f(m))).collect();
    let layer = format!(
        "[[layer]]\ntau = {}\nalbedo = {}\nphase = {{ kind = \"legendre\", moments = [{}] }}\n",
        f(&c["tau"]),
        f(&c["albedo"]),
        moments.join(", ")
    );
    let start = text.find("[spectrum]").unwrap();
    let end = text.find("[output]").unwrap();
    Scene::from_toml_str(&format!("{}{layer}{}", &text[..start], &text[end..])).unwrap()
}

/// The km scene of the cloud by its `particles`: the thickness
/// (micrometres) set so that km's own extinction gives DISORT's optical
/// thickness.
fn particle_scene(c: &Value) -> Scene {
    let text = c["scene"].as_str().unwrap().replace("THICKNESS", "1.0");
    let unit = Scene::from_toml_str(&text).unwrap();
    let mono = &unit.channels()[0];
    let layer = &mono.layers()[0];
    let layer = layer.with_thickness(f(&c["tau"]) / layer.sigma_t()).unwrap();
    unit.with_channels(vec![mono.with_layers(vec![layer]).unwrap()]).unwrap()
}

/// Directions within this angle of the transmitted beam form the forward
/// lobe (below).
const LOBE_DEG: f64 = 15.0;

/// `(worst total error, worst radiance relative error outside the forward
/// lobe, worst inside it)` of one case on DISORT's inputs.
fn errors(c: &Value, opts: &MultifluxOptions) -> (f64, f64, f64) {
    errors_of(&case_scene(c), c, opts)
}

/// The errors of `scene` against case `c`, as [`errors`].
fn errors_of(scene: &Scene, c: &Value, opts: &MultifluxOptions) -> (f64, f64, f64) {
    let s = solve(scene, opts).unwrap();
    let ch = &s.channels[0];
    let total = (ch.reflectance - f(&c["reflectance"]))
        .abs()
        .max((ch.transmittance - f(&c["transmittance"])).abs());
    let dirs = scene.channels()[0].directions_deg();
    let t0 = THETA0_DEG.to_radians();
    let (mut out, mut lobe) = (0.0f64, 0.0f64);
    for r in c["radiances"].as_array().unwrap() {
        let (th, ph, side, want) = (f(&r[0]), f(&r[1]), r[2].as_str().unwrap(), f(&r[3]));
        let i = dirs.iter().position(|d| d[0] == th && d[1] == ph).expect("direction");
        let got = if side == "r" { ch.brdf[i] } else { ch.btdf[i] };
        let e = (got - want).abs() / want.abs();
        // Angle from the transmitted beam (which travels at azimuth 180).
        let (t, p) = (th.to_radians(), ph.to_radians());
        let cos = t.cos() * t0.cos() - t.sin() * t0.sin() * p.cos();
        if side == "t" && cos.clamp(-1.0, 1.0).acos().to_degrees() < LOBE_DEG {
            lobe = lobe.max(e);
        } else {
            out = out.max(e);
        }
    }
    (total, out, lobe)
}

/// At the default settings each case meets the solver's documented target
/// (docs/multiflux.md §8: every BRDF/BTDF value within 1 %), and the
/// totals are within 1e-4 (the DISORT references' own agreement with the
/// adding-doubling references of tests/data).
///
/// The 1 % holds at all 30 directions of every case, the cloud's forward
/// lobe (transmitted directions within 15 degrees of the beam, 2 of its 30)
/// included: that is the target of the cloud's forward lobe (the solver's
/// 1 % for every BRDF/BTDF value, there too). It needs the truncation of
/// eq. 4b of docs/multiflux.md (the cloud keeps `3N/2` moments): with
/// Wiscombe's `2N` the lobe is off by 1.8 % at the default 32 streams
/// (docs/phase.md §4–§5), as DISORT's at the same streams
/// (`lobe_equals_disort_at_equal_streams`). Measured: printed by the test
/// (docs/phase.md §5).
#[test]
fn default_settings_meet_the_bounds() {
    let d = data();
    for c in d["cases"].as_array().unwrap() {
        let name = c["name"].as_str().unwrap();
        let (total, rad, lobe) = errors(c, &MultifluxOptions::default());
        eprintln!("{name}: totals {total:.2e}, worst radiance {rad:.2e}, forward lobe {lobe:.2e}");
        assert!(total < 1e-4, "{name}: totals off by {total:.2e}");
        assert!(rad < 0.01, "{name}: a radiance off by {:.2} %", 100.0 * rad);
        assert!(lobe < 0.01, "{name}: forward lobe off by {:.2} %", 100.0 * lobe);
    }
}

/// km's own Mie theory end to end (the scene's `particles`, about 10 s:
/// `cargo test -p km-multiflux --test phase_disort -- --ignored`): the
/// moments are those the DISORT run took from miepython within the size
/// quadrature's uncertainty (module comment: chi_1 = g differs by 9e-5
/// between the two quadratures; 3e-4 allows for it), the albedo within
/// 5e-8 (1 - omega: km 4.41e-7, the reference 4.71e-7 from its coefficient
/// sums, miepython's efficiencies 4.39e-7 at 2401 radii and 4.30e-7 at
/// 9601: the quadrature's spread), and the totals and radiances
/// move accordingly: within 1e-3 (a change of 1e-4 in g moves R by about
/// 1e-4 here) and, outside the forward lobe, 3 %.
#[test]
#[ignore]
fn cloud_by_particles() {
    let d = data();
    let c = &d["cases"].as_array().unwrap()[2];
    let scene = particle_scene(c);
    let layer = &scene.channels()[0].layers()[0];
    let km = layer.phase().stored_moments().unwrap();
    let want: Vec<f64> = c["moments"].as_array().unwrap().iter().map(f).collect();
    let (mut worst, mut at) = (0.0f64, 0);
    for l in 0..want.len().min(km.len()) {
        if (km[l] - want[l]).abs() > worst {
            (worst, at) = ((km[l] - want[l]).abs(), l);
        }
    }
    let omega = (layer.albedo() - f(&c["albedo"])).abs();
    let (total, rad, lobe) = errors_of(&scene, c, &MultifluxOptions::default());
    eprintln!(
        "cloud by particles: worst moment {worst:.2e} at l = {at}, albedo {omega:.1e}, totals \
         {total:.2e}, radiance {rad:.2e}, forward lobe {lobe:.2e}"
    );
    assert!(worst < 3e-4, "chi_{at}: off by {worst:.2e}");
    assert!(omega < 5e-8, "albedo {} vs {}", layer.albedo(), c["albedo"]);
    assert!(total < 1e-3 && rad < 0.03, "totals {total:.2e}, radiance {rad:.2e}");
}

/// The convergence of the three cases with the streams (table of
/// docs/phase.md §5): totals / radiances outside the lobe / in the lobe.
/// Slow: `cargo test -p km-multiflux --test phase_disort -- --ignored --nocapture`.
#[test]
#[ignore]
fn convergence_table() {
    let d = data();
    for n in [8usize, 16, 24, 32, 48, 64, 96] {
        let o = MultifluxOptions { streams: Some(n), ..Default::default() };
        let row: Vec<String> = d["cases"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| {
                let (t, r, l) = errors(c, &o);
                format!("{}: {t:.1e} / {r:.1e} / {l:.1e}", c["name"].as_str().unwrap())
            })
            .collect();
        eprintln!("N = {n:3}: {}", row.join(" | "));
    }
}

/// The cloud's forward lobe against DISORT at the solver's own stream count
/// (tests/data/phase_disort_streams.json, written by
/// km-bench/scripts/phase_disort_streams.py: cdisort 2.1.3 at NSTR = 2N with
/// the Nakajima–Tanaka correction, ten transmitted directions 2 to 25 degrees
/// from the beam). km at `N` streams reproduces DISORT at `2N` within 1e-4
/// (measured: at most 1.1e-6 relative), at every `N` and direction, including
/// the points 5 degrees from the beam where both move by up to 10 % between
/// the stream counts of the data: the lobe error of docs/phase.md §4 is the method's
/// (delta-M, the discrete ordinates and the TMS/IMS correction, the same in
/// both), not km's implementation of it. Both keep `2N` moments here
/// (`peak_truncation: false`: Wiscombe's delta-M for every layer, DISORT's).
/// 1e-4: the two solve the same
/// discrete equations (eq. 5–5e of docs/multiflux.md, DISORT's
/// `c_intensity_correction`); the bound leaves room for the rounding of the
/// two eigen-solvers, ten orders of magnitude above double precision but far
/// below the 1e-2 differences between successive `N` it is meant to resolve.
#[test]
fn lobe_equals_disort_at_equal_streams() {
    let d = data();
    let cloud = &d["cases"].as_array().unwrap()[2];
    let path = format!("{}/tests/data/phase_disort_streams.json", env!("CARGO_MANIFEST_DIR"));
    let s: Value =
        serde_json::from_str(&std::fs::read_to_string(path).expect("data")).expect("json");
    assert_eq!(f(&s["theta0_deg"]), THETA0_DEG);
    let dirs: Vec<String> = s["lobe"]
        .as_array()
        .unwrap()
        .iter()
        .map(|l| format!("[{:.15}, {:.15}]", f(&l["theta_deg"]), f(&l["phi_deg"])))
        .collect();
    let moments: Vec<String> =
        cloud["moments"].as_array().unwrap()[1..].iter().map(|m| format!("{:e}", f(m))).collect();
    let scene = Scene::from_toml_str(&format!(
        "[light]\ntheta_deg = {THETA0_DEG}\n[[layer]]\ntau = {}\nalbedo = {}\nphase = {{ kind = \
         \"legendre\", moments = [{}] }}\n[output]\ndirections_deg = [{}]\n",
        f(&cloud["tau"]),
        f(&cloud["albedo"]),
        moments.join(", "),
        dirs.join(", ")
    ))
    .unwrap();
    let mut worst = 0.0f64;
    for run in s["runs"].as_array().unwrap() {
        let n = run["streams"].as_u64().unwrap() as usize;
        let o = MultifluxOptions { streams: Some(n), peak_truncation: false, ..Default::default() };
        let got = solve(&scene, &o).unwrap().channels[0].btdf.clone();
        for (g, w) in got.iter().zip(run["nakajima_tanaka"].as_array().unwrap()) {
            let rel = (g / f(w) - 1.0).abs();
            worst = worst.max(rel);
            assert!(rel < 1e-4, "N = {n}: {g} vs DISORT {}", f(w));
        }
    }
    eprintln!("forward lobe, km at N against DISORT at 2N streams: worst {worst:.1e}");
}

/// The truncation rule of eq. 4b (docs/multiflux.md) keeps the cloud's `3N/2`
/// moments wherever its kept lobe matters (measured: the rule holds for the
/// cloud from `N = 5` to 112, every default and table stream count of
/// docs/phase.md) and leaves every Henyey–Greenstein layer on Wiscombe's
/// `2N`: one term of `|g| <= 0.95` and two terms of `|g1|, |g2| <= 0.95`
/// (steps of 0.05, weights 0.1..0.9) at every stream count 1..=64, by the
/// moments `km_core` gives (as a `legendre` layer holding them would: the
/// solver asks the rule for phase functions given as data only). The HG side
/// is a proof in `kept_moments`'s documentation; this checks it on the
/// moments themselves.
#[test]
fn truncation_rule_separates_the_cloud_from_henyey_greenstein() {
    use km_core::phase::{Phase, PhaseFunction};
    use km_multiflux::legendre::kept_moments;
    let d = data();
    let cloud: Vec<f64> =
        d["cases"].as_array().unwrap()[2]["moments"].as_array().unwrap().iter().map(f).collect();
    for n in 8..=96 {
        assert_eq!(kept_moments(|l| cloud[l], n), 3 * n / 2, "cloud at N = {n}");
    }
    let gs: Vec<f64> = (-19..=19).map(|i| f64::from(i) * 0.05).collect();
    let mut phases = Vec::new();
    for &g in &gs {
        phases.push(Phase::henyey_greenstein(g).unwrap());
        for &g2 in &gs {
            for w in 1..=9 {
                let toml = format!(
                    "[[layer]]\ntau = 1.0\nalbedo = 0.9\nphase = {{ kind = \"two-term-hg\", g1 = \
                     {g}, g2 = {g2}, weight = {} }}\n",
                    f64::from(w) * 0.1
                );
                let s = Scene::from_toml_str(&toml).unwrap();
                phases.push(s.channels()[0].layers()[0].phase().clone());
            }
        }
    }
    for p in &phases {
        for n in 1..=64 {
            assert_eq!(kept_moments(|l| p.legendre_moment(l), n), 2 * n, "{p:?} at N = {n}");
        }
    }
}
