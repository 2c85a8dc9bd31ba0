//! `--set KEY=VALUE` against the equivalent edited scene files.

use std::path::PathBuf;
use std::process::{Command, Output};

fn km(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_km")).args(args).output().expect("run km")
}

fn scene_file(tag: &str, text: &str) -> String {
    let dir = std::env::temp_dir().join(format!("km-set-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p: PathBuf = dir.join(format!("{tag}.toml"));
    std::fs::write(&p, text).unwrap();
    p.to_string_lossy().into_owned()
}

/// The JSON of `km solve` without its wall time.
fn solve_json(args: &[&str]) -> serde_json::Value {
    let out = km(args);
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    let mut v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    v.as_object_mut().unwrap().remove("seconds");
    v
}

const BASE: &str = "[light]\nkind = \"collimated\"\ntheta_deg = 45.0\n\n[[layer]]\ntau = 0.5\n\
                    albedo = 0.8\ng = 0.0\nn = 1.3\n\n[[layer]]\ntau = 1.0\nalbedo = 0.5\n\n\
                    [substrate]\nkind = \"lambertian\"\nalbedo = 0.2\n";

#[test]
fn set_equals_the_edited_file() {
    let base = scene_file("base", BASE);
    // (edits, the same scene written out)
    let cases: &[(&[&str], String)] = &[
        (&["layer[1].g=0.8"], BASE.replace("g = 0.0", "g = 0.8")),
        (
            &["light.theta_deg=60", "layer[2].albedo=0.9"],
            BASE.replace("theta_deg = 45.0", "theta_deg = 60")
                .replace("albedo = 0.5", "albedo = 0.9"),
        ),
        (&["substrate.albedo=0.5"], BASE.replace("albedo = 0.2", "albedo = 0.5")),
        // A key the file does not have is added.
        (&["layer[2].g=0.5"], BASE.replace("albedo = 0.5\n", "albedo = 0.5\ng = 0.5\n")),
        (
            &["output.directions_deg=[[0,0],[30,180]]"],
            format!("{BASE}\n[output]\ndirections_deg = [[0, 0], [30, 180]]\n"),
        ),
    ];
    for (i, (edits, text)) in cases.iter().enumerate() {
        let edited = scene_file(&format!("edited{i}"), text);
        for method in ["km", "multiflux"] {
            let mut a = vec!["solve", base.as_str(), "--method", method, "--json"];
            for e in *edits {
                a.extend(["--set", e]);
            }
            let b = solve_json(&["solve", &edited, "--method", method, "--json"]);
            assert_eq!(solve_json(&a), b, "{edits:?} with {method}");
        }
    }
    // Plan and check take --set too.
    let out = km(&["check", &base, "--set", "layer[1].g=0.8"]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("g = 0.8"));
    let a = km(&["plan", &base, "--set", "layer[1].n=1", "--json"]);
    let b = km(&["plan", &scene_file("n1", &BASE.replace("n = 1.3", "n = 1")), "--json"]);
    assert!(a.status.success());
    assert_eq!(a.stdout, b.stdout);
}

#[test]
fn bad_set_is_refused_naming_the_key_and_set() {
    let base = scene_file("base-bad", BASE);
    for (edit, names) in [
        ("layer[1].g=2", "`layer[1].g`"),
        ("layer[3].g=0.5", "`layer[3].g`"),
        ("layer[0].g=0.5", "1-based"),
        ("g", "KEY=VALUE"),
        ("light.theta_deg=95", "`light.theta_deg`"),
    ] {
        let out = km(&["solve", &base, "--set", edit]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{edit}: {err}");
        assert!(err.contains(names) && err.contains("--set"), "{edit}: {err}");
        assert!(out.stdout.is_empty());
    }
}

/// `km sweep` against `km solve` of the equivalent edited files, in grid order,
/// in each format.
#[test]
fn sweep_rows_equal_solves_of_the_edited_files() {
    let base = scene_file("sweep-base", BASE);
    for method in ["km", "multiflux"] {
        let args = [
            "sweep",
            base.as_str(),
            "--set",
            "layer[1].g=0:0.9:4",
            "--set",
            "light.theta_deg=0:60:3",
            "--set",
            "substrate.albedo=0.5",
            "--method",
            method,
        ];
        let run = |format: &str| {
            let mut a = args.to_vec();
            a.extend(["--format", format]);
            let out = km(&a);
            assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
            String::from_utf8(out.stdout).unwrap()
        };
        let jsonl = run("jsonl");
        let rows: Vec<serde_json::Value> =
            jsonl.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
        assert_eq!(rows.len(), 12, "4 x 3 points");
        let mut i = 0;
        for g in [0.0, 0.3, 0.6, 0.9] {
            for theta in [0.0, 30.0, 60.0] {
                let row = &rows[i];
                i += 1;
                // Grid order: the first axis slowest.
                let (rg, rt) =
                    (row["layer[1].g"].as_f64().unwrap(), row["light.theta_deg"].as_f64().unwrap());
                // Linear spacing, within rounding of start + step * i.
                assert!((rg - g).abs() < 1e-12 && (rt - theta).abs() < 1e-12, "{row}");
                let text = BASE
                    .replace("g = 0.0", &format!("g = {rg:?}"))
                    .replace("theta_deg = 45.0", &format!("theta_deg = {rt:?}"))
                    .replace("albedo = 0.2", "albedo = 0.5");
                let edited = scene_file(&format!("sweep-{method}-{i}"), &text);
                let v = solve_json(&["solve", &edited, "--method", method, "--json"]);
                for key in [
                    "reflectance",
                    "reflectance_specular",
                    "transmittance",
                    "transmittance_direct",
                    "absorptance",
                ] {
                    assert_eq!(row[key], v[key], "{method} {row} {key}");
                }
            }
        }
        // CSV: a header and the same numbers; the table: a header and one line per point.
        let csv = run("csv");
        let mut lines = csv.lines();
        assert_eq!(
            lines.next().unwrap(),
            "layer[1].g,light.theta_deg,reflectance,reflectance_specular,transmittance,\
             transmittance_direct,absorptance"
        );
        for (line, row) in lines.zip(&rows) {
            let r: f64 = line.split(',').nth(2).unwrap().parse().unwrap();
            assert_eq!(r, row["reflectance"].as_f64().unwrap());
        }
        assert_eq!(run("table").lines().count(), 13);
    }
}

#[test]
fn bad_sweeps_are_refused() {
    let base = scene_file("sweep-bad", BASE);
    for (set, names) in [
        ("layer[1].g=0:0.9", "START:STOP:N"),
        ("layer[1].g=0:x:3", "START:STOP:N"),
        ("layer[1].g=0:0.9:0", "START:STOP:N"),
        ("layer[1].g=0:2:3", "`layer[1].g`"),
    ] {
        let out = km(&["sweep", &base, "--set", set]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{set}: {err}");
        assert!(err.contains(names), "{set}: {err}");
    }
}
