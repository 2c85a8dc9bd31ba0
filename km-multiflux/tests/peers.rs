//! The peers' own test problems (tests/data/peer_suites.json): DISORT's
//! DISOTEST cases (cdisort 2.1.3 "correct answers") and Prahl's adding-doubling
//! tests, each with repository, path and commit in the data file.

mod common;
use common::{data, run};
use serde_json::Value;

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap()
}

/// DISOTEST 1a-1f, 3a-3b, 6a-6c, 8a-8c (isotropic and Henyey-Greenstein
/// phase functions, one or two layers, beam or isotropic illumination, black
/// or Lambertian floor): fluxes at the top and bottom, and the radiances that
/// leave the medium at the user cosines and azimuths. Tolerance: 1e-3
/// relative (the cdisort regression tolerance named in the data), plus an
/// absolute floor of 1e-3 times the incident flux for radiances the test
/// prints with 6 digits. Cases 4 and 5 need DISORT's tabulated haze and cloud
/// phase functions (not Henyey–Greenstein) and are not run.
#[test]
fn disort_test_problems() {
    let d = data("peer_suites.json");
    let mut checked = 0;
    for c in d["cases"].as_array().unwrap() {
        let id = c["id"].as_str().unwrap();
        if !id.starts_with("DISOTEST-")
            || id.starts_with("DISOTEST-4")
            || id.starts_with("DISOTEST-5")
        {
            continue;
        }
        let inp = &c["inputs"];
        let exp = &c["expected"];
        let (fbeam, fisot, umu0) = (f(&inp["fbeam"]), f(&inp["fisot"]), f(&inp["umu0"]));
        let g = inp["phase"].get("gg").map_or(0.0, f);
        let albedo = inp["albedo"].as_f64().unwrap_or(0.0);
        let beam = fbeam > 0.0;
        let incident = if beam { fbeam * umu0 } else { std::f64::consts::PI * fisot };
        // Scene: layers; light; Lambertian floor or a clear (index-matched) half-space.
        let mut t = if beam {
            format!("[light]\ntheta_deg = {}\n", umu0.acos().to_degrees())
        } else {
            "[light]\nkind = \"diffuse\"\n".to_string()
        };
        let dtauc = inp["dtauc"].as_array().unwrap();
        let ssalb = inp["ssalb"].as_array().unwrap();
        for (tau, w) in dtauc.iter().zip(ssalb) {
            t += &format!("[[layer]]\ntau = {}\nalbedo = {}\ng = {g}\n", f(tau), f(w));
        }
        if albedo > 0.0 {
            t += &format!("[substrate]\nkind = \"lambertian\"\nalbedo = {albedo}\n");
        }
        // Exit directions (DISORT: umu > 0 is up-going): up-going at the top,
        // down-going at the bottom.
        let umu: Vec<f64> = inp["umu"].as_array().unwrap().iter().map(f).collect();
        let phis: Vec<f64> = inp["phi_deg"].as_array().unwrap().iter().map(f).collect();
        let mut dirs = Vec::new();
        for &p in &phis {
            for &u in &umu {
                // DISORT's phi - phi0 = 0 is the forward half-plane: our azimuth 180.
                dirs.push(format!("[{}, {}]", u.abs().acos().to_degrees(), 180.0 - p));
            }
        }
        t += &format!("[output]\ndirections_deg = [{}]\n", dirs.join(", "));
        // DISORT's NSTR counts both hemispheres: the same double-Gauss
        // discretisation is ours with N = NSTR / 2 per hemisphere.
        let nstr = inp["nstr"].as_u64().unwrap() as usize;
        let r = run(&t, nstr / 2);

        let utau = inp["utau"].as_array().unwrap();
        let last = utau.len() - 1;
        let tol = |x: f64, y: f64, floor: f64| (x - y).abs() <= 1e-3 * y.abs() + floor;
        // DISORT's single-scattering correction uses the phase function of its
        // NMOM Legendre moments, ours the exact Henyey–Greenstein function: at
        // worst (forward scattering) they differ by the relative tail
        // sum_{l>=NMOM} (2l+1) g^l / sum_l (2l+1) g^l, added to the radiance tolerance.
        let nmom = inp["nmom"].as_u64().unwrap() as i32;
        let total: f64 = (1.0 + g) / ((1.0 - g) * (1.0 - g));
        let head: f64 = (0..nmom).map(|l| (2 * l + 1) as f64 * g.powi(l)).sum();
        let tail_rel = if g == 0.0 { 0.0 } else { (total - head) / total };
        // For anisotropic cases DISORT's 16-stream intensities carry its own
        // intensity-correction error (about 1 %): the 2 % intensity tolerance
        // of the DISORT references in slabs.json applies there.
        let rel = if g == 0.0 { 1e-3 } else { 2e-2 };
        let tol_rad = |x: f64, y: f64| (x - y).abs() <= (rel + tail_rel) * y.abs() + 1e-6;
        let flup0 = f(&exp["flup"][0]) / incident;
        let r_diffuse = r.reflectance - r.reflectance_specular;
        assert!(tol(r_diffuse, flup0, 1e-6), "{id}: R {r_diffuse} vs {flup0}");
        if albedo == 0.0 {
            let t_ref = (f(&exp["rfldir"][last]) + f(&exp["rfldn"][last])) / incident;
            assert!(tol(r.transmittance, t_ref, 1e-6), "{id}: T {} vs {t_ref}", r.transmittance);
        }
        checked += 1;
        // Radiances: uu[phi][utau][umu]; ours per unit incident flux.
        let uu = &exp["uu[phi][utau][umu]"];
        for (ip, _) in phis.iter().enumerate() {
            for (iu, &u) in umu.iter().enumerate() {
                let k = ip * umu.len() + iu;
                let (ours, theirs) = if u > 0.0 {
                    (r.brdf[k], f(&uu[ip][0][iu]) / incident)
                } else if albedo == 0.0 {
                    (r.btdf[k], f(&uu[ip][last][iu]) / incident)
                } else {
                    continue;
                };
                assert!(tol_rad(ours, theirs), "{id} umu {u} phi {}: {ours} vs {theirs}", phis[ip]);
                checked += 1;
            }
        }
    }
    assert!(checked > 60, "{checked}");
}

/// Prahl's adding-doubling tests: the iad C library forward cases (16
/// quadrature points, tolerance 1e-4 as in the peer's test). iadpython's
/// 4-point cases are regression values of an unconverged calculation (the
/// data file says so): they are only printed, not asserted.
/// Glass slides are clear layers of their index (no absorption).
#[test]
fn adding_doubling_test_problems() {
    let d = data("peer_suites.json");
    let mut checked = 0;
    for c in d["cases"].as_array().unwrap() {
        let id = c["id"].as_str().unwrap();
        let inp = &c["inputs"];
        let (n, n_above, n_below, tol) = if id.starts_with("iad-C-basic_forward") {
            (f(&inp["n_slab"]), f(&inp["n_slide"]), f(&inp["n_slide"]), 1e-4)
        } else if id.starts_with("iadpython-test_ur1_uru") {
            (f(&inp["n"]), f(&inp["n_above"]), f(&inp["n_below"]), f64::INFINITY)
        } else {
            continue;
        };
        let tau = match &inp["b"] {
            Value::String(_) => "\"inf\"".to_string(),
            v => format!("{}", f(v)),
        };
        let (a, g) = (f(&inp["a"]), f(&inp["g"]));
        let mut layers = String::new();
        if n_above != 1.0 {
            layers += &format!("[[layer]]\ntau = 0.0\nalbedo = 0.0\nn = {n_above}\n");
        }
        layers += &format!("[[layer]]\ntau = {tau}\nalbedo = {a}\ng = {g}\nn = {n}\n");
        if n_below != 1.0 && tau != "\"inf\"" {
            layers += &format!("[[layer]]\ntau = 0.0\nalbedo = 0.0\nn = {n_below}\n");
        }
        let exp = &c["expected"];
        let rc = run(&format!("[light]\ntheta_deg = 0.0\n{layers}"), 24);
        let rd = run(&format!("[light]\nkind = \"diffuse\"\n{layers}"), 24);
        for (ours, key) in [
            (rc.reflectance, "ur1"),
            (rc.transmittance, "ut1"),
            (rd.reflectance, "uru"),
            (rd.transmittance, "utu"),
        ] {
            let theirs = f(&exp[key]);
            println!("{id} {key}: ours {ours:.6} peer {theirs:.6} diff {:+.2e}", ours - theirs);
            assert!((ours - theirs).abs() < tol, "{id} {key}: {ours} vs {theirs}");
            checked += tol.is_finite() as usize;
        }
    }
    assert_eq!(checked, 20);
}
