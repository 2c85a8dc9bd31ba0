//! `km fit` refuses every flag that does not apply to its mode (`--km`,
//! the slab inverse of `--m-r`/`--m-t`, an `.rxt` file, a `.csv` file),
//! naming the flag and the mode, before any fit: one test per flag.

use std::process::Command;

fn km(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_km")).args(args).output().unwrap();
    (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
}

const RXT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/fit-synthetic.rxt");
const CSV: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/fit-spectrum.csv");

/// The base command of each mode (valid on its own).
fn base(mode: &str) -> Vec<&'static str> {
    match mode {
        "km" => vec!["fit", "--km", "--r-inf", "0.6"],
        "slab" => vec!["fit", "--m-r", "0.2726", "--m-t", "0.2991", "--thickness", "1"],
        "rxt" => vec!["fit", RXT],
        "csv" => vec!["fit", CSV, "--thickness", "1"],
        _ => unreachable!(),
    }
}

fn assert_refused(mode: &str, extra: &[&str], flag: &str, mode_words: &str) {
    let mut args = base(mode);
    args.extend_from_slice(extra);
    let (ok, err) = km(&args);
    assert!(!ok, "{args:?} was accepted");
    assert!(err.contains(flag) && err.contains("does not apply to"), "{args:?}: {err}");
    assert!(err.contains(mode_words), "{args:?}: {err}");
}

macro_rules! refused {
    ($($name:ident: $mode:literal, [$($extra:literal),*], $flag:literal, $words:literal;)*) => {
        $(
            #[test]
            fn $name() {
                assert_refused($mode, &[$($extra),*], $flag, $words);
            }
        )*
    };
}

refused! {
    km_refuses_m_r: "km", ["--m-r", "0.2"], "--m-r", "--km";
    km_refuses_m_t: "km", ["--m-t", "0.2"], "--m-t", "--km";
    km_refuses_m_u: "km", ["--m-u", "0.1"], "--m-u", "--km";
    km_refuses_sigma_r: "km", ["--sigma-r", "0.01"], "--sigma-r", "--km";
    km_refuses_sigma_t: "km", ["--sigma-t", "0.01"], "--sigma-t", "--km";
    km_refuses_sigma_u: "km", ["--sigma-u", "0.01"], "--sigma-u", "--km";
    km_refuses_n_slide: "km", ["--n-slide", "1.5"], "--n-slide", "--km";
    km_refuses_g: "km", ["--g", "0.5"], "--g", "--km";
    km_refuses_specular_in_m_r: "km", ["--specular-in-m-r", "0.5"], "--specular-in-m-r", "--km";
    km_refuses_unscattered_in_m_t: "km", ["--unscattered-in-m-t", "0.5"], "--unscattered-in-m-t", "--km";
    km_refuses_exclude_specular: "km", ["--exclude-specular"], "--exclude-specular", "--km";
    km_refuses_exclude_unscattered: "km", ["--exclude-unscattered"], "--exclude-unscattered", "--km";
    km_refuses_incidence: "km", ["--incidence", "8"], "--incidence", "--km";
    km_refuses_streams: "km", ["--streams", "16"], "--streams", "--km";
    km_refuses_a_file: "km", ["examples/fit-synthetic.rxt"], "a measurement file", "--km";
    slab_refuses_r_black: "slab", ["--r-black", "0.3"], "--r-black", "slab inverse";
    slab_refuses_r_white: "slab", ["--r-white", "0.5"], "--r-white", "slab inverse";
    slab_refuses_r_white_ground: "slab", ["--r-white-ground", "0.8"], "--r-white-ground", "slab inverse";
    slab_refuses_r_black_ground: "slab", ["--r-black-ground", "0.01"], "--r-black-ground", "slab inverse";
    slab_refuses_plot: "slab", ["--plot", "out"], "--plot", "slab inverse";
    slab_refuses_r_inf: "slab", ["--r-inf", "0.6"], "--r-inf", "slab inverse";
    slab_refuses_r_zero: "slab", ["--r-zero", "0.3"], "--r-zero", "slab inverse";
    slab_refuses_k2: "slab", ["--k2", "0.6"], "--k2", "slab inverse";
    rxt_refuses_thickness: "rxt", ["--thickness", "2"], "--thickness", ".rxt file";
    rxt_refuses_n_sample: "rxt", ["--n-sample", "1.33"], "--n-sample", ".rxt file";
    rxt_refuses_n_slide: "rxt", ["--n-slide", "1.5"], "--n-slide", ".rxt file";
    rxt_refuses_incidence: "rxt", ["--incidence", "8"], "--incidence", ".rxt file";
    rxt_refuses_m_r: "rxt", ["--m-r", "0.2"], "--m-r", ".rxt file";
    rxt_refuses_k2: "rxt", ["--k2", "0.6"], "--k2", ".rxt file";
    csv_refuses_m_t: "csv", ["--m-t", "0.3"], "--m-t", ".csv spectrum";
    csv_refuses_r_inf: "csv", ["--r-inf", "0.6"], "--r-inf", ".csv spectrum";
    rxt_refuses_spheres: "rxt", ["--spheres", "1"], "--spheres", ".rxt file";
    rxt_refuses_r_sphere: "rxt", ["--r-sphere", "200", "25", "12", "1", "0.98"], "--r-sphere", ".rxt file";
    rxt_refuses_t_sphere: "rxt", ["--t-sphere", "200", "25", "12", "1", "0.98"], "--t-sphere", ".rxt file";
    rxt_refuses_r_std: "rxt", ["--r-std", "0.98"], "--r-std", ".rxt file";
    km_refuses_spheres: "km", ["--spheres", "1"], "--spheres", "--km";
    csv_refuses_fix_mu_s: "csv", ["--fix-mu-s", "1.8"], "--fix-mu-s", ".csv spectrum";
    csv_refuses_fix_mu_a: "csv", ["--fix-mu-a", "0.2"], "--fix-mu-a", ".csv spectrum";
    km_refuses_semi_infinite: "km", ["--semi-infinite"], "--semi-infinite", "--km";
}

#[test]
fn flags_of_the_mode_are_accepted() {
    // The same flags in the mode they belong to run (exit 0).
    let mut slab = base("slab");
    slab.extend(["--sigma-r", "0.001", "--exclude-specular", "--streams", "16", "--g", "0.1"]);
    let (ok, err) = km(&slab);
    assert!(ok, "{err}");
    let (ok, err) = km(&[&base("km")[..], &["--thickness", "0.05", "--r-zero", "0.3"]].concat());
    assert!(ok, "{err}");
    let (ok, err) = km(&[&base("rxt")[..], &["--sigma-r", "0.001", "--streams", "8"]].concat());
    assert!(ok, "{err}");
}

#[test]
fn every_example_of_km_fit_help_exists_and_runs() {
    // The examples of `km fit --help` (km-cli/help/fit.txt), run from the
    // workspace root as written: every file they name exists, every one exits 0.
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/..");
    let help = include_str!("../help/fit.txt");
    let examples: Vec<&str> = help.lines().filter_map(|l| l.trim().strip_prefix("km ")).collect();
    assert!(examples.len() >= 5, "{help}");
    for ex in examples {
        let args: Vec<&str> = ex.split_whitespace().collect();
        for a in args.iter().filter(|a| a.starts_with("examples/")) {
            assert!(std::path::Path::new(root).join(a).is_file(), "{a} of `km {ex}` is missing");
        }
        let out = Command::new(env!("CARGO_BIN_EXE_km")).args(&args).current_dir(root).output();
        let out = out.unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "`km {ex}` failed: {err}");
        assert!(!out.stdout.is_empty(), "`km {ex}` printed nothing");
    }
}

#[test]
fn a_one_sphere_file_says_what_it_does_not_model_and_where_u_comes_from() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/..");
    let out = Command::new(env!("CARGO_BIN_EXE_km"))
        .args(["fit", "examples/fit-phantom.rxt"])
        .current_dir(root)
        .output()
        .unwrap();
    assert!(out.status.success());
    let table = String::from_utf8_lossy(&out.stdout);
    for words in [
        "lost light is not modelled",
        "beam diameter of the file is not used",
        "u(mu_s')",
        "1/length",
        "default measurement uncertainty 1e-4",
    ] {
        assert!(table.contains(words), "{words:?} missing from\n{table}");
    }
    // The file's rows were made by the measurement model at the albedos of
    // its comments (0.9, 0.95, 0.99; b = 2): the fit recovers them to the
    // stream rule's accuracy (docs/inverse.md eq. I7; 1e-4 is ample).
    let out = Command::new(env!("CARGO_BIN_EXE_km"))
        .args(["fit", "examples/fit-phantom.rxt", "--json", "--sigma-r", "0.002"])
        .current_dir(root)
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for (row, a) in v.as_array().unwrap().iter().zip([0.9, 0.95, 0.99]) {
        assert!((row["albedo"].as_f64().unwrap() - a).abs() < 1e-4, "{row}");
        assert_eq!(row["uncertainty"]["sigma_given"], true, "{row}");
        let notes = row["notes"].to_string();
        assert!(notes.contains("lost light"), "{notes}");
    }
}

#[test]
fn spheres_on_the_command_line_fit_like_the_rxt_header() {
    // Row 1 of examples/fit-phantom.rxt, its header's spheres given as iad's
    // -1 on the command line: the same answer as the file (a = 0.9, b = 2).
    let args = [
        "fit",
        "--m-r",
        "0.23847235",
        "--m-t",
        "0.31190634",
        "--thickness",
        "1",
        "--n-sample",
        "1.4",
        "--n-slide",
        "1.5",
        "--spheres",
        "1",
        "--r-sphere",
        "200",
        "25",
        "12",
        "1",
        "0.98",
        "--r-std",
        "0.98",
        "--json",
    ];
    let out = Command::new(env!("CARGO_BIN_EXE_km")).args(args).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    // The measurement model made the row at 64 streams: recovered to 1e-4.
    assert!((v["albedo"].as_f64().unwrap() - 0.9).abs() < 1e-4, "{v}");
    assert!((v["tau"].as_f64().unwrap() - 2.0).abs() < 1e-3, "{v}");
    assert!(v["notes"].to_string().contains("lost light is not modelled"), "{v}");
    // Without the spheres the same numbers mean another sample.
    let bare = Command::new(env!("CARGO_BIN_EXE_km")).args(&args[..11]).arg("--json").output();
    let w: serde_json::Value = serde_json::from_slice(&bare.unwrap().stdout).unwrap();
    assert!((w["albedo"].as_f64().unwrap() - 0.9).abs() > 1e-3, "{w}");
}

#[test]
fn sphere_flags_need_each_other() {
    let slab = base("slab");
    let (ok, err) = km(&[&slab[..], &["--spheres", "1"]].concat());
    assert!(!ok && err.contains("--r-sphere"), "{err}");
    let (ok, err) = km(&[&slab[..], &["--r-sphere", "200", "25", "12", "1", "0.98"]].concat());
    assert!(!ok && err.contains("--spheres 1 or 2"), "{err}");
    let (ok, err) = km(&[&slab[..], &["--spheres", "3"]].concat());
    assert!(!ok && err.contains("--spheres"), "{err}");
    // A port larger than the sphere is refused by the sphere's own check.
    let (ok, err) =
        km(&[&slab[..], &["--spheres", "1", "--r-sphere", "200", "500", "12", "1", "0.98"]]
            .concat());
    assert!(!ok && (err.contains("d_sample") || err.contains("port")), "{err}");
}

fn json_of(args: &[&str]) -> serde_json::Value {
    let out = Command::new(env!("CARGO_BIN_EXE_km")).args(args).output().unwrap();
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn a_reflectance_only_fit_with_a_fixed_quantity_agrees_with_the_two_measurement_fit() {
    // The R + T fit of the help example gives mu_a and mu_s (Marquardt in
    // (a, b)); holding either at that value, M_R alone must give the other
    // back (bisection in one unknown, eq. R1): two different searches of
    // the same model, agreeing to the R + T fit's own convergence (its
    // residual within 1e-4 of M_R, M_T: about 1e-4 relative here).
    let sample = ["--thickness", "1", "--n-sample", "1.4", "--n-slide", "1.5", "--json"];
    let both = json_of(&[&["fit", "--m-r", "0.2726", "--m-t", "0.2991"][..], &sample].concat());
    let (mu_a, mu_s) = (both["mu_a"].as_f64().unwrap(), both["mu_s"].as_f64().unwrap());
    let (a, s) = (format!("{mu_a}"), format!("{mu_s}"));
    let r = json_of(&[&["fit", "--m-r", "0.2726", "--fix-mu-s", &s][..], &sample].concat());
    assert!((r["mu_a"].as_f64().unwrap() - mu_a).abs() < 1e-3 * mu_a, "{r} vs {both}");
    assert!(r["uncertainty"]["mu_a"].as_f64().unwrap() > 0.0, "{r}");
    let r = json_of(&[&["fit", "--m-r", "0.2726", "--fix-mu-a", &a][..], &sample].concat());
    assert!((r["mu_s"].as_f64().unwrap() - mu_s).abs() < 1e-3 * mu_s, "{r} vs {both}");
    assert!(r["notes"].to_string().contains("reflectance only"), "{r}");
}

#[test]
fn a_reflectance_only_fit_is_refused_where_m_r_does_not_determine_it() {
    let slab = ["fit", "--m-r", "0.2726", "--thickness", "1"];
    let (ok, err) = km(&slab);
    assert!(!ok && err.contains("--fix-mu-s"), "{err}");
    let (ok, err) = km(&[&slab[..], &["--fix-mu-s", "1.8", "--fix-mu-a", "0.2"]].concat());
    assert!(!ok && err.contains("one of"), "{err}");
    let (ok, err) = km(&[&slab[..], &["--m-t", "0.3", "--semi-infinite"]].concat());
    assert!(!ok && err.contains("reflectance-only"), "{err}");
    // With mu_s = 1.8 over d = 1 no mu_a gives M_R = 0.9 (the range is named).
    let (ok, err) = km(&["fit", "--m-r", "0.9", "--thickness", "1", "--fix-mu-s", "1.8"]);
    assert!(!ok && err.contains("does not determine mu_a") && err.contains('['), "{err}");
}
