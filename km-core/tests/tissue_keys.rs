//! The tissue keys (`mu_a`, `mu_s`, `mu_s_prime` with `g`) and the file's
//! length unit (`units`), docs/scene-file.md: each against the sigma form
//! it stands for, and every refusal naming its key.

use km_core::Scene;

fn layer0(text: &str) -> km_core::Layer {
    let s = Scene::from_toml_str(text).unwrap();
    s.channels()[0].layers()[0]
}

fn err(text: &str) -> String {
    Scene::from_toml_str(text).unwrap_err().to_string()
}

#[test]
fn mu_keys_are_the_sigma_form() {
    let a = layer0("[[layer]]\nmu_a = 0.3\nmu_s = 12.0\ng = 0.8\nthickness = 2.0\n");
    let b = layer0("[[layer]]\nsigma_a = 0.3\nsigma_s = 12.0\ng = 0.8\nthickness = 2.0\n");
    assert_eq!(a, b);
}

#[test]
fn mu_s_prime_is_unreduced_by_g() {
    // mu_s = mu_s' / (1 - g) = 2 / 0.2 = 10.
    let a = layer0("[[layer]]\nmu_a = 0.1\nmu_s_prime = 2.0\ng = 0.8\nthickness = 1.0\n");
    assert!((a.sigma_s() - 10.0).abs() < 1e-12, "{}", a.sigma_s());
    assert!((a.sigma_s_reduced() - 2.0).abs() < 1e-12);
    // Per channel: one g per channel.
    let s = Scene::from_toml_str(
        "[spectrum]\nlabels = [\"a\", \"b\"]\n[[layer]]\nmu_a = 0.1\nmu_s_prime = 2.0\n\
         g = [0.0, 0.5]\nthickness = 1.0\n",
    )
    .unwrap();
    let s1: Vec<f64> = s.channels().iter().map(|c| c.layers()[0].sigma_s()).collect();
    assert_eq!(s1, vec![2.0, 4.0]);
}

#[test]
fn centimetres_are_converted_to_millimetres_once() {
    // 0.1 cm thick, mu_a = 1/cm, mu_s = 100/cm: in mm 1 mm, 0.1/mm, 10/mm;
    // the optical thickness 10.1 and the albedo are unit-free and unchanged.
    let cm = layer0("units = \"cm\"\n[[layer]]\nmu_a = 1.0\nmu_s = 100.0\nthickness = 0.1\n");
    assert!((cm.thickness() - 1.0).abs() < 1e-15, "{cm:?}");
    assert!((cm.sigma_a() - 0.1).abs() < 1e-15);
    assert!((cm.sigma_s() - 10.0).abs() < 1e-12);
    let mm = layer0("units = \"mm\"\n[[layer]]\nsigma_a = 0.1\nsigma_s = 10.0\nthickness = 1.0\n");
    assert!((cm.tau() - mm.tau()).abs() < 1e-12 && (cm.albedo() - mm.albedo()).abs() < 1e-15);
    // A preset (mm) in a cm file: only its thickness is the file's.
    let p = layer0("units = \"cm\"\n[[layer]]\npreset = \"marble\"\nthickness = 0.2\n");
    let q = layer0("[[layer]]\npreset = \"marble\"\nthickness = 2.0\n");
    assert_eq!(p, q);
}

#[test]
fn refusals_name_the_key() {
    let base = "[[layer]]\nthickness = 1.0\n";
    let cases = [
        ("mu_a = 1.0\nmu_s = 1.0\nmu_s_prime = 1.0\ng = 0.5\n", "give mu_s or mu_s_prime"),
        ("mu_a = 1.0\nmu_s_prime = 1.0\n", "mu_s_prime needs g"),
        ("mu_a = 1.0\nmu_s = 1.0\nsigma_a = 1.0\n", "remove sigma_a/sigma_s"),
        ("mu_s = 1.0\n", "needs mu_a"),
        ("mu_a = 1.0\n", "needs mu_s or mu_s_prime"),
        ("mu_a = -1.0\nmu_s = 1.0\n", "layer[1].mu_a"),
        ("mu_a = 1.0\nmu_s_prime = 1.0\ng = 1.0\n", "|g| must be < 1"),
    ];
    for (keys, want) in cases {
        let e = err(&format!("{base}{keys}"));
        assert!(e.contains(want), "{keys}: {e}");
    }
    let e = err("units = \"inch\"\n[[layer]]\ntau = 1\nalbedo = 0.5\n");
    assert!(e.contains("units") && e.contains("inch"), "{e}");
    let e = err("[[layer]]\nmu_a = 1.0\nmu_s = 1.0\n");
    assert!(e.contains("needs a thickness"), "{e}");
}
