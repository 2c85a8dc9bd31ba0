//! The forward model's delta parts against closed forms (Fresnel + Beer–Lambert).

use km_inverse::forward::{
    Optical, Sample, boundary, tau_from_unscattered, totals, unscattered_transmittance,
};

/// The specular reflection and unscattered transmission of km's multi-flux
/// solver against eq. F1–F2 (independent: closed forms, no quadrature).
/// Tolerance 1e-12: both are exact sums of the same geometric series.
#[test]
fn delta_parts_match_closed_forms() {
    for slide in [None, Some(1.5)] {
        for n in [1.0, 1.33, 1.4] {
            for b in [0.1, 2.0, 8.0] {
                let s = Sample::new(1.0, n, slide).unwrap();
                let t = totals(&s, &Optical { albedo: 0.9, tau: b, g: 0.5 }, 8, false).unwrap();
                let (r12, t12) = boundary(n, slide);
                let x = (-2.0 * b).exp();
                let r_u = r12 + t12 * t12 * r12 * x / (1.0 - r12 * r12 * x);
                assert!((t.r_specular - r_u).abs() < 1e-12, "{n} {slide:?} {b}");
                let t_u = unscattered_transmittance(n, slide, b);
                assert!((t.t_unscattered - t_u).abs() < 1e-12 * t_u.max(1e-3));
                assert!((tau_from_unscattered(t_u, n, slide).unwrap() - b).abs() < 1e-10 * b);
            }
        }
    }
}

/// A non-scattering sample: M_R is the specular part only and the total
/// transmission is the unscattered beam (energy: R + T = 1 at a = 1, b = 0+).
#[test]
fn limits() {
    let s = Sample::new(1.0, 1.4, Some(1.5)).unwrap();
    let t = totals(&s, &Optical { albedo: 0.0, tau: 1.0, g: 0.0 }, 8, false).unwrap();
    assert!((t.r_total - t.r_specular).abs() < 1e-14);
    assert!((t.t_total - t.t_unscattered).abs() < 1e-14);
    let t = totals(&s, &Optical { albedo: 1.0, tau: 3.0, g: 0.7 }, 16, true).unwrap();
    assert!((t.r_total + t.t_total - 1.0).abs() < 1e-10);
    assert!((t.r_diffuse + t.t_diffuse - 1.0).abs() < 1e-10);
}
