//! Adding of layers whose operators carry probes: exit directions of zero
//! quadrature weight that receive light but never give any back.
//!
//! # Why a structure
//!
//! The solver carries, besides the quadrature nodes, extra directions
//! (`docs/multiflux.md` §5): collimated beams, which scatter into the nodes,
//! and probes (an exit direction of the user's, or a marker of the BSDF's
//! single-scattering correction), which only receive. Written as one dense
//! operator on `[nodes, beams, probes]` the star product costs
//! `O((N + P)^3)` for `P` probes: a thousand exit directions made `km solve`
//! slower than the whole BSDF table. Because a probe gives nothing back,
//! every operator has the block form
//!
//! ```text
//!          core   probe
//!   core [ K_cc     0   ]        K_cc: nodes and beams, dense
//!   probe[ K_pc  diag k ]        K_pc: the probe's row, k: probe -> same probe    (PA1)
//! ```
//!
//! (the diagonal is the probe's own path: attenuation, a Fresnel reflection
//! or transmission of that direction), and so is `X = I - R1' R2` of eq. A3.
//! Its inverse is block lower triangular, and the star product costs
//! `O(N^3 + P N^2)`: linear in the number of probes.
//!
//! # The star product with probes (eq. A4 extended)
//!
//! With the core adding's `X^-1 T1` (`XT1`) and `X^-1 R1' T2'` (`XR`), the
//! core streams at the common boundary are `d = XT1 a + XR b`,
//! `u = Ua a + Ub b` with `Ua = R2 XT1`, `Ub = R2 XR + T2'`. Per probe, with
//! `x = 1 - r1' r2` of its diagonal entries (`r1'` of the top layer's
//! `r_bottom`, `r2` of the bottom layer's `r_top`, and so on), its down- and
//! up-going streams at the boundary are
//!
//! ```text
//!   DPa = [T1_p + R1'_p Ua + r1' R2_p XT1] / x
//!   DPb = [R1'_p Ub + r1' (R2_p XR + T2'_p)] / x                        (PA2)
//!   UPa = R2_p XT1 + r2 DPa,     UPb = R2_p XR + T2'_p + r2 DPb
//! ```
//!
//! (`K_p`: the probe's row of operator `K`), and the probe rows of the sum are
//!
//! ```text
//!   r_top_p    = R1_p + T1'_p Ua + t1' UPa,   t_up_p   = T1'_p Ub + t1' UPb
//!   t_down_p   = T2_p XT1 + t2 DPa,           r_bottom_p = T2_p XR + R2'_p + t2 DPb   (PA3)
//! ```
//!
//! with the diagonal of the scalar star product (eq. A4 for `1 x 1` operators):
//! `r_top = r1 + t1' r2 t1 / x`, `t_down = t2 t1 / x`,
//! `r_bottom = r2' + t2 r1' t2' / x`, `t_up = t1' t2' / x`.
//!
//! The truncated series of eq. 21 keeps, for the block lower triangular
//! `M = R1' R2`, the terms `M^0 .. M^k` of the whole vector (core and probes):
//! [`add_truncated`] applies them block by block, so that it equals the dense
//! truncated adding (test `probed_adding_equals_dense_adding`).

use faer::Mat;

use super::{LayerOperators, add_parts, add_truncated_parts};
use crate::MultifluxError;

/// The probes' part of an augmented operator: for `P` probes, their rows in
/// the core columns of each operator and their own diagonal (eq. PA1).
#[derive(Debug, Clone, PartialEq)]
pub struct ProbeRows {
    /// Up-going probes above from the down-going core above (`P x D_a`).
    pub r_top: Mat<f64>,
    /// Down-going probes below from the down-going core above (`P x D_a`).
    pub t_down: Mat<f64>,
    /// Down-going probes below from the up-going core below (`P x U_b`).
    pub r_bottom: Mat<f64>,
    /// Up-going probes above from the up-going core below (`P x U_b`).
    pub t_up: Mat<f64>,
    /// Each probe into itself: `[r_top, t_down, r_bottom, t_up]`, `P` each.
    pub diag: [Vec<f64>; 4],
}

impl ProbeRows {
    /// No probe, for a core of `d_a` down-going streams above and `u_b`
    /// up-going streams below.
    pub fn none(d_a: usize, u_b: usize) -> ProbeRows {
        ProbeRows {
            r_top: Mat::zeros(0, d_a),
            t_down: Mat::zeros(0, d_a),
            r_bottom: Mat::zeros(0, u_b),
            t_up: Mat::zeros(0, u_b),
            diag: Default::default(),
        }
    }

    /// `P` probes with zero rows and zero diagonals.
    pub fn zeros(p: usize, d_a: usize, u_b: usize) -> ProbeRows {
        ProbeRows {
            r_top: Mat::zeros(p, d_a),
            t_down: Mat::zeros(p, d_a),
            r_bottom: Mat::zeros(p, u_b),
            t_up: Mat::zeros(p, u_b),
            diag: [vec![0.0; p], vec![0.0; p], vec![0.0; p], vec![0.0; p]],
        }
    }

    /// The number of probes.
    pub fn len(&self) -> usize {
        self.diag[0].len()
    }

    /// Whether there is no probe.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The operators of a layer on the core (nodes and beams, dense) and on its
/// probes (rows and diagonal, eq. PA1).
#[derive(Debug, Clone, PartialEq)]
pub struct Augmented {
    /// Nodes and beams.
    pub core: LayerOperators,
    /// The probes (the same directions, by Snell invariant, on both sides).
    pub probes: ProbeRows,
}

impl Augmented {
    /// Operators without probes.
    pub fn core_only(core: LayerOperators) -> Augmented {
        let probes = ProbeRows::none(core.r_top.ncols(), core.t_up.ncols());
        Augmented { core, probes }
    }

    /// Split dense operators on `[core, probes]` (the probes last on both
    /// sides; `core_a`, `core_b` the core sizes above and below, the same for
    /// the down- and up-going vectors of a side) into core and probe parts.
    ///
    /// # Errors
    /// [`MultifluxError::Shape`] when the probe count differs between the
    /// sides, or when the dense operators are not of the form of eq. PA1 (a
    /// probe feeding the core, or two probes coupled).
    pub fn from_dense(
        ops: &LayerOperators,
        core_a: usize,
        core_b: usize,
    ) -> Result<Augmented, MultifluxError> {
        let (d_a, _, d_b, _) = ops.sizes()?;
        let shape = |detail: String| MultifluxError::Shape { what: "Augmented", detail };
        if d_a < core_a || d_b < core_b || d_a - core_a != d_b - core_b {
            return Err(shape(format!("sides of {d_a} and {d_b} with cores {core_a}, {core_b}")));
        }
        let p = d_a - core_a;
        let block =
            |m: &Mat<f64>, rows: usize, cols: usize| Mat::from_fn(rows, cols, |i, j| m[(i, j)]);
        let core = LayerOperators {
            r_top: block(&ops.r_top, core_a, core_a),
            t_down: block(&ops.t_down, core_b, core_a),
            r_bottom: block(&ops.r_bottom, core_b, core_b),
            t_up: block(&ops.t_up, core_a, core_b),
        };
        // Rows of the probes (after the core rows of the output side).
        let rows =
            |m: &Mat<f64>, r0: usize, cols: usize| Mat::from_fn(p, cols, |i, j| m[(r0 + i, j)]);
        let diag = |m: &Mat<f64>, r0: usize, c0: usize| {
            (0..p).map(|i| m[(r0 + i, c0 + i)]).collect::<Vec<f64>>()
        };
        // The form of eq. PA1: nothing from a probe into the core, nor into another probe.
        let pa1 = |m: &Mat<f64>, r0: usize, c0: usize| {
            (0..p)
                .all(|j| (0..m.nrows()).all(|i| (i >= r0 && i - r0 == j) || m[(i, c0 + j)] == 0.0))
        };
        let all = [
            (&ops.r_top, core_a, core_a),
            (&ops.t_down, core_b, core_a),
            (&ops.r_bottom, core_b, core_b),
            (&ops.t_up, core_a, core_b),
        ];
        if !all.iter().all(|(m, r0, c0)| pa1(m, *r0, *c0)) {
            return Err(shape("a probe feeds the core or another probe".into()));
        }
        let probes = ProbeRows {
            r_top: rows(&ops.r_top, core_a, core_a),
            t_down: rows(&ops.t_down, core_b, core_a),
            r_bottom: rows(&ops.r_bottom, core_b, core_b),
            t_up: rows(&ops.t_up, core_a, core_b),
            diag: [
                diag(&ops.r_top, core_a, core_a),
                diag(&ops.t_down, core_b, core_a),
                diag(&ops.r_bottom, core_b, core_b),
                diag(&ops.t_up, core_a, core_b),
            ],
        };
        Ok(Augmented { core, probes })
    }

    /// The dense operators on `[core, probes]` (for tests and small cases).
    pub fn to_dense(&self) -> LayerOperators {
        let p = self.probes.len();
        let c = &self.core;
        let dense = |k: &Mat<f64>, rows: &Mat<f64>, d: &[f64]| {
            let (r, cc) = (k.nrows(), k.ncols());
            Mat::from_fn(r + p, cc + p, |i, j| match (i < r, j < cc) {
                (true, true) => k[(i, j)],
                (false, true) => rows[(i - r, j)],
                (false, false) if i - r == j - cc => d[i - r],
                _ => 0.0,
            })
        };
        let pr = &self.probes;
        LayerOperators {
            r_top: dense(&c.r_top, &pr.r_top, &pr.diag[0]),
            t_down: dense(&c.t_down, &pr.t_down, &pr.diag[1]),
            r_bottom: dense(&c.r_bottom, &pr.r_bottom, &pr.diag[2]),
            t_up: dense(&c.t_up, &pr.t_up, &pr.diag[3]),
        }
    }
}

/// `m` with row `i` multiplied by `d[i]`, added to `acc` (`acc += diag(d) m`).
fn add_scaled_rows(acc: &mut Mat<f64>, d: &[f64], m: &Mat<f64>) {
    for j in 0..m.ncols() {
        let (a, x) = (acc.col_as_slice_mut(j), m.col_as_slice(j));
        for i in 0..d.len() {
            a[i] += d[i] * x[i];
        }
    }
}

/// `diag(1 / x) m`, where a zero `x` (a probe trapped between two total
/// reflections with nothing between) takes only zero rows: nothing enters
/// it. A trapped probe that something would feed is refused.
fn divide_rows(m: &mut Mat<f64>, x: &[f64]) -> Result<(), MultifluxError> {
    for j in 0..m.ncols() {
        let col = m.col_as_slice_mut(j);
        for i in 0..x.len() {
            if x[i] != 0.0 {
                col[i] /= x[i];
            } else if col[i] != 0.0 {
                return Err(MultifluxError::Numerical {
                    what: "adding",
                    detail: "a probe direction is trapped between two total reflections".into(),
                });
            }
        }
    }
    Ok(())
}

/// `a / x`, or 0 where `x = 0` and `a = 0` (see [`divide_rows`]).
fn divide(a: f64, x: f64) -> Result<f64, MultifluxError> {
    if x != 0.0 {
        Ok(a / x)
    } else if a == 0.0 {
        Ok(0.0)
    } else {
        Err(MultifluxError::Numerical {
            what: "adding",
            detail: "a probe direction is trapped between two total reflections".into(),
        })
    }
}

/// The diagonal of the sum (scalar star product, eq. A4 with `1 x 1` operators).
fn add_diagonal(top: &ProbeRows, bottom: &ProbeRows) -> Result<[Vec<f64>; 4], MultifluxError> {
    let p = top.len();
    let [r1, t1, r1p, t1p] = &top.diag;
    let [r2, t2, r2p, t2p] = &bottom.diag;
    let mut out: [Vec<f64>; 4] = [vec![0.0; p], vec![0.0; p], vec![0.0; p], vec![0.0; p]];
    for i in 0..p {
        let x = 1.0 - r1p[i] * r2[i];
        out[0][i] = r1[i] + t1p[i] * r2[i] * divide(t1[i], x)?;
        out[1][i] = t2[i] * divide(t1[i], x)?;
        out[2][i] = r2p[i] + t2[i] * r1p[i] * divide(t2p[i], x)?;
        out[3][i] = t1p[i] * divide(t2p[i], x)?;
    }
    Ok(out)
}

/// Check that the probe parts of `top` and `bottom` fit their cores.
fn check_probes(top: &Augmented, bottom: &Augmented) -> Result<(), MultifluxError> {
    let (d_a, _, d_b, u_b) = top.core.sizes()?;
    let (_, _, _, u_b2) = bottom.core.sizes()?;
    let fits = |pr: &ProbeRows, d: usize, u: usize| {
        let p = pr.len();
        [&pr.r_top, &pr.t_down].iter().all(|m| m.nrows() == p && m.ncols() == d)
            && [&pr.r_bottom, &pr.t_up].iter().all(|m| m.nrows() == p && m.ncols() == u)
            && pr.diag.iter().all(|v| v.len() == p)
    };
    if top.probes.len() != bottom.probes.len()
        || !fits(&top.probes, d_a, u_b)
        || !fits(&bottom.probes, d_b, u_b2)
    {
        return Err(MultifluxError::Shape {
            what: "adding",
            detail: format!(
                "probe parts do not fit: {} probes above, {} below",
                top.probes.len(),
                bottom.probes.len()
            ),
        });
    }
    Ok(())
}

/// Exact adding of two augmented layers (eq. A4 on the core, eq. PA2–PA3 on
/// the probes).
///
/// # Errors
/// As [`super::add`]; a probe trapped between total reflections that
/// something would feed.
pub fn add(top: &Augmented, bottom: &Augmented) -> Result<Augmented, MultifluxError> {
    check_probes(top, bottom)?;
    let (core, xt1, xr) = add_parts(&top.core, &bottom.core)?;
    if top.probes.is_empty() {
        return Ok(Augmented::core_only(core));
    }
    let (t, b) = (&top.probes, &bottom.probes);
    let (r2, t2p) = (&bottom.core.r_top, &bottom.core.t_up);
    // Core streams at the common boundary, up-going: u = Ua a + Ub b.
    let ua = r2 * &xt1;
    let mut ub = r2 * &xr;
    ub += t2p;
    // The probes' own round trip between the two layers.
    let x: Vec<f64> = (0..t.len()).map(|i| 1.0 - t.diag[2][i] * b.diag[0][i]).collect();
    // Down-going probes at the boundary (eq. PA2).
    let r2p_xt1 = &b.r_top * &xt1;
    let mut r2p_xr = &b.r_top * &xr;
    r2p_xr += &b.t_up;
    let mut dpa = &t.t_down + &t.r_bottom * &ua;
    add_scaled_rows(&mut dpa, &t.diag[2], &r2p_xt1);
    divide_rows(&mut dpa, &x)?;
    let mut dpb = &t.r_bottom * &ub;
    add_scaled_rows(&mut dpb, &t.diag[2], &r2p_xr);
    divide_rows(&mut dpb, &x)?;
    // Up-going probes at the boundary.
    let mut upa = r2p_xt1;
    add_scaled_rows(&mut upa, &b.diag[0], &dpa);
    let mut upb = r2p_xr;
    add_scaled_rows(&mut upb, &b.diag[0], &dpb);
    Ok(Augmented { core, probes: sum_rows(t, b, (&ua, &ub, &xt1, &xr), (dpa, dpb, upa, upb))? })
}

/// The probe rows of the sum (eq. PA3) from the boundary streams.
fn sum_rows(
    t: &ProbeRows,
    b: &ProbeRows,
    (ua, ub, xt1, xr): (&Mat<f64>, &Mat<f64>, &Mat<f64>, &Mat<f64>),
    (dpa, dpb, upa, upb): (Mat<f64>, Mat<f64>, Mat<f64>, Mat<f64>),
) -> Result<ProbeRows, MultifluxError> {
    let mut r_top = &t.r_top + &t.t_up * ua;
    add_scaled_rows(&mut r_top, &t.diag[3], &upa);
    let mut t_up = &t.t_up * ub;
    add_scaled_rows(&mut t_up, &t.diag[3], &upb);
    let mut t_down = &b.t_down * xt1;
    add_scaled_rows(&mut t_down, &b.diag[1], &dpa);
    let mut r_bottom = &b.t_down * xr;
    r_bottom += &b.r_bottom;
    add_scaled_rows(&mut r_bottom, &b.diag[1], &dpb);
    Ok(ProbeRows { r_top, t_down, r_bottom, t_up, diag: add_diagonal(t, b)? })
}

/// Adding truncated after `order` round trips (seed eq. 21) of two augmented
/// layers: the Neumann series of the block lower triangular `X` applied to
/// the core and the probes together.
///
/// # Errors
/// As [`super::add_truncated`].
pub fn add_truncated(
    top: &Augmented,
    bottom: &Augmented,
    order: usize,
) -> Result<Augmented, MultifluxError> {
    check_probes(top, bottom)?;
    let (core, xt1, xr, yt2) = add_truncated_parts(&top.core, &bottom.core, order)?;
    if top.probes.is_empty() {
        return Ok(Augmented::core_only(core));
    }
    let (t, b) = (&top.probes, &bottom.probes);
    let (r1p, r2, t2p) = (&top.core.r_bottom, &bottom.core.r_top, &bottom.core.t_up);
    let p = t.len();
    // Round trip down -> up -> down: core block R1' R2, probe rows
    // C = R1'_p R2 + r1' R2_p, probe diagonal r1' r2 (and up -> down -> up).
    let down = Trip {
        first: r1p,
        second: r2,
        first_p: &t.r_bottom,
        second_p: &b.r_top,
        first_d: &t.diag[2],
        second_d: &b.diag[0],
    };
    let up = Trip {
        first: r2,
        second: r1p,
        first_p: &b.r_top,
        second_p: &t.r_bottom,
        first_d: &b.diag[0],
        second_d: &t.diag[2],
    };
    // Down-going at the boundary from above: series applied to (T1, T1_p).
    let dpa = down.series_rows(&top.core.t_down, &t.t_down, order);
    // ... from below: series applied to (R1' T2', R1'_p T2' + r1' T2'_p).
    let mut rhs = &t.r_bottom * t2p;
    add_scaled_rows(&mut rhs, &t.diag[2], &b.t_up);
    let dpb = down.series_rows(&(r1p * t2p), &rhs, order);
    // Up-going at the boundary from above: u = R2 d (d truncated).
    let ua = r2 * &xt1;
    let mut upa = &b.r_top * &xt1;
    add_scaled_rows(&mut upa, &b.diag[0], &dpa);
    // ... from below for t_up: its own series applied to (T2', T2'_p).
    let upb = up.series_rows(t2p, &b.t_up, order);
    let mut r_top = &t.r_top + &t.t_up * &ua;
    add_scaled_rows(&mut r_top, &t.diag[3], &upa);
    let mut t_up = &t.t_up * &yt2;
    add_scaled_rows(&mut t_up, &t.diag[3], &upb);
    let mut t_down = &b.t_down * &xt1;
    add_scaled_rows(&mut t_down, &b.diag[1], &dpa);
    let mut r_bottom = &b.t_down * &xr;
    r_bottom += &b.r_bottom;
    add_scaled_rows(&mut r_bottom, &b.diag[1], &dpb);
    // The diagonal: each probe a scalar layer, series truncated likewise.
    let mut diag: [Vec<f64>; 4] = [vec![0.0; p], vec![0.0; p], vec![0.0; p], vec![0.0; p]];
    let [r1, t1, r1pd, t1p] = &t.diag;
    let [r2d, t2, r2pd, t2pd] = &b.diag;
    for i in 0..p {
        let q = r1pd[i] * r2d[i];
        let s: f64 = (0..=order).map(|j| q.powi(j as i32)).sum();
        diag[0][i] = r1[i] + t1p[i] * r2d[i] * s * t1[i];
        diag[1][i] = t2[i] * s * t1[i];
        diag[2][i] = r2pd[i] + t2[i] * s * r1pd[i] * t2pd[i];
        diag[3][i] = t1p[i] * s * t2pd[i];
    }
    Ok(Augmented { core, probes: ProbeRows { r_top, t_down, r_bottom, t_up, diag } })
}

/// One round trip between two layers for the truncated series: `first`
/// after `second` on the core, with the probe rows and diagonals of each.
struct Trip<'a> {
    first: &'a Mat<f64>,
    second: &'a Mat<f64>,
    first_p: &'a Mat<f64>,
    second_p: &'a Mat<f64>,
    first_d: &'a [f64],
    second_d: &'a [f64],
}

impl Trip<'_> {
    /// The probe rows of `sum_{j<=order} M^j [c; p]` for the block lower
    /// triangular round trip `M` (core `F S`, probe rows `F_p S + f S_p`,
    /// diagonal `f s`).
    fn series_rows(&self, c: &Mat<f64>, p: &Mat<f64>, order: usize) -> Mat<f64> {
        let mut term_c = c.clone();
        let mut term_p = p.clone();
        let mut acc = p.clone();
        for _ in 0..order {
            let s_c = self.second * &term_c;
            // Probe rows of the next term (from the current core term).
            let mut next_p = self.first_p * &s_c;
            let s_p = self.second_p * &term_c;
            add_scaled_rows(&mut next_p, self.first_d, &s_p);
            let ds: Vec<f64> = self.first_d.iter().zip(self.second_d).map(|(f, s)| f * s).collect();
            add_scaled_rows(&mut next_p, &ds, &term_p);
            term_c = self.first * &s_c;
            term_p = next_p;
            acc += &term_p;
        }
        acc
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pseudo-random augmented layer: a core of `c` streams each way and
    /// `p` probes; non-negative, leaking light; one probe totally reflected
    /// from below (`r_bottom = 1`, `t = 0`) when `mirror`.
    fn layer(c: usize, p: usize, seed: u64, mirror: bool) -> Augmented {
        let mut s = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let mut rnd = move || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 11) as f64) / ((1u64 << 53) as f64)
        };
        let scale = 0.9 / (2.0 * c as f64);
        let mut m = |r: usize, k: usize| Mat::from_fn(r, k, |_, _| rnd() * scale);
        let core =
            LayerOperators { r_top: m(c, c), t_down: m(c, c), r_bottom: m(c, c), t_up: m(c, c) };
        let mut probes = ProbeRows {
            r_top: m(p, c),
            t_down: m(p, c),
            r_bottom: m(p, c),
            t_up: m(p, c),
            diag: Default::default(),
        };
        let mut d = || (0..p).map(|_| 0.45 * rnd()).collect::<Vec<f64>>();
        probes.diag = [d(), d(), d(), d()];
        if mirror && p > 0 {
            probes.diag[2][0] = 1.0;
            probes.diag[1][0] = 0.0;
            probes.diag[3][0] = 0.0;
        }
        Augmented { core, probes }
    }

    fn max_diff(a: &LayerOperators, b: &LayerOperators) -> f64 {
        let mut d = 0.0f64;
        for (x, y) in [
            (&a.r_top, &b.r_top),
            (&a.t_down, &b.t_down),
            (&a.r_bottom, &b.r_bottom),
            (&a.t_up, &b.t_up),
        ] {
            assert_eq!((x.nrows(), x.ncols()), (y.nrows(), y.ncols()));
            for j in 0..x.ncols() {
                for i in 0..x.nrows() {
                    d = d.max((x[(i, j)] - y[(i, j)]).abs());
                }
            }
        }
        d
    }

    /// The structured star product against the dense one of the same
    /// operators (eq. A4 on `[core, probes]`): equal to rounding (1e-14 on
    /// entries of order 0.1-1), exact and truncated at several orders; and
    /// the conversion to and from the dense form.
    #[test]
    fn probed_adding_equals_dense_adding() {
        for (c, p) in [(1, 1), (3, 5), (6, 2), (4, 0)] {
            for mirror in [false, true] {
                let (a, b) = (layer(c, p, 3 + c as u64, mirror), layer(c, p, 17 + p as u64, false));
                let (da, db) = (a.to_dense(), b.to_dense());
                assert_eq!(Augmented::from_dense(&da, c, c).unwrap(), a);
                let want = crate::adding::add(&da, &db).unwrap();
                let got = add(&a, &b).unwrap();
                assert!(max_diff(&got.to_dense(), &want) < 1e-14, "exact c={c} p={p}");
                for k in [0, 1, 3] {
                    let want = crate::adding::add_truncated(&da, &db, k).unwrap();
                    let got = add_truncated(&a, &b, k).unwrap();
                    let d = max_diff(&got.to_dense(), &want);
                    assert!(d < 1e-14, "order {k} c={c} p={p}: {d:e}");
                }
            }
        }
    }

    /// A probe coupled to another probe or feeding the core is not of the
    /// form of eq. PA1: refused.
    #[test]
    fn dense_operators_not_of_the_probe_form_are_refused() {
        let a = layer(2, 2, 5, false);
        let mut d = a.to_dense();
        d.t_down[(2, 3)] = 0.1; // probe 1 into probe 0
        assert!(Augmented::from_dense(&d, 2, 2).is_err());
        let mut d = a.to_dense();
        d.r_top[(0, 2)] = 0.1; // probe 0 into the core
        assert!(Augmented::from_dense(&d, 2, 2).is_err());
    }

    /// Two facing total reflections of a probe with nothing to feed it: the
    /// probe is trapped and stays dark; the same with a source is refused.
    #[test]
    fn trapped_probe_is_dark_or_refused() {
        let mut a = layer(2, 1, 9, true);
        let mut b = layer(2, 1, 10, false);
        b.probes.diag[0][0] = 1.0; // the bottom reflects the probe totally from above
        a.probes.t_down = Mat::zeros(1, 2);
        a.probes.r_bottom = Mat::zeros(1, 2);
        b.probes.r_top = Mat::zeros(1, 2);
        b.probes.t_up = Mat::zeros(1, 2);
        b.probes.diag[3][0] = 0.0;
        let s = add(&a, &b).unwrap();
        assert_eq!(s.probes.diag[1][0], 0.0);
        b.probes.t_up[(0, 0)] = 0.2;
        assert!(add(&a, &b).is_err());
    }
}
