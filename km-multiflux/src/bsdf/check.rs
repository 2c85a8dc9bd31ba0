//! Checks of a BSDF table: energy, reciprocity, positivity (`docs/bsdf.md` §4).

use super::Bsdf;

/// Hemispherical integrals of the table per channel and incidence.
#[derive(Debug, Clone, PartialEq)]
pub struct Energy {
    /// `R_table + R_specular` per `[c * n_i + i]`.
    pub reflectance: Vec<f64>,
    /// `T_table + T_direct` (0 when opaque).
    pub transmittance: Vec<f64>,
    /// Largest `|table - solver|` over channels and incidences, R and T.
    pub max_error: f64,
}

/// Quadrature weights in `mu` for the exit cosines of `theta_o` (degrees):
/// the given Gauss weights when `theta_o` are the nodes of
/// [`super::gauss_angles`], else the trapezoid rule in `mu` on `[0, 1]`
/// with the integrand `mu f` taken as 0 at `mu = 0` and constant up to `mu = 1`.
fn mu_weights(theta_o: &[f64]) -> Vec<f64> {
    let (g, w) = super::gauss_angles(theta_o.len());
    if g.iter().zip(theta_o).all(|(a, b)| (a - b).abs() < 1e-12) {
        return w;
    }
    let mu: Vec<f64> = theta_o.iter().map(|t| t.to_radians().cos()).collect();
    let mut order: Vec<usize> = (0..mu.len()).collect();
    order.sort_by(|&a, &b| mu[a].total_cmp(&mu[b]));
    let mut w = vec![0.0; mu.len()];
    for (k, &j) in order.iter().enumerate() {
        let lo = if k == 0 { 0.0 } else { mu[order[k - 1]] };
        let hi = if k + 1 == order.len() { 1.0 } else { mu[order[k + 1]] };
        // Trapezoid: half the neighbouring intervals (the whole last one).
        let left = 0.5 * (mu[j] - lo);
        let right = if k + 1 == order.len() { hi - mu[j] } else { 0.5 * (hi - mu[j]) };
        w[j] = left + right;
    }
    w
}

/// Energy check (eq. B4 of `docs/bsdf.md`): the hemispherical integral of the
/// table, `2 pi sum_o w_o mu_o <f>_phi(mu_o)` with the azimuthal mean over a
/// uniform grid of `n_phi` azimuths (exact for the cosine series, spectrally
/// accurate for the correction), plus the delta parts, against the solver's
/// totals per incidence. Through a rough face it integrates the series
/// ([`Bsdf::eval_series_into`]): the exact single path (eq. R18 of
/// docs/rough.md) that the table adds has no azimuthal mean, and a lobe
/// narrower than the azimuth grid would only measure the grid.
///
/// # Reference
/// `docs/conventions.md` §3, eq. C3 (`R(mu0) = integral f_r mu dw`).
pub fn energy(b: &Bsdf, n_phi: usize) -> Energy {
    energy_weighted(b, &mu_weights(&b.theta_o), n_phi)
}

/// [`energy`] with explicit quadrature weights `w_mu` in `mu` for the exit
/// angles (e.g. a composite Gauss rule split at a critical angle, where the
/// BTDF jumps).
pub fn energy_weighted(b: &Bsdf, w_mu: &[f64], n_phi: usize) -> Energy {
    let n_phi = n_phi.max(4);
    let phi: Vec<f64> = (0..n_phi).map(|k| 360.0 * k as f64 / n_phi as f64).collect();
    let w = w_mu;
    let (ni, no) = (b.theta_i.len(), b.theta_o.len());
    let mut out = Energy { reflectance: vec![], transmittance: vec![], max_error: 0.0 };
    let mut buf = vec![0.0; n_phi];
    for (c, ch) in b.channels.iter().enumerate() {
        for i in 0..ni {
            let (mut r, mut t) = (0.0, 0.0);
            for o in 0..no {
                let mu = b.theta_o[o].to_radians().cos();
                b.eval_series_into(c, i, o, &phi, false, &mut buf);
                r += w[o] * mu * buf.iter().sum::<f64>() / n_phi as f64;
                if b.transmits {
                    b.eval_series_into(c, i, o, &phi, true, &mut buf);
                    t += w[o] * mu * buf.iter().sum::<f64>() / n_phi as f64;
                }
            }
            let r = 2.0 * std::f64::consts::PI * r + ch.reflectance_specular[i];
            let t = 2.0 * std::f64::consts::PI * t + ch.transmittance_direct[i];
            out.max_error = out
                .max_error
                .max((r - ch.reflectance[i]).abs())
                .max((t - ch.transmittance[i]).abs());
            out.reflectance.push(r);
            out.transmittance.push(t);
        }
    }
    out
}

/// Reciprocity of the BRDF, `f(i, o, phi) = f(o, i, phi)` (Helmholtz): the
/// largest `|f(i, o) - f(o, i)| / max(|f(i, o)|, |f(o, i)|, floor)` over the
/// pairs whose angles appear in both grids, at the azimuths `phi_deg`.
/// Returns `None` when no such pair exists.
///
/// # Reference
/// Chandrasekhar 1960 §7 (the reciprocity of the scattering function).
pub fn reciprocity(b: &Bsdf, phi_deg: &[f64], floor: f64) -> Option<f64> {
    let find = |t: f64| b.theta_o.iter().position(|x| (x - t).abs() < 1e-12);
    let findi = |t: f64| b.theta_i.iter().position(|x| (x - t).abs() < 1e-12);
    let mut worst: Option<f64> = None;
    let (mut u, mut v) = (vec![0.0; phi_deg.len()], vec![0.0; phi_deg.len()]);
    for c in 0..b.channels.len() {
        for (i, &ti) in b.theta_i.iter().enumerate() {
            let Some(o_of_i) = find(ti) else { continue };
            for (o, &to) in b.theta_o.iter().enumerate() {
                let Some(i_of_o) = findi(to) else { continue };
                b.eval_into(c, i, o, phi_deg, false, &mut u);
                b.eval_into(c, i_of_o, o_of_i, phi_deg, false, &mut v);
                for (x, y) in u.iter().zip(&v) {
                    let d = (x - y).abs() / x.abs().max(y.abs()).max(floor);
                    worst = Some(worst.map_or(d, |w: f64| w.max(d)));
                }
            }
        }
    }
    worst
}

/// Reciprocity across an index change (the `n^2` law, Nicodemus 1965):
/// `f_t(i -> o) / n_o^2 = f_t(o -> i) / n_i^2`, compared between a table lit
/// from above (`above`) and one lit from below (`below`) on the same grids;
/// largest relative deviation as in [`reciprocity`]. `None` when a table
/// does not transmit.
pub fn transmission_reciprocity(
    above: &Bsdf,
    below: &Bsdf,
    phi_deg: &[f64],
    floor: f64,
) -> Option<f64> {
    if !(above.transmits && below.transmits) {
        return None;
    }
    let (n_top, n_bot) = (above.n_in, above.n_out?);
    let find = |g: &[f64], t: f64| g.iter().position(|x| (x - t).abs() < 1e-12);
    let mut worst: Option<f64> = None;
    let (mut u, mut v) = (vec![0.0; phi_deg.len()], vec![0.0; phi_deg.len()]);
    for c in 0..above.channels.len() {
        for (i, &ti) in above.theta_i.iter().enumerate() {
            let Some(o2) = find(&below.theta_o, ti) else { continue };
            for (o, &to) in above.theta_o.iter().enumerate() {
                let Some(i2) = find(&below.theta_i, to) else { continue };
                above.eval_into(c, i, o, phi_deg, true, &mut u);
                below.eval_into(c, i2, o2, phi_deg, true, &mut v);
                for (x, y) in u.iter().zip(&v) {
                    let (x, y) = (x / (n_bot * n_bot), y / (n_top * n_top));
                    let d = (x - y).abs() / x.abs().max(y.abs()).max(floor);
                    worst = Some(worst.map_or(d, |w: f64| w.max(d)));
                }
            }
        }
    }
    worst
}

/// Where the table is negative (Fourier ringing of a truncated series, or a
/// correction that overshoots): never clamped, reported.
#[derive(Debug, Clone, PartialEq)]
pub struct Negatives {
    /// Number of negative table values (BRDF and BTDF).
    pub count: usize,
    /// Number of values looked at.
    pub total: usize,
    /// The most negative value and where: `(value, channel, theta_i, theta_o,
    /// phi, transmitted)`.
    pub worst: Option<(f64, usize, f64, f64, f64, bool)>,
}

/// Positivity check of the table at the azimuths `phi_deg`.
pub fn negatives(b: &Bsdf, phi_deg: &[f64]) -> Negatives {
    let (r, t) = b.table(phi_deg);
    let (ni, no, np) = (b.theta_i.len(), b.theta_o.len(), phi_deg.len());
    let mut out = Negatives { count: 0, total: 0, worst: None };
    for (tab, transmitted) in [(&r, false), (&t, true)] {
        if transmitted && !b.transmits {
            continue;
        }
        for (k, &v) in tab.iter().enumerate() {
            out.total += 1;
            if v < 0.0 {
                out.count += 1;
                if out.worst.is_none_or(|w| v < w.0) {
                    let p = k % np;
                    let o = (k / np) % no;
                    let i = (k / (np * no)) % ni;
                    let c = k / (np * no * ni);
                    out.worst = Some((v, c, b.theta_i[i], b.theta_o[o], phi_deg[p], transmitted));
                }
            }
        }
    }
    out
}
