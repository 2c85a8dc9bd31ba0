//! The phase functions of `km_core::phase` (docs/phase.md): every kind is
//! normalised (eq. P1), its moments are those of its values (eq. P2), its
//! sampler inverts its cumulative distribution, and its "two scatterings"
//! function has the squared moments; each against Gauss–Legendre quadrature
//! of the kind's own `eval` (exact to rounding for the smooth kinds at
//! 2000 nodes; the tolerances below are those of the quadrature).

use std::f64::consts::PI;
use std::sync::{Arc, Mutex};

use km_core::legendre::legendre_pair;
use km_core::phase::{
    LegendreSeries, Phase, PhaseFunction, PhaseTable, Rayleigh, ReynoldsMcCormick, TwoTermHg,
};
use km_core::quadrature::gauss_legendre;

/// A Gauss rule: nodes and weights.
type Rule = Arc<(Vec<f64>, Vec<f64>)>;

/// `2 pi integral f` on `[a, b]` by an `n`-point Gauss rule (rules cached).
fn integral(f: &dyn Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    static RULES: Mutex<Vec<(usize, Rule)>> = Mutex::new(Vec::new());
    let rule = {
        let mut r = RULES.lock().unwrap();
        match r.iter().find(|e| e.0 == n) {
            Some(e) => e.1.clone(),
            None => {
                let e = Arc::new(gauss_legendre(n));
                r.push((n, e.clone()));
                e
            }
        }
    };
    let (x, w) = (&rule.0, &rule.1);
    let (h, c) = (0.5 * (b - a), 0.5 * (b + a));
    2.0 * PI * h * x.iter().zip(w.iter()).map(|(xi, wi)| wi * f(c + h * xi)).sum::<f64>()
}

/// The smooth kinds of the scene file, each with a tolerance of its quadrature.
fn smooth_kinds() -> Vec<(&'static str, Phase)> {
    vec![
        ("hg 0.7", Phase::henyey_greenstein(0.7).unwrap()),
        ("two-term", Phase::TwoTermHg(TwoTermHg::new(0.85, -0.4, 0.8).unwrap())),
        ("rayleigh", Phase::Rayleigh(Rayleigh::new(0.0279).unwrap())),
        ("rm", Phase::ReynoldsMcCormick(Arc::new(ReynoldsMcCormick::new(0.75, 1.3).unwrap()))),
        (
            "legendre",
            Phase::Legendre(Arc::new(LegendreSeries::new(&[0.6, 0.4, 0.25, 0.1, 0.03]).unwrap())),
        ),
    ]
}

#[test]
fn every_kind_is_normalised_and_has_its_moments() {
    for (name, p) in smooth_kinds() {
        let norm = integral(&|c| p.eval(c), -1.0, 1.0, 2000);
        assert!((norm - 1.0).abs() < 1e-12, "{name}: norm {norm}");
        for l in [1usize, 2, 3, 6, 15] {
            let q = integral(&|c| p.eval(c) * legendre_pair(l, c).0, -1.0, 1.0, 2000);
            assert!(
                (q - p.legendre_moment(l)).abs() < 1e-12,
                "{name} chi_{l}: {q} vs {}",
                p.legendre_moment(l)
            );
        }
        assert_eq!(p.g(), p.legendre_moment(1));
    }
}

/// The sampler inverts the cumulative distribution from -1: the mass above
/// the sample is `1 - u` (the two-term lobe choice is not monotone in `u`:
/// checked lobe by lobe; its histogram is tested in km-montecarlo).
#[test]
fn samplers_invert_the_cumulative_distribution() {
    for (name, p) in smooth_kinds() {
        if name == "two-term" {
            continue;
        }
        for k in 1..20 {
            let u = k as f64 / 20.0;
            let c = p.sample_cos(u);
            let above = integral(&|x| p.eval(x), c, 1.0, 400);
            // The Legendre kind samples its interpolant (eq. P18): 1e-6.
            let tol = if name == "legendre" { 1e-6 } else { 1e-11 };
            assert!((above - (1.0 - u)).abs() < tol, "{name} u = {u}: {above}");
        }
    }
    // Two-term: u < w samples lobe 1 (a HG of g1), the rest lobe 2.
    let t = TwoTermHg::new(0.85, -0.4, 0.8).unwrap();
    let p = Phase::TwoTermHg(t);
    let hg1 = Phase::henyey_greenstein(0.85).unwrap();
    let hg2 = Phase::henyey_greenstein(-0.4).unwrap();
    assert_eq!(p.sample_cos(0.4), hg1.sample_cos(0.5));
    assert!((p.sample_cos(0.9) - hg2.sample_cos(0.5)).abs() < 1e-12);
}

/// `eval_convolved` has the moments `chi_l^2` (docs/multiflux.md eq. 5e).
#[test]
fn convolved_function_has_the_squared_moments() {
    for (name, p) in smooth_kinds() {
        for l in [0usize, 1, 2, 4, 9] {
            let q = integral(&|c| p.eval_convolved(c) * legendre_pair(l, c).0, -1.0, 1.0, 2000);
            let want = p.legendre_moment(l).powi(2);
            assert!((q - want).abs() < 1e-12, "{name} l = {l}: {q} vs {want}");
        }
    }
}

/// The interpolant of a series (eq. P18) is within 1e-5 of the series
/// wherever the series matters (checked on 4001 cosines), and
/// `eval_tabulated` uses it.
#[test]
fn series_interpolant_is_close() {
    // A peaked series: HG 0.9 truncated at 200 moments (positive, g^200 ~ 7e-10).
    let m: Vec<f64> = (1..=200).map(|l| 0.9f64.powi(l)).collect();
    let s = LegendreSeries::new(&m).unwrap();
    let p = Phase::Legendre(Arc::new(s.clone()));
    let (table, min) = s.lookup();
    assert!(*min > 0.0);
    let peak = s.eval(1.0);
    for k in 0..=4000 {
        let c = -1.0 + k as f64 / 2000.0;
        let (a, b) = (s.eval(c), table.eval(c));
        assert!((a - b).abs() <= 1e-5 * a + 1e-9 * peak, "c = {c}: {a} vs {b}");
        assert_eq!(p.eval_tabulated(c), b);
    }
    assert!(p.check_density().is_ok());
}

/// A truncated series that rings negative cannot be sampled: refused with
/// the least value named.
#[test]
fn negative_series_is_not_a_density() {
    let m: Vec<f64> = (1..=8).map(|l| 0.95f64.powi(l)).collect();
    let p = Phase::Legendre(Arc::new(LegendreSeries::new(&m).unwrap()));
    let e = p.check_density().unwrap_err().to_string();
    assert!(e.contains("negative"), "{e}");
}

/// A table is normalised by km and its moments are those of its interpolant;
/// given in angles or cosines, ascending or descending, it is the same.
#[test]
fn tables_are_normalised() {
    let th = [0.0f64, 10.0, 30.0, 60.0, 90.0, 120.0, 180.0];
    let pv = [50.0, 20.0, 4.0, 1.0, 0.6, 0.5, 0.7];
    let cos: Vec<f64> = th.iter().map(|t| t.to_radians().cos()).collect();
    let t = PhaseTable::new(&cos, &pv).unwrap();
    let p = Phase::Table(Arc::new(t.clone()));
    let norm = integral(&|c| p.eval(c), -1.0, 1.0, 4);
    // The interpolant is linear per interval: a 4-point rule per interval.
    let mut piecewise = 0.0;
    let mu = t.table().mu();
    for k in 0..mu.len() - 1 {
        piecewise += integral(&|c| p.eval(c), mu[k], mu[k + 1], 4);
    }
    assert!((piecewise - 1.0).abs() < 1e-13, "{piecewise} ({norm} unsplit)");
    assert!(t.given_norm() > 1.0);
    let ascending: Vec<f64> = cos.iter().rev().copied().collect();
    let pv_rev: Vec<f64> = pv.iter().rev().copied().collect();
    let u = PhaseTable::new(&ascending, &pv_rev).unwrap();
    assert_eq!(t, u);
    // Ratios of values are kept: p(0 deg)/p(180 deg) = 50/0.7.
    assert!((p.eval(1.0) / p.eval(-1.0) - 50.0 / 0.7).abs() < 1e-12);
}

#[test]
fn kinds_and_moments_report_themselves() {
    let r = Phase::Rayleigh(Rayleigh::new(0.0).unwrap());
    assert_eq!((r.kind(), r.g(), r.legendre_moment(2)), ("rayleigh", 0.0, 0.1));
    assert!(!r.is_isotropic() && r.finite_moments() == Some(3));
    assert_eq!(Phase::henyey_greenstein(0.0).unwrap().kind(), "isotropic");
    let l = Phase::Legendre(Arc::new(LegendreSeries::new(&[0.5, 0.0, 0.0]).unwrap()));
    assert_eq!(l.finite_moments(), Some(2));
    assert_eq!(l.stored_moments(), Some(&[1.0, 0.5][..]));
}

#[test]
fn bad_parameters_are_refused() {
    assert!(TwoTermHg::new(1.0, 0.0, 0.5).is_err());
    assert!(TwoTermHg::new(0.5, 0.0, -0.1).is_err());
    assert!(Rayleigh::new(1.5).is_err());
    assert!(ReynoldsMcCormick::new(0.0, 1.0).is_err());
    assert!(ReynoldsMcCormick::new(0.5, -0.5).is_err());
    assert!(LegendreSeries::new(&[0.5, f64::NAN]).is_err());
    assert!(LegendreSeries::new(&[1.0]).is_err());
    assert!(LegendreSeries::new(&[0.5, -1.5]).is_err());
}
