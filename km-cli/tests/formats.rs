//! `km solve --format table|json|csv` (and `--json`): the same numbers in
//! every format; text that reads well (no `0` label, Monte Carlo ±, no BTDF
//! of an opaque substrate, every note, the two-flux mapping named).

use std::path::PathBuf;
use std::process::{Command, Output};

fn km(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_km")).args(args).output().expect("run km")
}

fn stdout(args: &[&str]) -> String {
    let out = km(args);
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap()
}

fn examples(name: &str) -> String {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..").join("examples").join(name);
    root.to_string_lossy().into_owned()
}

fn scene_file(tag: &str, text: &str) -> String {
    let dir = std::env::temp_dir().join(format!("km-formats-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(format!("{tag}.toml"));
    std::fs::write(&p, text).unwrap();
    p.to_string_lossy().into_owned()
}

const SPECTRAL: &str = "[spectrum]\nwavelengths_nm = [450, 550, 650, 750]\n[[layer]]\n\
                        sigma_a = [0.1, 0.2, 0.3, 0.4]\nsigma_s = 1\nthickness = 2\n\
                        [substrate]\nkind = \"lambertian\"\nalbedo = [0.2, 0.5, 0.8, 0.9]\n";

#[test]
fn json_alias_and_conflict() {
    let s = examples("fresnel-slab.toml");
    let strip = |t: String| {
        let mut v: serde_json::Value = serde_json::from_str(&t).unwrap();
        v.as_object_mut().unwrap().remove("seconds");
        v
    };
    let a = strip(stdout(&["solve", &s, "--json"]));
    let b = strip(stdout(&["solve", &s, "--format", "json"]));
    assert_eq!(a, b);
    let out = km(&["solve", &s, "--json", "--format", "csv"]);
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn csv_rows_are_the_json_numbers() {
    for (tag, scene, method, label_col) in [
        ("fresnel", examples("fresnel-slab.toml"), "multiflux", "channel"),
        ("rgb", examples("paint-over-primer.toml"), "km", "channel"),
        ("spectral", scene_file("spectral", SPECTRAL), "multiflux", "wavelength_nm"),
        ("mc", examples("fresnel-slab.toml"), "mc", "channel"),
    ] {
        let mut args = vec!["solve", scene.as_str(), "--method", method];
        if method == "mc" {
            args.extend(["--samples", "5000"]);
        }
        let mut j = args.clone();
        j.push("--json");
        let v: serde_json::Value = serde_json::from_str(&stdout(&j)).unwrap();
        let mut c = args.clone();
        c.extend(["--format", "csv"]);
        let csv = stdout(&c);
        let mut lines = csv.lines();
        let head: Vec<&str> = lines.next().unwrap().split(',').collect();
        assert_eq!(head[0], label_col, "{tag}");
        let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
        let n = v["channels"].as_array().map_or(1, Vec::len);
        assert_eq!(rows.len(), n, "{tag}: one row per channel");
        for (k, row) in rows.iter().enumerate() {
            assert_eq!(row.len(), head.len(), "{tag}");
            for key in ["reflectance", "transmittance", "absorptance"] {
                let col = head.iter().position(|h| *h == key).unwrap();
                let x: f64 = row[col].parse().unwrap();
                let want = if n == 1 { v[key].as_f64() } else { v[key][k].as_f64() };
                assert_eq!(Some(x), want, "{tag} {key} row {k}");
            }
            if tag == "spectral" {
                let w: f64 = row[0].parse().expect("numeric wavelength");
                assert_eq!(w, [450.0, 550.0, 650.0, 750.0][k]);
            }
        }
        assert_eq!(head.contains(&"stderr_reflectance"), method == "mc", "{tag}");
        // The opaque paint has no BTDF columns.
        if tag == "rgb" {
            assert!(!head.iter().any(|h| h.starts_with("btdf")), "{head:?}");
        }
    }
}

#[test]
fn text_reads_well() {
    let slab = examples("fresnel-slab.toml");
    let t = stdout(&["solve", &slab]);
    let header = t.lines().nth(1).unwrap();
    assert_eq!(header.trim(), "value", "single channel header: {t}");
    let mc = stdout(&["solve", &slab, "--method", "mc", "--samples", "5000"]);
    assert!(mc.lines().any(|l| l.starts_with("reflectance") && l.contains(" ± ")), "{mc}");
    assert!(mc.contains("5000 photons per channel"), "{mc}");
    // Opaque substrate: no BTDF rows; every JSON note printed.
    let paint = examples("paint-over-primer.toml");
    let t = stdout(&["solve", &paint, "--method", "km"]);
    assert!(!t.contains("BTDF"), "{t}");
    assert!(t.contains("BRDF"), "{t}");
    assert!(t.contains("K/S mapping gate1974: K = 2 sigma_a, S = 3/4 sigma_s (1 - g)"), "{t}");
    assert!(t.contains("model four-flux"), "{t}");
    assert!(t.contains("model error estimate"), "{t}");
    assert!(t.contains("--method multiflux"), "{t}");
    let t2 = stdout(&["solve", &paint, "--method", "km", "--km-mapping", "seed"]);
    assert!(t2.contains("K/S mapping seed: K = sigma_a, S = sigma_s"), "{t2}");
    let t3 = stdout(&["solve", &paint, "--method", "km", "--km-model", "two-flux"]);
    assert!(t3.contains("model two-flux"), "{t3}");
    for scene in [&slab, &paint, &examples("cloud-deck.toml")] {
        for method in ["km", "multiflux"] {
            let t = stdout(&["solve", scene, "--method", method]);
            let v: serde_json::Value =
                serde_json::from_str(&stdout(&["solve", scene, "--method", method, "--json"]))
                    .unwrap();
            for n in v["notes"].as_array().unwrap() {
                assert!(t.contains(&format!("note: {}", n.as_str().unwrap())), "{n} in {t}");
            }
        }
    }
    // A spectral scene: one row per wavelength.
    let s = scene_file("spectral-text", SPECTRAL);
    let t = stdout(&["solve", &s]);
    let lines: Vec<&str> = t.lines().collect();
    assert!(lines[1].trim_start().starts_with("wavelength_nm"), "{t}");
    for (i, w) in ["450", "550", "650", "750"].iter().enumerate() {
        assert!(lines[2 + i].trim_start().starts_with(w), "{t}");
    }
    assert!(lines[1].len() < 100, "narrow header: {}", lines[1]);
}

#[test]
fn profile_text_has_units() {
    let t = stdout(&["profile", &examples("marble-half-space.toml"), "--points", "3"]);
    let head = t.lines().next().unwrap();
    assert!(head.contains("r [L]") && head.contains("[1/L^2]"), "{t}");
    assert!(t.contains("L: the scene's length unit"), "{t}");
    assert_eq!(t.lines().count(), 5, "header, 3 radii, the unit line: {t}");
}

#[test]
fn profile_csv_rows_are_the_json_numbers() {
    let s = examples("marble-half-space.toml");
    for method in ["dipole", "mc"] {
        let mut args = vec!["profile", &s, "--method", method, "--points", "5"];
        if method == "mc" {
            args.extend(["--samples", "20000"]);
        }
        let json: serde_json::Value =
            serde_json::from_str(&stdout(&[&args[..], &["--format", "json"]].concat())).unwrap();
        let csv = stdout(&[&args[..], &["--format", "csv"]].concat());
        let mut lines = csv.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        assert_eq!(header[0], "r", "{csv}");
        assert_eq!(header.iter().any(|h| h.starts_with("stderr")), method == "mc", "{csv}");
        let rows: Vec<Vec<f64>> =
            lines.map(|l| l.split(',').map(|x| x.parse().unwrap()).collect()).collect();
        let r = json["r"].as_array().unwrap();
        assert_eq!(rows.len(), r.len());
        for (i, row) in rows.iter().enumerate() {
            assert_eq!(row[0], r[i].as_f64().unwrap());
            // One channel per rd column (marble has three).
            let rd = &json["rd"];
            let first = if rd[0].is_array() { rd[0][i].as_f64() } else { rd[i].as_f64() };
            assert_eq!(row[1], first.unwrap(), "{method} row {i}");
        }
    }
    // --json and --format conflict, as for km solve.
    assert!(!km(&["profile", &s, "--json", "--format", "csv"]).status.success());
}

#[test]
fn merge_takes_every_format() {
    let dir = std::env::temp_dir().join(format!("km-formats-merge-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let s = examples("fresnel-slab.toml");
    let parts: Vec<String> = (0..2)
        .map(|i| {
            let p = dir.join(format!("part{i}.json")).to_string_lossy().into_owned();
            let _ = std::fs::remove_file(&p);
            let shard = format!("{i}/2");
            stdout(&[
                "solve",
                &s,
                "--method",
                "mc",
                "--samples",
                "20000",
                "--shard",
                &shard,
                "--out",
                &p,
            ]);
            p
        })
        .collect();
    let mut base = vec!["merge"];
    base.extend(parts.iter().map(String::as_str));
    let json: serde_json::Value =
        serde_json::from_str(&stdout(&[&base[..], &["--format", "json"]].concat())).unwrap();
    let csv = stdout(&[&base[..], &["--format", "csv"]].concat());
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let row: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = header.iter().position(|h| *h == "reflectance").expect("reflectance column");
    let r: f64 = row[col].parse().unwrap();
    assert!((r - json["reflectance"].as_f64().unwrap()).abs() <= 1e-12 * r.abs().max(1.0));
    let table = stdout(&[&base[..], &["--format", "table"]].concat());
    assert!(table.contains('±'), "{table}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn repeat_times_the_same_answer_k_times() {
    let s = examples("fresnel-slab.toml");
    for method in ["km", "multiflux", "dipole"] {
        let single = km(&["solve", &s, "--method", method, "--json"]);
        let out = km(&["solve", &s, "--method", method, "--json", "--repeat", "5"]);
        if method == "dipole" {
            // The dipole refuses this slab; --repeat does not change that.
            assert_eq!(single.status.code(), Some(2));
            assert_eq!(out.status.code(), Some(2));
            continue;
        }
        let once: serde_json::Value = serde_json::from_slice(&single.stdout).unwrap();
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(v["repeat"], 5);
        let (first, best, median) = (
            v["seconds"].as_f64().unwrap(),
            v["seconds_best"].as_f64().unwrap(),
            v["seconds_median"].as_f64().unwrap(),
        );
        assert!(best <= first && best <= median && median.is_finite(), "{v}");
        assert_eq!(v["reflectance"], once["reflectance"], "{method}");
    }
    // Refused: 0 repeats, and --repeat with a shard.
    assert_eq!(km(&["solve", &s, "--repeat", "0"]).status.code(), Some(2));
    let shard =
        km(&["solve", &s, "--method", "mc", "--shard", "0/2", "--out", "x", "--repeat", "2"]);
    assert_eq!(shard.status.code(), Some(2));
}
