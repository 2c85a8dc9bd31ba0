//! `.rxt` rows that give M_R alone (iad's legend `1`, or columns without
//! `t`), fitted with a fixed quantity: `--fix-mu-s` (a number, or iad's
//! `-F` power laws `P L0 MU_S0 EXP` and `R L0 MU_SP0 EXP`), `--fix-mu-a`,
//! `--semi-infinite` (docs/inverse.md §7, eq. R1–R3).
//!
//! The rows are made by the forward model (`km_inverse::slab::model`, eq.
//! S2 of docs/inverse.md) at the set-up the file's header describes, from
//! known optical properties; the fit must give them back. The model is
//! evaluated at 64 streams and the fit told `--streams 64`, so the only
//! error is the bisection's and the printed digits: 1e-6 relative.

use std::process::Command;

use km_inverse::forward::Optical;
use km_inverse::rxt::parse_rxt;
use km_inverse::slab::model;
use serde_json::Value;

/// The phantom's header (examples/fit-phantom.rxt: one sphere, slides,
/// d = 1 mm), with the legend `L r`.
fn header() -> String {
    let text = include_str!("../../examples/fit-phantom.rxt");
    let head: Vec<&str> = text.lines().take_while(|l| !l.starts_with("L r t")).collect();
    format!("{}\nL r  # wavelength, M_R\n", head.join("\n"))
}

/// An `.rxt` file of M_R-only rows for `(wavelength, mu_a, mu_s, g)`.
fn file(rows: &[(f64, f64, f64, f64)], name: &str) -> std::path::PathBuf {
    let head = header();
    // The set-up of a row, as the reader builds it from the header.
    let probe = parse_rxt(&format!("{head}500 0.2\n")).unwrap();
    assert!(probe[0].reflectance_only);
    let setup = probe[0].setup;
    let d = setup.sample.thickness;
    let mut text = head;
    for &(w, mu_a, mu_s, g) in rows {
        let p = Optical { albedo: mu_s / (mu_a + mu_s), tau: (mu_a + mu_s) * d, g };
        let m = model(&setup, &p, 64).unwrap();
        text += &format!("{w} {:.12}\n", m[0]);
    }
    let dir = std::env::temp_dir().join(format!("km-fit-rows-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

fn km(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_km")).args(args).output().unwrap();
    let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
    (out.status.success(), text(&out.stdout), text(&out.stderr))
}

fn fitted(path: &std::path::Path, extra: &[&str]) -> Vec<Value> {
    let p = path.to_str().unwrap();
    let (ok, out, err) = km(&[&["fit", p, "--json", "--streams", "64"][..], extra].concat());
    assert!(ok, "{err}");
    serde_json::from_str::<Value>(&out).unwrap().as_array().unwrap().clone()
}

fn close(got: f64, want: f64, what: &str) {
    assert!((got - want).abs() <= 1e-6 * want.abs(), "{what}: {got} vs {want}");
}

#[test]
fn a_fixed_mu_s_gives_back_mu_a_row_by_row() {
    let rows = [(500.0, 0.2, 1.8, 0.0), (600.0, 0.1, 1.8, 0.0), (700.0, 0.02, 1.8, 0.0)];
    let fits = fitted(&file(&rows, "same.rxt"), &["--fix-mu-s", "1.8"]);
    for (f, &(w, mu_a, _, _)) in fits.iter().zip(&rows) {
        assert_eq!(f["wavelength_nm"].as_f64(), Some(w));
        close(f["mu_a"].as_f64().unwrap(), mu_a, "mu_a");
        assert!(f["notes"].to_string().contains("reflectance only"), "{f}");
    }
}

#[test]
fn iad_power_laws_fix_mu_s_or_mu_s_prime_at_each_wavelength() {
    // mu_s = 2 (lambda / 500)^-1.3 (iad -F 'P 500 2 -1.3').
    let law = |w: f64| 2.0 * (w / 500.0f64).powf(-1.3);
    let rows: Vec<_> = [(450.0, 0.3), (550.0, 0.1), (650.0, 0.05)]
        .iter()
        .map(|&(w, a)| (w, a, law(w), 0.0))
        .collect();
    let fits = fitted(&file(&rows, "p.rxt"), &["--fix-mu-s", "P 500 2 -1.3"]);
    for (f, r) in fits.iter().zip(&rows) {
        close(f["mu_a"].as_f64().unwrap(), r.1, "mu_a (P law)");
        close(f["mu_s"].as_f64().unwrap(), r.2, "mu_s (P law)");
    }
    // mu_s' = 1 (lambda / 500)^-1.3 at g = 0.5 (iad -F 'R 500 1 -1.3'): mu_s = mu_s' / 0.5.
    let g = 0.5;
    let rows: Vec<_> = [(450.0, 0.3), (650.0, 0.05)]
        .iter()
        .map(|&(w, a)| (w, a, 0.5 * law(w) / (1.0 - g), g))
        .collect();
    let fits = fitted(&file(&rows, "r.rxt"), &["--fix-mu-s", "R 500 1 -1.3", "--g", "0.5"]);
    for (f, r) in fits.iter().zip(&rows) {
        close(f["mu_a"].as_f64().unwrap(), r.1, "mu_a (R law)");
    }
}

#[test]
fn the_reflectance_only_rows_agree_with_the_fit_of_m_r_and_m_t() {
    // The phantom's first row fitted from M_R and M_T gives (mu_a, mu_s);
    // its M_R alone with mu_s fixed there must give the same mu_a: two
    // different searches of one model, agreeing to the R + T fit's own
    // convergence (1e-3 relative, as in fit_flags.rs).
    let phantom = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/fit-phantom.rxt");
    let (ok, out, err) = km(&["fit", phantom, "--json"]);
    assert!(ok, "{err}");
    let both: Value = serde_json::from_str(&out).unwrap();
    let (mu_a, mu_s) = (both[0]["mu_a"].as_f64().unwrap(), both[0]["mu_s"].as_f64().unwrap());
    let m_r = include_str!("../../examples/fit-phantom.rxt")
        .lines()
        .find(|l| l.starts_with("500 "))
        .and_then(|l| l.split_whitespace().nth(1))
        .unwrap()
        .to_string();
    let dir = std::env::temp_dir().join(format!("km-fit-rows-x-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("one.rxt");
    std::fs::write(&path, format!("{}500 {m_r}\n", header())).unwrap();
    let (ok, out, err) =
        km(&["fit", path.to_str().unwrap(), "--json", "--fix-mu-s", &mu_s.to_string()]);
    assert!(ok, "{err}");
    let r: Value = serde_json::from_str(&out).unwrap();
    let got = r[0]["mu_a"].as_f64().unwrap();
    assert!((got - mu_a).abs() < 1e-3 * mu_a, "{got} vs {mu_a}");
}

#[test]
fn reflectance_only_rows_without_a_fixed_quantity_and_bad_laws_are_refused() {
    let path = file(&[(500.0, 0.2, 1.8, 0.0)], "refuse.rxt");
    let p = path.to_str().unwrap();
    let (ok, out, err) = km(&["fit", p]);
    assert!(!ok && out.contains("M_R alone") && out.contains("--fix-mu-s"), "{out} {err}");
    // A fixed quantity with a file whose rows all give M_T.
    let phantom = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/fit-phantom.rxt");
    let (ok, _, err) = km(&["fit", phantom, "--semi-infinite"]);
    assert!(!ok && err.contains("gives M_T too"), "{err}");
    // A power law needs wavelengths: refused for --m-r.
    let (ok, _, err) =
        km(&["fit", "--m-r", "0.3", "--thickness", "1", "--fix-mu-s", "P 500 1 -1.3"]);
    assert!(!ok && err.contains("power law needs wavelengths"), "{err}");
    for bad in ["Q 500 1 -1.3", "P 500 1", "P 0 1 -1.3", "P 500 -1 -1.3", "P 500 1 nan", "x"] {
        let (ok, _, err) = km(&["fit", p, "--fix-mu-s", bad]);
        assert!(!ok && err.contains("--fix-mu-s"), "{bad}: {err}");
    }
}
