//! `km bsdf --fourier-tol` (`BsdfLists::fourier_tol`): the tolerance reaches
//! the table's azimuthal series (docs/bsdf.md §1, docs/multiflux.md eq. 5j)
//! and a value outside [0, 0.1] is refused by name.

use km::Scene;
use km::bsdf_file::{BsdfLists, BsdfRequest, bsdf_file};

/// The peaked slab of the C DISORT comparison (g = 0.9), whose series the
/// default rule runs to its last order.
const SLAB: &str = "[[layer]]\ntau = 1.0\nalbedo = 0.9\ng = 0.9\n[substrate]\nkind = \"black\"\n";

fn table(tol: Option<f64>) -> Result<Vec<f64>, String> {
    let scene = Scene::from_toml_str(SLAB).unwrap();
    let lists = BsdfLists {
        theta_i: Some("0,30,60".into()),
        theta_o: Some("0:90:10".into()),
        phi: Some("0:360:30".into()),
        streams: Some(16),
        fourier_tol: tol,
        ..Default::default()
    };
    let request = BsdfRequest::from_lists(&lists, None).unwrap();
    let f = bsdf_file(&scene, "slab.toml", SLAB, &request, false).map_err(|e| e.to_string())?;
    let mut v = Vec::new();
    for i in 0..request.theta_i.len() {
        for o in 0..request.theta_o.len() {
            for &p in &request.phi {
                v.push(f.bsdf.brdf(0, i, o, p));
            }
        }
    }
    Ok(v)
}

/// At 1e-4 the table is no longer the default one (the flag reaches the
/// solver) and stays within ten times the tolerance of its largest value
/// (the bound of km-multiflux/tests/fourier_stop.rs; measured 1e-5 on the
/// default grid of this slab at 32 streams).
#[test]
fn the_tolerance_reaches_the_table() {
    let full = table(None).unwrap();
    let loose = table(Some(1e-4)).unwrap();
    let largest = full.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    let worst = full.iter().zip(&loose).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(worst > 0.0, "the table at 1e-4 equals the default one");
    assert!(worst <= 1e-3 * largest, "{worst:e} of {largest:e}");
}

#[test]
fn a_tolerance_outside_its_range_is_refused() {
    for tol in [0.5, -1.0, f64::NAN] {
        let e = table(Some(tol)).unwrap_err();
        assert!(e.contains("fourier_tol"), "{tol}: {e}");
    }
}
