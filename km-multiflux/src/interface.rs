//! Smooth Fresnel interfaces and opaque substrates as layers (seed 000 §3.4).
//!
//! An interface between media `a` (above) and `b` (below) maps each node or
//! extra direction of `a` onto the node of `b` with the same Snell invariant
//! (see [`crate::quadrature`]), so its operators are diagonal:
//!
//! ```text
//!   r_top = R_F(mu_a),  t_down = (1 - R_F) (n_b/n_a)^2                    (F1)
//!   r_bottom = R_F(mu_b),  t_up = (1 - R_F) (n_a/n_b)^2
//! ```
//!
//! for radiances (the `n^2` law of radiance), and without the `n^2` factor for
//! the collimated beam, whose value is an irradiance on a horizontal plane.
//! Directions that exist in only one medium are totally reflected (`R_F = 1`).
//! `R_F` is the unpolarised Fresnel reflectance of `km_core::fresnel`.
//!
//! A Lambertian substrate of albedo `A` (order `m = 0` only) reflects every
//! incident flux `F = 2 pi sum_j w_j mu_j I_j (+ beam)` into the radiance
//! `A F / pi` in every up-going direction:  `r_top = A [2 w_j mu_j | 1]`  (F2).

use faer::Mat;
use km_core::fresnel::reflectance;

use crate::adding::LayerOperators;
use crate::quadrature::MediumNodes;
use crate::slab::Extra;

/// Operators of the smooth interface from medium `a` (above) to `b` (below),
/// on the augmented spaces `[nodes, extras]` of each medium (eq. F1).
pub fn fresnel_operators(
    a: &MediumNodes,
    b: &MediumNodes,
    ea: &[Extra],
    eb: &[Extra],
) -> LayerOperators {
    let (na, nb) = (a.mu.len(), b.mu.len());
    let ne = ea.len();
    let (da, db) = (na + ne, nb + ne);
    let mut r_top = Mat::<f64>::zeros(da, da);
    let mut t_down = Mat::<f64>::zeros(db, da);
    let mut r_bottom = Mat::<f64>::zeros(db, db);
    let mut t_up = Mat::<f64>::zeros(da, db);
    // One direction: indices ia / ib on each side (None = absent there).
    let mut set = |ia: Option<(usize, f64)>, ib: Option<(usize, f64)>, radiance: bool| {
        let [rt, td, rb, tu] =
            fresnel_entries(ia.map(|x| x.1), ib.map(|x| x.1), a.n, b.n, radiance);
        if let Some((i, _)) = ia {
            r_top[(i, i)] = rt;
        }
        if let Some((j, _)) = ib {
            r_bottom[(j, j)] = rb;
        }
        if let (Some((i, _)), Some((j, _))) = (ia, ib) {
            t_down[(j, i)] = td;
            t_up[(i, j)] = tu;
        }
    };
    for g in 0..na.max(nb) {
        let ia = (g < na).then(|| (g, a.mu[g]));
        let ib = (g < nb).then(|| (g, b.mu[g]));
        set(ia, ib, true);
    }
    for e in 0..ne {
        let ia = ea[e].mu.map(|m| (na + e, m));
        let ib = eb[e].mu.map(|m| (nb + e, m));
        set(ia, ib, !ea[e].beam);
    }
    LayerOperators { r_top, t_down, r_bottom, t_up }
}

/// The four entries `[r_top, t_down, r_bottom, t_up]` of eq. F1 for one
/// direction of cosine `mu_a` above (index `n_a`) and `mu_b` below (`n_b`),
/// `None` where it cannot propagate (total reflection on the other side);
/// `radiance` applies the `n^2` law (false for a beam's irradiance).
pub fn fresnel_entries(
    mu_a: Option<f64>,
    mu_b: Option<f64>,
    n_a: f64,
    n_b: f64,
    radiance: bool,
) -> [f64; 4] {
    match (mu_a, mu_b) {
        (Some(mu_a), Some(mu_b)) => {
            let ratio2 = (n_b / n_a) * (n_b / n_a);
            let ra = reflectance(mu_a, n_a, n_b);
            let rb = reflectance(mu_b, n_b, n_a);
            let (fd, fu) = if radiance { (ratio2, 1.0 / ratio2) } else { (1.0, 1.0) };
            [ra, (1.0 - ra) * fd, rb, (1.0 - rb) * fu]
        }
        (Some(_), None) => [1.0, 0.0, 0.0, 0.0],
        (None, Some(_)) => [0.0, 0.0, 1.0, 0.0],
        (None, None) => [0.0; 4],
    }
}

/// Reflection operator of a Lambertian substrate of albedo `albedo` for
/// Fourier order `m` (eq. F2; zero for `m > 0`), on `[nodes, extras]`.
pub fn lambertian_reflection(
    nodes: &MediumNodes,
    extras: &[Extra],
    albedo: f64,
    m: usize,
) -> Mat<f64> {
    let n = nodes.mu.len();
    let dim = n + extras.len();
    let mut r = Mat::<f64>::zeros(dim, dim);
    if m != 0 || albedo == 0.0 {
        return r;
    }
    // Flux weight of each incoming component.
    let col: Vec<f64> = (0..dim)
        .map(|j| {
            if j < n {
                2.0 * nodes.w[j] * nodes.mu[j]
            } else {
                let ex = &extras[j - n];
                match (ex.mu, ex.beam) {
                    (Some(_), true) => 1.0 / std::f64::consts::PI,
                    _ => 0.0,
                }
            }
        })
        .collect();
    for i in 0..dim {
        // Out-going radiance: every node and every present probe (not the beam).
        let out = if i < n {
            true
        } else {
            let ex = &extras[i - n];
            ex.mu.is_some() && !ex.beam
        };
        if !out {
            continue;
        }
        for j in 0..dim {
            r[(i, j)] = albedo * col[j];
        }
    }
    r
}
