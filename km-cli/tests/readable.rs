//! Numbers people can read: Monte Carlo CSV with every standard error
//! (BRDF/BTDF included) and no long runs of zeros; no `±` on a part that is
//! the same for every photon; `x ± se` with the standard error to two
//! significant digits and the value to the same place; spectral tables with
//! the BRDF rows under a header of wavelengths.

use std::path::PathBuf;
use std::process::{Command, Output};

use serde_json::Value;

fn km(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_km")).args(args).output().expect("run km")
}

fn stdout(args: &[&str]) -> String {
    let out = km(args);
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap()
}

fn example(name: &str) -> String {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../examples").join(name);
    p.to_string_lossy().into_owned()
}

fn scene_file(tag: &str, text: &str) -> String {
    let dir = std::env::temp_dir().join(format!("km-readable-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(format!("{tag}.toml"));
    std::fs::write(&p, text).unwrap();
    p.to_string_lossy().into_owned()
}

const SPECTRAL: &str = "[spectrum]\nwavelengths_nm = [450, 550, 650, 750]\n[[layer]]\n\
                        sigma_a = [0.1, 0.2, 0.3, 0.4]\nsigma_s = 1\nthickness = 2\nn = 1.5\n\
                        [substrate]\nkind = \"transparent\"\nn = 1.0\n\
                        [output]\ndirections_deg = [[0, 0], [30, 180]]\n";

#[test]
fn monte_carlo_csv_has_every_standard_error_in_round_trip_digits() {
    // Paint: three channels, three BRDF directions, opaque (no BTDF).
    let paint = example("paint-over-primer.toml");
    let args = ["solve", paint.as_str(), "--method", "mc", "--samples", "5000"];
    let v: Value = serde_json::from_str(&stdout(&[&args[..], &["--json"]].concat())).unwrap();
    let csv = stdout(&[&args[..], &["--format", "csv"]].concat());
    let mut lines = csv.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    for i in 0..3 {
        assert!(head.contains(&format!("stderr_brdf_{i}").as_str()), "{head:?}");
    }
    assert!(!head.iter().any(|h| h.contains("btdf")), "opaque: {head:?}");
    for (c, line) in lines.enumerate() {
        let row: Vec<&str> = line.split(',').collect();
        assert_eq!(row.len(), head.len());
        let col = |name: &str| row[head.iter().position(|h| *h == name).unwrap()];
        for i in 0..3 {
            // Every digit of the JSON: equal to the bit.
            let se: f64 = col(&format!("stderr_brdf_{i}")).parse().unwrap();
            assert_eq!(Some(se), v["stderr"]["brdf"][c][i].as_f64(), "stderr_brdf_{i} {c}");
            let x: f64 = col(&format!("brdf_{i}")).parse().unwrap();
            assert_eq!(Some(x), v["brdf"][c][i].as_f64());
        }
        // The mirror reflection of the smooth top surface is the same for
        // every photon: its standard error is 0, in the CSV and the JSON.
        assert_eq!(col("stderr_reflectance_specular"), "0", "{line}");
        assert_eq!(v["stderr"]["reflectance_specular"][c].as_f64(), Some(0.0));
        for field in &row {
            assert!(!field.contains("0.00000"), "a run of zeros: {field} in {line}");
        }
    }
}

/// `x ± e`: `e` with two significant digits, `x` to the same decimal
/// place, both the JSON's numbers rounded there (within half a unit).
fn check_pair(x: &str, e: &str, json_x: f64, json_e: f64) {
    let places = |t: &str| t.split_once('.').map_or(0, |(_, f)| f.len());
    assert_eq!(places(x), places(e), "{x} ± {e}");
    let digits: String = e.chars().filter(char::is_ascii_digit).collect();
    assert_eq!(digits.trim_start_matches('0').len(), 2, "{x} ± {e}");
    let unit = 10f64.powi(-(places(x) as i32));
    let (xv, ev): (f64, f64) = (x.parse().unwrap(), e.parse().unwrap());
    assert!((xv - json_x).abs() <= 0.5 * unit * (1.0 + 1e-9), "{x} vs {json_x}");
    assert!((ev - json_e).abs() <= 0.5 * unit * (1.0 + 1e-9), "{e} vs {json_e}");
}

#[test]
fn the_table_gives_plus_minus_only_where_photons_disagree() {
    let marble = example("marble-half-space.toml");
    let args = ["solve", marble.as_str(), "--method", "mc", "--samples", "5000"];
    let t = stdout(&args);
    let v: Value = serde_json::from_str(&stdout(&[&args[..], &["--json"]].concat())).unwrap();
    let line = |start: &str| t.lines().find(|l| l.starts_with(start)).unwrap().to_string();
    assert!(!line("  specular part").contains('±'), "{t}");
    let r = line("reflectance");
    let cells: Vec<&str> = r["reflectance".len()..].split_whitespace().collect();
    assert_eq!(cells.len(), 9, "three channels of `x ± e`: {r}");
    for k in 0..3 {
        assert_eq!(cells[3 * k + 1], "±");
        let (x, e) = (v["reflectance"][k].as_f64(), v["stderr"]["reflectance"][k].as_f64());
        check_pair(cells[3 * k], cells[3 * k + 2], x.unwrap(), e.unwrap());
    }
}

#[test]
fn spectral_table_has_brdf_rows_under_a_header_of_wavelengths() {
    let s = scene_file("spectral", SPECTRAL);
    let v: Value = serde_json::from_str(&stdout(&["solve", &s, "--json"])).unwrap();
    let t = stdout(&["solve", &s]);
    let lines: Vec<&str> = t.lines().collect();
    let h = lines.iter().position(|l| l.contains("450 nm")).expect("a header of wavelengths");
    let head: Vec<&str> = lines[h].split_whitespace().collect();
    assert_eq!(head, ["450", "nm", "550", "nm", "650", "nm", "750", "nm"], "{t}");
    // Then one row per direction and kind, a column per wavelength.
    let rows = &lines[h + 1..h + 5];
    for (k, (i, what)) in [(0, "brdf"), (1, "brdf"), (0, "btdf"), (1, "btdf")].iter().enumerate() {
        let row = rows[k];
        assert!(row.starts_with(&what.to_uppercase()), "{row}");
        let what = *what;
        let i = *i;
        let nums: Vec<f64> = row
            .split(" 1/sr")
            .nth(1)
            .unwrap()
            .split_whitespace()
            .map(|x| x.parse().unwrap())
            .collect();
        assert_eq!(nums.len(), 4, "{row}");
        for (c, x) in nums.iter().enumerate() {
            let want = v[what][c][i].as_f64().unwrap();
            // Printed to 6 decimals: within half a unit of the 6th.
            assert!((x - want).abs() <= 5e-7, "{row}: {x} vs {want}");
        }
    }
}
