//! `--colour` and `--swatch` of `km solve` and `km sweep` against the CIE
//! formulas: a flat reflectance spectrum R under D65 has `XYZ = R (Xn, Yn,
//! Zn)` with the white `(95.047, 100, 108.883)` (ASTM E308 Table 5, CIE 1931
//! 2°), `L* = 116 R^(1/3) - 16`, `a* = b* = 0` (CIE 015:2018 eq. 8.1-8.3),
//! and the sRGB grey `1.055 R^(1/2.4) - 0.055` (IEC 61966-2-1 eq. C6).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

fn km(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_km")).args(args).output().expect("run km")
}

fn ok(args: &[&str]) -> String {
    let out = km(args);
    assert!(out.status.success(), "km {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap()
}

fn dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("km-colour-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A flat spectrum of reflectance `albedo` (a clear film over a Lambertian
/// substrate: `R = albedo` to 1e-12 by the two-flux closed form).
fn flat(d: &Path, albedo: f64) -> PathBuf {
    let p = d.join(format!("flat-{albedo}.toml"));
    std::fs::write(
        &p,
        format!(
            "[spectrum]\nwavelengths_nm = [380, 430, 480, 530, 580, 630, 680, 730, 780]\n\
             [[layer]]\ntau = 1e-12\nalbedo = 0.5\n\
             [substrate]\nkind = \"lambertian\"\nalbedo = {albedo}\n"
        ),
    )
    .unwrap();
    p
}

/// ASTM E308 Table 5: the D65 white, CIE 1931 2°; the sums of the CIE
/// tables agree with it to 0.01 (docs/colour.md §6).
const WHITE: [f64; 3] = [95.047, 100.0, 108.883];

fn expected_grey(r: f64) -> ([f64; 3], f64, String) {
    let l = 116.0 * r.cbrt() - 16.0;
    let e = 1.055 * r.powf(1.0 / 2.4) - 0.055;
    let byte = (e * 255.0).round() as u8;
    (WHITE.map(|w| w * r), l, format!("#{byte:02x}{byte:02x}{byte:02x}"))
}

#[test]
fn solve_gives_the_cie_colour_of_a_flat_spectrum() {
    let d = dir("solve");
    for r in [1.0, 0.5, 0.18] {
        let scene = flat(&d, r);
        let v: Value = serde_json::from_str(&ok(&[
            "solve",
            s(&scene),
            "--method",
            "km",
            "--colour",
            "--json",
        ]))
        .unwrap();
        let c = &v["colour"]["reflectance"];
        let (xyz, l, hex) = expected_grey(r);
        for k in 0..3 {
            let got = c["xyz"][k].as_f64().unwrap();
            assert!((got - xyz[k]).abs() < 0.01 * r.max(0.1), "{r}: XYZ[{k}] {got} vs {}", xyz[k]);
        }
        // Relative to its own white, a flat spectrum is neutral: only rounding.
        assert!((c["lab"][0].as_f64().unwrap() - l).abs() < 1e-6, "{r}: {c}");
        assert!(
            c["lab"][1].as_f64().unwrap().abs() < 1e-9
                && c["lab"][2].as_f64().unwrap().abs() < 1e-9
        );
        assert_eq!(c["hex"], Value::from(hex), "{r}");
        assert_eq!(v["colour"]["illuminant"], "D65");
        assert!(v["colour"].get("transmittance").is_none(), "opaque: no transmittance colour");
    }
    // The table has the colour line.
    let t = ok(&["solve", s(&flat(&d, 1.0)), "--method", "km", "--colour"]);
    assert!(t.contains("XYZ (95.04") && t.contains("L*a*b* (100.00, 0.00, 0.00)"), "{t}");
    assert!(t.contains("#ffffff") && !t.contains("clipped"), "{t}");
}

#[test]
fn swatch_is_written_and_refusals_name_the_flag() {
    let d = dir("swatch");
    let scene = flat(&d, 0.5);
    let svg = d.join("grey.svg");
    ok(&["solve", s(&scene), "--method", "km", "--colour", "--swatch", s(&svg)]);
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<svg") && text.contains("#bcbcbc"), "{text}");
    // Never over the scene file; --swatch needs --colour; RGB scenes, CSV
    // and a Monte Carlo shard (which prints nothing) refused; the shard's
    // file is not written.
    let part = d.join("part.json");
    let cases: [(&[&str], &str); 5] = [
        (&["solve", s(&scene), "--colour", "--swatch", s(&scene)], "--swatch"),
        (
            &[
                "solve",
                s(&scene),
                "--method",
                "mc",
                "--shard",
                "0/2",
                "--out",
                s(&part),
                "--colour",
            ],
            "--shard",
        ),
        (&["solve", s(&scene), "--swatch", s(&svg)], "--colour"),
        (&["solve", s(&scene), "--colour", "--format", "csv"], "whole spectrum"),
        (
            &[
                "sweep",
                s(&scene),
                "--set",
                "substrate.albedo=0:1:100",
                "--colour",
                "--swatch",
                s(&svg),
            ],
            "at most 64",
        ),
    ];
    for (args, words) in cases {
        let out = km(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(words), "{args:?}: {err}");
    }
    assert!(!part.exists(), "no shard written under --colour");
    assert!(std::fs::read_to_string(&scene).unwrap().contains("[spectrum]"), "scene intact");
    let rgb = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../examples/paint-over-primer.toml");
    let out = km(&["solve", s(&rgb), "--colour"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("wavelengths_nm"));
}

#[test]
fn sweep_gives_one_colour_row_per_point() {
    let d = dir("sweep");
    let scene = flat(&d, 0.5);
    let svg = d.join("sweep.svg");
    let args = ["sweep", s(&scene), "--set", "substrate.albedo=0.2:1:5", "--method", "km"];
    let csv = ok(&[&args[..], &["--colour", "--swatch", s(&svg), "--format", "csv"]].concat());
    let mut lines = csv.lines();
    assert_eq!(lines.next().unwrap(), "substrate.albedo,R_X,R_Y,R_Z,R_L,R_a,R_b,R_hex");
    let mut n = 0;
    for (line, r) in lines.zip([0.2, 0.4, 0.6, 0.8, 1.0]) {
        let cells: Vec<&str> = line.split(',').collect();
        let (xyz, l, hex) = expected_grey(r);
        assert_eq!(cells[0].parse::<f64>().unwrap(), r);
        let y: f64 = cells[2].parse().unwrap();
        assert!((y - xyz[1]).abs() < 1e-5, "{line}");
        assert!((cells[4].parse::<f64>().unwrap() - l).abs() < 1e-5, "{line}");
        assert_eq!(
            (cells[5], cells[6], cells[7]),
            ("0.000000", "0.000000", hex.as_str()),
            "{line}"
        );
        n += 1;
    }
    assert_eq!(n, 5);
    let text = std::fs::read_to_string(&svg).unwrap();
    for r in [0.2, 0.4, 0.6, 0.8, 1.0] {
        let hex = expected_grey(r).2;
        assert!(text.contains(&hex), "a patch per point: {hex} in {text}");
    }
    assert!(text.contains("substrate.albedo=0.6"), "patches labelled by their point");
}
