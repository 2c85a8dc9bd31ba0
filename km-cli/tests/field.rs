//! `km field`: the JSON equals the library's field, CSV rows, the chart,
//! and the refusals named.

use std::process::Command;

const SCENE: &str = "[[layer]]\nsigma_a = 0.3\nsigma_s = 3.0\ng = 0.5\nn = 1.4\nthickness = 1.0\n\
    [output]\ndepths = { step = 0.25, max = 1.0 }\n";

fn km(args: &[&str]) -> (bool, String, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_km")).args(args).output().unwrap();
    (o.status.success(), String::from_utf8(o.stdout).unwrap(), String::from_utf8(o.stderr).unwrap())
}

#[test]
fn field_json_csv_plot_and_refusals() {
    let dir = std::env::temp_dir().join(format!("km-field-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("s.toml");
    std::fs::write(&path, SCENE).unwrap();
    let p = path.to_str().unwrap();
    let (ok, out, err) = km(&["field", p, "--json"]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let scene = km_core::Scene::from_toml_str(SCENE).unwrap();
    let lib = km::field::field(&scene, None, &Default::default()).unwrap();
    assert_eq!(v["depths"], serde_json::json!([0.0, 0.25, 0.5, 0.75, 1.0]));
    for (k, want) in [("fluence", &lib.fluence[0]), ("net_flux", &lib.net_flux[0])] {
        let got: Vec<f64> = serde_json::from_value(v[k].clone()).unwrap();
        assert_eq!(&got, want, "{k}");
    }
    let (ok, out, _) = km(&["field", p, "--method", "mc", "--samples", "2000", "--csv"]);
    assert!(ok);
    assert!(out.starts_with("channel,z,fluence,absorbed,net_flux,fluence_se"), "{out}");
    assert_eq!(out.lines().count(), 6);
    let svg = dir.join("f.svg");
    let (ok, _, err) = km(&["field", p, "--method", "km", "--plot", svg.to_str().unwrap()]);
    assert!(ok, "{err}");
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));
    let other = dir.join("notes.svg");
    std::fs::write(&other, "mine").unwrap();
    let (ok, _, err) = km(&["field", p, "--plot", other.to_str().unwrap()]);
    assert!(!ok && err.contains("not replaced"), "{err}");
    assert_eq!(std::fs::read_to_string(&other).unwrap(), "mine");
    // The dipole treats half-spaces only, and says so.
    let (ok, _, err) = km(&["field", p, "--method", "dipole"]);
    assert!(!ok && err.contains("semi-infinite"), "{err}");
    let (ok, _, err) = km(&["field", p, "--method", "direction-set"]);
    assert!(!ok && err.contains("no depth-resolved field"), "{err}");
    let (ok, _, err) = km(&["field", p, "--depths", "1.5"]);
    assert!(!ok && err.contains("depths = 1.5"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `km solve --json` on a scene with `[output] depths` and
/// `inside_directions_deg` carries `km field --json`'s `radiance` object,
/// key for key and number for number (multi-flux at the same streams;
/// Monte Carlo at the same photons and seed, whose solve tallies it in the
/// run that gives the answer, as `km field` does), and the table shows it
/// under the depth table; without the directions the key is absent.
#[test]
fn solve_json_carries_the_radiance_of_km_field() {
    let dir = std::env::temp_dir().join(format!("km-solve-radiance-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("s.toml");
    let text = format!(
        "[light]\ntheta_deg = 30.0\n{SCENE}inside_directions_deg = [[20.0, 180.0], [150.0, 0.0]]\n"
    );
    std::fs::write(&path, &text).unwrap();
    let p = path.to_str().unwrap();
    let json = |args: &[&str]| -> serde_json::Value {
        let (ok, out, err) = km(args);
        assert!(ok, "{args:?}: {err}");
        serde_json::from_str(&out).unwrap()
    };
    for extra in [
        &["--method", "multiflux", "--streams", "12"][..],
        &["--method", "mc", "--samples", "5000", "--seed", "4"][..],
    ] {
        let solve = json(&[&["solve", p, "--json"][..], extra].concat());
        let field = json(&[&["field", p, "--json"][..], extra].concat());
        let r = &solve["radiance"];
        assert!(r.is_object(), "{extra:?}: {solve}");
        assert_eq!(r, &field["radiance"], "{extra:?}");
        // Five depths x two directions, one channel.
        let v = r["values"].as_array().unwrap();
        assert_eq!(v.len(), 5);
        assert!(v.iter().all(|row| row.as_array().unwrap().len() == 2));
        let notes = solve["notes"].as_array().unwrap();
        assert!(!notes.iter().any(|n| n.as_str().unwrap().contains("inside_directions")));
        let (ok, table, err) = km(&[&["solve", p][..], extra].concat());
        assert!(ok, "{err}");
        assert!(table.contains("radiance inside"), "{table}");
    }
    // Two-flux gives none and says so; the answer stands.
    let km_solve = json(&["solve", p, "--method", "km", "--json"]);
    assert!(km_solve.get("radiance").is_none());
    let notes = km_solve["notes"].as_array().unwrap();
    assert!(notes.iter().any(|n| n.as_str().unwrap().contains("gives no radiance")), "{notes:?}");
    // Without directions: no key.
    std::fs::write(&path, SCENE).unwrap();
    assert!(json(&["solve", p, "--json"]).get("radiance").is_none());
    std::fs::remove_dir_all(&dir).unwrap();
}
