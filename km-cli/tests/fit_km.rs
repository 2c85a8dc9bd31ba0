//! `km fit --km`: the Kubelka–Munk inverse from the command line (the
//! computation is `km_inverse::drawdown`, tested there; here the flags,
//! the JSON keys, the plot and the refusals).

use std::process::Command;

use km_inverse::kubelka::{Saunderson, Specular, reflectance_over_ground};

fn km(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_km")).args(args).output().expect("run km")
}

fn km_json(args: &[&str]) -> serde_json::Value {
    let out = km(args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

fn stderr(args: &[&str]) -> String {
    let out = km(args);
    assert!(!out.status.success());
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Readings made by the forward model (km-core's two-flux adding), then
/// passed through Saunderson's surface as an instrument sees them, give the
/// film's K and S back (1e-12 in the library, km-inverse/tests/kubelka.rs;
/// 1e-9 here after the decimal round trip of the flags, 17 digits).
#[test]
fn black_white_readings_give_the_films_k_and_s() {
    let (k, s, x, n) = (0.3, 2.0, 0.5, 1.5);
    let c = Saunderson::fresnel(n, Specular::Included).unwrap();
    let read = |g: f64| {
        format!(
            "{:e}",
            c.measured_from_internal(reflectance_over_ground(k, s, x, g).unwrap()).unwrap()
        )
    };
    let (rb, rw) = (read(0.02), read(0.85));
    let args = [
        "fit",
        "--km",
        "--r-black",
        &rb,
        "--r-white",
        &rw,
        "--r-white-ground",
        "0.85",
        "--r-black-ground",
        "0.02",
        "--thickness",
        "0.5",
        "--n-sample",
        "1.5",
    ];
    let mut json_args = args.to_vec();
    json_args.push("--json");
    let v = km_json(&json_args);
    assert!((v["K"].as_f64().unwrap() - k).abs() < 1e-9, "{v}");
    assert!((v["S"].as_f64().unwrap() - s).abs() < 1e-9, "{v}");
    assert_eq!(v["mode"], "black_white");
    assert_eq!(v["uncertainty"]["u_reading"], 1e-3);
    assert!(v["saunderson"]["k1"].as_f64().unwrap() > 0.0);
    for key in ["K_over_S", "S_X", "R_inf", "R_inf_measured", "R_0", "T", "thickness"] {
        assert!(v[key].is_number(), "{key}");
    }
    let out = km(&args);
    assert!(out.status.success() && String::from_utf8_lossy(&out.stdout).contains("absorption K"));
}

#[test]
fn plot_draws_the_hiding_curves() {
    let (k, s, x) = (0.3, 2.0, 0.5);
    let (rb, rw) = (
        format!("{:e}", reflectance_over_ground(k, s, x, 0.0).unwrap()),
        format!("{:e}", reflectance_over_ground(k, s, x, 0.8).unwrap()),
    );
    let dir = std::env::temp_dir().join(format!("km-fit-km-plot-{}", std::process::id()));
    let d = dir.to_str().unwrap();
    let args = [
        "fit",
        "--km",
        "--r-black",
        &rb,
        "--r-white",
        &rw,
        "--r-white-ground",
        "0.8",
        "--thickness",
        "0.5",
        "--plot",
        d,
    ];
    let out = km(&args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = std::fs::read_to_string(dir.join("km-fit-km.svg")).unwrap();
    assert!(text.contains("<svg") && text.contains("R_inf"));
    assert!(std::fs::metadata(dir.join("km-fit-km.png")).unwrap().len() > 1000);
    std::fs::remove_dir_all(&dir).unwrap();
    // Only R_inf: nothing to draw, said so.
    let e = stderr(&["fit", "--km", "--r-inf", "0.5", "--plot", d]);
    assert!(e.contains("--plot needs K and S"), "{e}");
}

#[test]
fn r_inf_alone_gives_k_over_s_and_null_k_s() {
    let v = km_json(&["fit", "--km", "--r-inf", "0.5", "--json"]);
    // K/S = (1 - R)^2 / (2R) = 0.25 (Kubelka 1948, eq. I1).
    assert!((v["K_over_S"].as_f64().unwrap() - 0.25).abs() < 1e-15);
    assert!(v["K"].is_null() && v["S"].is_null());
}

#[test]
fn missing_and_conflicting_inputs_are_named() {
    let e = stderr(&["fit", "--km", "--r-black", "0.1"]);
    assert!(e.contains("--r-white"), "{e}");
    let e =
        stderr(&["fit", "--km", "--r-black", "0.1", "--r-white", "0.3", "--r-white-ground", "0.8"]);
    assert!(e.contains("--thickness"), "{e}");
    let e = stderr(&["fit", "--km", "--r-black", "0.1", "--r-inf", "0.3"]);
    assert!(e.contains("not both"), "{e}");
    let e = stderr(&["fit", "--km", "--r-inf", "0.3", "--k2", "0.6"]);
    // The binder's index is the flag --n-sample.
    assert!(e.contains("--k2 needs --n-sample (k1 "), "{e}");
    let e = stderr(&["fit", "--km", "--r-inf", "0.5", "--n-sample", "0.5"]);
    assert!(e.contains("--n-sample: invalid n = 0.5"), "{e}");
    let e = stderr(&["fit", "--km", "--r-zero", "0.3"]);
    assert!(e.contains("--r-zero needs --r-inf (the reflectance of the opaque film)"), "{e}");
    // Swapped readings: the library's message names r_black.
    let e = stderr(&[
        "fit",
        "--km",
        "--r-black",
        "0.5",
        "--r-white",
        "0.3",
        "--r-white-ground",
        "0.8",
        "--thickness",
        "1",
    ]);
    assert!(e.contains("r_black = 0.5"), "{e}");
    // A reading below the surface reflection, with --n-sample.
    let e = stderr(&["fit", "--km", "--r-inf", "0.01", "--n-sample", "1.5"]);
    assert!(e.contains("--r-inf") && e.contains("r_inf = 0.01"), "{e}");
}
