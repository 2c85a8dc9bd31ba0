//! `km fit`: the JSON contract (docs/inverse.md §6) and its refusals.

use std::process::Command;

fn km(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_km")).args(args).output().expect("run km")
}

/// The row a = 0.9, b = 1 of examples/fit-synthetic.rxt (km's model at 64
/// streams): the fit returns it within the 1e-4 measurement uncertainty's
/// effect (u(a) ~ 1e-4, u(b) ~ 1e-3) and every contract key.
#[test]
fn json_contract() {
    let out = km(&[
        "fit",
        "--m-r",
        "0.23515730",
        "--m-t",
        "0.51524373",
        "--thickness",
        "2",
        "--n-sample",
        "1.4",
        "--n-slide",
        "1.5",
        "--json",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for k in ["albedo", "tau", "g", "mu_a", "mu_s", "mu_s_prime", "status", "uncertainty"] {
        assert!(!v[k].is_null(), "missing {k}");
    }
    for k in ["albedo", "tau", "g", "mu_a", "mu_s", "mu_s_prime"] {
        assert!(v["uncertainty"][k].is_number(), "uncertainty.{k}");
    }
    assert_eq!(v["status"], "converged");
    assert!((v["albedo"].as_f64().unwrap() - 0.9).abs() < 1e-4);
    assert!((v["tau"].as_f64().unwrap() - 1.0).abs() < 1e-3);
    // mu in 1/length of --thickness 2: mu_a = (1 - a) b / d = 0.05.
    assert!((v["mu_a"].as_f64().unwrap() - 0.05).abs() < 1e-4);
    assert!((v["fitted"]["m_r"].as_f64().unwrap() - 0.23515730).abs() < 1e-8);
}

#[test]
fn spectrum_file_is_a_list_with_wavelengths() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/fit-spectrum.csv");
    let out =
        km(&["fit", path, "--thickness", "1", "--n-sample", "1.4", "--n-slide", "1.5", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let list = v.as_array().unwrap();
    assert_eq!(list.len(), 3);
    assert_eq!(list[1]["wavelength_nm"], 600.0);
    assert!((list[2]["albedo"].as_f64().unwrap() - 0.99).abs() < 1e-4);
}

#[test]
fn refusals_name_the_problem() {
    let out = km(&["fit", "--m-r", "0.3", "--m-t", "0.4"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--thickness"));
    let out = km(&["fit", "--m-r", "1.3", "--m-t", "0.4", "--thickness", "1"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("m_r = 1.3"));
    // Kubelka–Munk flags without --km.
    let out = km(&["fit", "--m-r", "0.3", "--m-t", "0.4", "--thickness", "1", "--r-black", "0.2"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--r-black does not apply") && err.contains("--km"), "{err}");
}
