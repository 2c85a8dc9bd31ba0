//! `[output] depths`: a list or a `{ step, max }` grid, converted with the
//! file's length unit; bad values named with their key and line.

use km_core::Scene;

fn parse(out: &str) -> Result<Scene, km_core::CoreError> {
    Scene::from_toml_str(&format!("[[layer]]\ntau = 1.0\nalbedo = 0.5\n[output]\n{out}\n"))
}

#[test]
fn depths_as_a_list_and_as_a_grid() {
    assert!(parse("").unwrap().depths().is_empty());
    assert_eq!(parse("depths = [0.0, 0.5, 2]").unwrap().depths(), &[0.0, 0.5, 2.0]);
    let g = parse("depths = { step = 0.1, max = 0.3 }").unwrap();
    assert_eq!(g.depths().len(), 4);
    assert!((g.depths()[3] - 0.3).abs() < 1e-15 && g.depths()[1] == 0.1);
    assert_eq!(parse("depths = { step = 0.25, max = 0.6 }").unwrap().depths(), &[0.0, 0.25, 0.5]);
    // Tissue units: depths are converted as thicknesses are (cm -> mm).
    let s = Scene::from_toml_str(
        "units = \"cm\"\n[[layer]]\nmu_a = 0.1\nmu_s = 10.0\nthickness = 0.2\n\
         [output]\ndepths = [0.1]\n",
    )
    .unwrap();
    assert!((s.depths()[0] - 1.0).abs() < 1e-15);
    assert!((s.channels()[0].layers()[0].thickness() - 2.0).abs() < 1e-15);
}

#[test]
fn bad_depths_are_named() {
    for (bad, want) in [
        ("depths = []", "no depth"),
        ("depths = [-1.0]", "finite and >= 0"),
        ("depths = [\"inf\"]", "finite and >= 0"),
        ("depths = [\"x\"]", "expected a number"),
        ("depths = 1.0", "expected a list"),
        ("depths = { step = 0.0, max = 1.0 }", "step"),
        ("depths = { step = 0.1 }", "needs \"max\""),
        ("depths = { step = 0.1, max = -1.0 }", "max"),
        ("depths = { step = 1e-9, max = 1.0 }", "at most 100000"),
        ("depths = { step = 0.1, max = 1.0, min = 0.0 }", "unknown key \"min\""),
    ] {
        let e = parse(bad).unwrap_err().to_string();
        assert!(e.contains("output.depths") && e.contains(want), "{bad}: {e}");
        assert!(e.contains("line 5"), "{bad}: {e}");
    }
}

/// Two-flux values in a stack: the net flux drops across each layer by the
/// layer's absorptance (eq. K9, 1e-12); F = 1 - R at the top, T at the
/// bottom; A = K (i+ + i-) integrates to the absorptance (Simpson, 1e-6).
#[test]
fn two_flux_profile_balances() {
    use km_core::two_flux::{KmModel, KmOptions, depth_profile, solve_mono};
    let s = Scene::from_toml_str(
        "[[layer]]\nsigma_a = 0.3\nsigma_s = 2.0\nthickness = 0.5\nn = 1.5\n\
         [[layer]]\nsigma_a = 0.1\nsigma_s = 5.0\nthickness = 1.0\nn = 1.3\n\
         [substrate]\nkind = \"lambertian\"\nalbedo = 0.5\n",
    )
    .unwrap();
    let m = &s.channels()[0];
    // The profile is the two-flux model's; the same model's totals.
    let o = KmOptions { model: KmModel::TwoFlux, ..Default::default() };
    let c = solve_mono(m, &o).unwrap();
    let p = depth_profile(m, &o, &[0.0, 0.5, 0.5 + 1e-13, 1.5]).unwrap();
    let a = p.layer_absorptance.clone();
    assert!((p.net_flux[0] - p.net_flux[1] - a[0]).abs() < 1e-12);
    assert!((p.net_flux[2] - p.net_flux[3] - a[1]).abs() < 1e-12);
    assert!((c.reflectance + p.net_flux[3] + a[0] + a[1] - 1.0).abs() < 1e-12);
    // Simpson on 2000 intervals of the second layer.
    let n = 2000;
    let zs: Vec<f64> = (0..=n).map(|i| 0.5 + i as f64 / n as f64).collect();
    let q = depth_profile(m, &o, &zs).unwrap();
    let h = 1.0 / n as f64;
    let int: f64 = (0..=n)
        .map(|i| {
            let w = if i == 0 || i == n {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            };
            w * q.absorbed[i]
        })
        .sum::<f64>()
        * h
        / 3.0;
    // The first node (z = 0.5) belongs to the layer above: its A is that
    // layer's, an O(h) error of the endpoint; shift it in by a hair.
    let first = depth_profile(m, &o, &[0.5 + 1e-13]).unwrap().absorbed[0];
    let int = int + (first - q.absorbed[0]) * h / 3.0;
    assert!((int - a[1]).abs() < 1e-6, "{int} vs {}", a[1]);
    assert!(depth_profile(m, &o, &[1.6]).is_err());
    assert!(depth_profile(m, &o, &[-0.1]).is_err());
}
