//! `km sweep` with the settings of `km solve` (the same flags, refused by
//! the same table `km::settings::SETTINGS`), its BRDF/BTDF columns and
//! standard errors, and its swept values printed as the decimals of the range.

use std::path::PathBuf;
use std::process::{Command, Output};

use serde_json::Value;

fn km(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_km")).args(args).output().expect("run km")
}

fn slab() -> String {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../examples/fresnel-slab.toml");
    p.to_string_lossy().into_owned()
}

/// Two exit directions: the BRDF and BTDF columns of the rows.
const DIRS: &str = "output.directions_deg=[[0,0],[30,180]]";

fn ok(out: &Output) -> String {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout.clone()).unwrap()
}

/// The JSONL rows of a sweep of `layer[1].g` over 0, 0.5 with `extra` flags.
fn sweep_rows(method: &str, extra: &[&str]) -> Vec<Value> {
    let s = slab();
    let mut a = vec!["sweep", &s, "--set", "layer[1].g=0:0.5:2", "--set", DIRS];
    a.extend(["--method", method, "--format", "jsonl"]);
    a.extend(extra);
    ok(&km(&a)).lines().map(|l| serde_json::from_str(l).unwrap()).collect()
}

/// `km solve` of the slab at `g` with `extra` flags, as JSON.
fn solve_at(g: &str, method: &str, extra: &[&str]) -> Value {
    let s = slab();
    let set = format!("layer[1].g={g}");
    let mut a = vec!["solve", &s, "--set", &set, "--set", DIRS, "--method", method, "--json"];
    a.extend(extra);
    serde_json::from_str(&ok(&km(&a))).unwrap()
}

/// Every number of a sweep row equals the solve's at the same point with the
/// same flags (the same code: equal to the bit), BRDF and BTDF included.
fn assert_row_is_solve(row: &Value, v: &Value, mc: bool) {
    for key in ["reflectance", "reflectance_specular", "transmittance", "absorptance"] {
        assert_eq!(row[key], v[key], "{key}: {row}");
        if mc {
            assert_eq!(row[format!("stderr_{key}")], v["stderr"][key], "stderr {key}: {row}");
        }
    }
    for what in ["brdf", "btdf"] {
        for i in 0..2 {
            assert_eq!(row[format!("{what}_{i}")], v[what][i], "{what}_{i}: {row}");
            if mc {
                let se = &row[format!("stderr_{what}_{i}")];
                assert_eq!(se, &v["stderr"][what][i], "stderr {what}_{i}: {row}");
            }
        }
    }
}

#[test]
fn sweep_takes_the_settings_of_solve_and_gives_brdf_columns() {
    // Multi-flux at 4 streams: the rows are the 4-stream solves, not the default.
    let rows = sweep_rows("multiflux", &["--streams", "4"]);
    assert_eq!(rows.len(), 2);
    for (row, g) in rows.iter().zip(["0", "0.5"]) {
        assert_row_is_solve(row, &solve_at(g, "multiflux", &["--streams", "4"]), false);
    }
    let default = solve_at("0.5", "multiflux", &[]);
    assert_ne!(rows[1]["reflectance"], default["reflectance"], "--streams 4 was ignored");
    // Monte Carlo with its photon count and seed, standard errors included.
    let mc = ["--samples", "3000", "--seed", "5"];
    let rows = sweep_rows("mc", &mc);
    for (row, g) in rows.iter().zip(["0", "0.5"]) {
        assert_row_is_solve(row, &solve_at(g, "mc", &mc), true);
    }
    // Two-flux with its model: another answer than the default four-flux.
    let two = sweep_rows("km", &["--km-model", "two-flux"]);
    assert_row_is_solve(&two[1], &solve_at("0.5", "km", &["--km-model", "two-flux"]), false);
    // An accuracy target: each point solved to it.
    let rows = sweep_rows("multiflux", &["--tolerance", "1e-3"]);
    assert_row_is_solve(&rows[0], &solve_at("0", "multiflux", &["--tolerance", "1e-3"]), false);
}

#[test]
fn sweep_refuses_settings_of_other_methods_as_solve_does() {
    let s = slab();
    let base = ["sweep", s.as_str(), "--set", "layer[1].g=0:0.5:2"];
    for (extra, words) in [
        (&["--method", "km", "--streams", "4"][..], "--streams does not apply to --method km"),
        (&["--method", "multiflux", "--samples", "10"][..], "--samples does not apply"),
        (&["--method", "km", "--order", "2"][..], "--order does not apply to --method km"),
        (&["--method", "mc", "--shard", "0/2"][..], "--shard applies to km solve, not"),
        (&["--repeat", "3"][..], "--repeat applies to km solve, not"),
        (&["--method", "mc", "--samples", "10", "--tolerance", "1e-3"][..], "either --samples"),
    ] {
        let out = km(&[&base[..], extra].concat());
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{extra:?}: {err}");
        assert!(err.contains(words), "{extra:?}: {err}");
        assert!(out.stdout.is_empty());
    }
    // The same words as `km solve` (both read km::settings::SETTINGS).
    let solve = km(&["solve", &s, "--method", "km", "--streams", "4"]);
    let err = String::from_utf8_lossy(&solve.stderr);
    assert!(err.contains("--streams does not apply to --method km"), "{err}");
    assert!(err.contains("multiflux"), "{err}");
}

#[test]
fn budget_scales_a_two_flux_sweep_as_one_request() {
    // 100 two-flux points of 4.6e5 work units each (docs/limits.md §1):
    // within the default budget of 1e10, over a thousandth of it.
    let s = slab();
    let base = ["sweep", s.as_str(), "--method", "km", "--set", "layer[1].g=0:0.99:100"];
    let ok = km(&base);
    assert_eq!(ok.status.code(), Some(0), "{}", String::from_utf8_lossy(&ok.stderr));
    let refused = km(&[&base[..], &["--budget", "0.001"]].concat());
    let err = String::from_utf8_lossy(&refused.stderr);
    assert_ne!(refused.status.code(), Some(0), "{err}");
    assert!(err.contains("100 points") && err.contains("--budget"), "{err}");
    assert!(refused.stdout.is_empty());
}

#[test]
fn swept_values_are_printed_as_the_decimals_of_the_range() {
    let s = slab();
    for format in ["csv", "table"] {
        let out = ok(&km(&[
            "sweep",
            &s,
            "--set",
            "layer[1].g=0.1:0.5:5",
            "--method",
            "km",
            "--format",
            format,
        ]));
        let first: Vec<String> = out
            .lines()
            .skip(1)
            .map(|l| l.trim_start().split([',', ' ']).next().unwrap().to_string())
            .collect();
        assert_eq!(first, ["0.1", "0.2", "0.3", "0.4", "0.5"], "{out}");
    }
    // JSONL: the same numbers (0.3 is the double nearest 3/10).
    let out = ok(&km(&["sweep", &s, "--set", "layer[1].g=0.1:0.5:5", "--format", "jsonl"]));
    let g: Vec<f64> = out
        .lines()
        .map(|l| serde_json::from_str::<Value>(l).unwrap()["layer[1].g"].as_f64().unwrap())
        .collect();
    assert_eq!(g, [0.1, 0.2, 0.3, 0.4, 0.5]);
}
