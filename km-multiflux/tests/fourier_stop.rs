//! The azimuthal stopping rule on the multiply scattered light (eq. 5i–5k
//! of docs/multiflux.md): each order's once-scattered part is known in
//! closed form, the rule tests the rest, and the orders after the stop are
//! the closed form alone. Checked against the series summed to its last
//! order (`fourier_tol = 0`: no order is ever small enough to stop), which
//! holds the same once-scattered orders computed by the operators.

use km_core::{MonoScene, Scene};
use km_multiflux::bsdf::{Bsdf, BsdfOptions};
use km_multiflux::{MultifluxOptions, solve_mono};

/// The 30 exit directions of the BRDF comparison with C DISORT
/// (docs/benchmarks.md §9): six polar angles, five azimuths.
fn directions() -> String {
    let mut d = Vec::new();
    for t in [10.0, 20.0, 30.0, 40.0, 50.0, 60.0] {
        for p in [0.0, 45.0, 90.0, 135.0, 180.0] {
            d.push(format!("[{t:?}, {p:?}]"));
        }
    }
    format!("[output]\ndirections_deg = [{}]\n", d.join(", "))
}

fn mono(text: &str) -> MonoScene {
    let s = Scene::from_toml_str(&format!("{text}{}", directions())).unwrap();
    s.channels()[0].clone()
}

/// A slab lit at 30 degrees over black (the peers' BRDF case), g = 0.9.
const SLAB: &str = "[light]\nkind = \"collimated\"\ntheta_deg = 30.0\n\
    [[layer]]\ntau = 1.0\nalbedo = 0.9\ng = 0.9\nn = 1.0\n[substrate]\nkind = \"black\"\n";

/// Two peaked layers under index steps over glass: both corrected layers,
/// the lower one seen through the upper, reflected and transmitted exits.
const STACK: &str = "[light]\nkind = \"collimated\"\ntheta_deg = 40.0\n\
    [[layer]]\ntau = 0.8\nalbedo = 0.95\ng = 0.85\nn = 1.5\n\
    [[layer]]\ntau = 1.5\nalbedo = 0.8\ng = 0.7\nn = 1.33\n\
    [substrate]\nkind = \"transparent\"\nn = 1.5\n";

/// A slab so thin that nearly all its light is scattered once (the light
/// scattered twice is of relative order `tau`), between air and glass.
const THIN: &str = "[light]\nkind = \"collimated\"\ntheta_deg = 30.0\n\
    [[layer]]\ntau = 1e-4\nalbedo = 0.9\ng = 0.9\nn = 1.0\n\
    [substrate]\nkind = \"transparent\"\nn = 1.0\n";

/// `(brdf and btdf values, largest |value|, orders solved)` at `tol`.
fn at(scene: &MonoScene, streams: usize, tol: f64) -> (Vec<f64>, f64, usize) {
    let o = MultifluxOptions { streams: Some(streams), fourier_tol: tol, ..Default::default() };
    let (r, orders) = solve_mono(scene, &o).unwrap();
    let v: Vec<f64> = r.brdf.iter().chain(&r.btdf).copied().collect();
    let largest = v.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    (v, largest, orders)
}

fn worst(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

/// At each tolerance the values stay within `10 tol` of the largest value
/// of the full series. The bound: the rule stops where two consecutive
/// orders' rests are below `tol` of the largest value and the rests decay
/// from there on (measured: the error, relative to the largest value, is
/// 0.15-1.0 times `tol` for the slab and 0.01-0.09 for the stack at 1e-9
/// to 1e-3), so ten times leaves room without hiding the once-scattered
/// light of the orders after the stop: leaving that closed-form tail out
/// puts the slab 2.2e-7 of its largest value off at the default 1e-9.
#[test]
fn stopping_on_the_rest_keeps_the_values_within_the_tolerance() {
    for (name, text, streams) in [("slab", SLAB, 20), ("stack", STACK, 12)] {
        let s = mono(text);
        let (full, largest, all_orders) = at(&s, streams, 0.0);
        for tol in [1e-9, 1e-6, 1e-4, 1e-3] {
            let (v, _, orders) = at(&s, streams, tol);
            let e = worst(&v, &full) / largest;
            assert!(e <= 10.0 * tol, "{name} at {tol:e}: {e:.2e} of the largest value");
            assert!(orders <= all_orders, "{name} at {tol:e}: {orders} > {all_orders} orders");
        }
    }
}

/// The rule stops where the multiply scattered light has converged, not
/// the peaked single scattering: the g = 0.9 slab at 20 streams (40 orders
/// resolved) needs about a third of its orders at `1e-4` and fewer than all
/// at the default. Testing the whole coefficient instead (DISORT's rule)
/// stopped it at 37 orders at the default tolerance.
#[test]
fn the_rest_converges_faster_than_the_series() {
    let s = mono(SLAB);
    let (_, _, all_orders) = at(&s, 20, 0.0);
    let (_, _, default_orders) = at(&s, 20, km_multiflux::options::FOURIER_TOL);
    let (_, _, loose) = at(&s, 20, 1e-4);
    assert_eq!(all_orders, 40);
    assert!(default_orders <= 33, "{default_orders} orders at the default tolerance");
    assert!(loose <= 14, "{loose} orders at 1e-4");
}

/// Eq. 5i is the operators' own once-scattered light: in a slab of
/// optical thickness 1e-4 the rest of every order is of relative order
/// 1e-4, so at a tolerance of 1e-3 the series stops after order 2 (two
/// orders below it), where the whole coefficients would run through all
/// 40 orders of the peaked phase function; the values, reflected and
/// transmitted, stay within 1e-5 of the largest value of the full series
/// (a tenth of the light scattered more than once; measured 5.4e-6; 0.51
/// without the closed-form tail). A wrong sign, parity or normalisation in
/// eq. 5i leaves rests of the size of the coefficients, and the series
/// would not stop.
#[test]
fn a_thin_slab_is_its_closed_form() {
    let s = mono(THIN);
    let (full, largest, all_orders) = at(&s, 20, 0.0);
    let (v, _, orders) = at(&s, 20, 1e-3);
    assert_eq!(all_orders, 40);
    assert!(orders <= 3, "{orders} orders");
    let e = worst(&v, &full) / largest;
    assert!(e <= 1e-5, "{e:.2e} of the largest value");
}

/// The BSDF table's series (its own rule, over the whole table) ends the
/// same way: its values at a tolerance of 1e-4 stay within ten times that
/// of the largest value of the full table, with the orders after its stop
/// stored as the closed form.
#[test]
fn a_table_stops_on_the_rest_too() {
    let scene = Scene::from_toml_str(STACK).unwrap();
    let (theta_i, theta_o, phis) = ([0.0, 30.0, 60.0], [0.0, 25.0, 50.0, 75.0], [0.0, 90.0, 170.0]);
    let table = |tol: f64| {
        let solver = MultifluxOptions { streams: Some(12), fourier_tol: tol, ..Default::default() };
        let b =
            Bsdf::new(&scene, &theta_i, &theta_o, &BsdfOptions { solver, ..Default::default() })
                .unwrap();
        let mut v = Vec::new();
        for i in 0..theta_i.len() {
            for o in 0..theta_o.len() {
                for &p in &phis {
                    v.push(b.brdf(0, i, o, p));
                    v.push(b.btdf(0, i, o, p));
                }
            }
        }
        (v, b.orders(0))
    };
    let ((full, all_orders), (v, orders)) = (table(0.0), table(1e-4));
    assert_eq!(orders, all_orders, "the stored series runs to the last order either way");
    let largest = full.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    let e = worst(&v, &full) / largest;
    assert!(e <= 1e-3, "{e:.2e} of the largest value");
    assert!(e > 0.0, "the table stopped early");
}

/// A tolerance outside `[0, 0.1]` (or not a number) is refused by name.
#[test]
fn a_bad_tolerance_is_refused() {
    let s = Scene::from_toml_str(SLAB).unwrap();
    for tol in [-1e-3, 0.5, f64::NAN] {
        let o = MultifluxOptions { fourier_tol: tol, ..Default::default() };
        let e = km_multiflux::solve(&s, &o).unwrap_err().to_string();
        assert!(e.contains("fourier_tol"), "{tol}: {e}");
    }
}
