//! The layer's reflection and transmission operators on nodes plus extras
//! (eq. S5, seed eq. 20), from the kept factors; the Beer–Lambert shortcut
//! of a layer that does not scatter.

use faer::Mat;

use super::{Extra, SlabOrder, SlabSolution, Tms, atten, mat_vec_into};
use crate::MultifluxError;
use crate::adding::LayerOperators;
use crate::adding::probed::{Augmented, ProbeRows};
use crate::workspace::{Workspace, with_workspace};

impl SlabSolution {
    /// The operators on the augmented space `[nodes, extras]` (same layout for
    /// down- and up-going vectors; the layer is symmetric, so `r_bottom = r_top`
    /// and `t_up = t_down`).
    pub fn operators(&self, extras: &[Extra], tms: Option<&Tms>) -> LayerOperators {
        with_workspace(|ws| self.operators_in(extras, tms, ws))
    }

    /// [`SlabSolution::operators`] with the scratch vectors of `ws`.
    pub(crate) fn operators_in(
        &self,
        extras: &[Extra],
        tms: Option<&Tms>,
        ws: &mut Workspace,
    ) -> LayerOperators {
        let n = self.n;
        let dim = n + extras.len();
        let (mut rr, mut tt) = self.node_blocks(dim);
        // Probe rows first (needed by the beam columns), once per distinct cosine.
        let probes = self.probes(extras, ws);
        let vectors = self.all_probe_row_vectors(&probes, ws);
        for (e, ex) in extras.iter().enumerate() {
            if let Some(mu_x) = ex.mu {
                tt[(n + e, n + e)] = atten(self.tau, mu_x);
            }
            if let Some(p) = probes.of(e) {
                let (rx, tx) = &vectors[p];
                for i in 0..n {
                    rr[(n + e, i)] = rx[i];
                    tt[(n + e, i)] = tx[i];
                }
            }
        }
        for (eb, ex) in extras.iter().enumerate() {
            let (true, Some(mu_b)) = (ex.beam, ex.mu) else { continue };
            let (cr, ct) = self.beam_response_rows(mu_b, extras, &probes, tms, true, ws);
            for i in 0..dim {
                if i < n || probes.of(i - n).is_some() {
                    rr[(i, n + eb)] = cr[i];
                    tt[(i, n + eb)] = ct[i];
                }
            }
            ws.give(cr);
            ws.give(ct);
        }
        for (rx, tx) in vectors {
            ws.give(rx);
            ws.give(tx);
        }
        probes.recycle(ws);
        LayerOperators { r_top: rr.clone(), t_down: tt.clone(), r_bottom: rr, t_up: tt }
    }

    /// `dim x dim` zero matrices with the node operators `R`, `T` in their
    /// leading `N x N` blocks (from the factors when built without `full`).
    fn node_blocks(&self, dim: usize) -> (Mat<f64>, Mat<f64>) {
        let n = self.n;
        let mut rr = Mat::<f64>::zeros(dim, dim);
        let mut tt = Mat::<f64>::zeros(dim, dim);
        let lazy;
        let (r, tr) = if self.r.nrows() == n {
            (&self.r, &self.tr)
        } else {
            // Built without `full`: the node operators from the factors.
            lazy = self.node_operators();
            (&lazy.0, &lazy.1)
        };
        for j in 0..n {
            rr.col_as_slice_mut(j)[..n].copy_from_slice(r.col_as_slice(j));
            tt.col_as_slice_mut(j)[..n].copy_from_slice(tr.col_as_slice(j));
        }
        (rr, tt)
    }

    /// The operators on the core `[nodes, beams]` and on the probes apart
    /// (eq. PA1 of [`crate::adding::probed`]), for `extras` holding `nbeam`
    /// beams first and then probes: the same numbers as
    /// [`SlabSolution::operators_in`] without its `(N + E)^2` matrices.
    pub(crate) fn augmented_in(
        &self,
        extras: &[Extra],
        nbeam: usize,
        ws: &mut Workspace,
    ) -> Augmented {
        let n = self.n;
        let (core, np) = (n + nbeam, extras.len() - nbeam);
        let (mut rr, mut tt) = self.node_blocks(core);
        let (mut pr, mut pt) = (Mat::<f64>::zeros(np, core), Mat::<f64>::zeros(np, core));
        let mut dt = vec![0.0; np];
        // Probe rows first (needed by the beam columns), once per distinct cosine.
        let probes = self.probes(extras, ws);
        let vectors = self.all_probe_row_vectors(&probes, ws);
        for (e, ex) in extras.iter().enumerate() {
            let Some(mu_x) = ex.mu else { continue };
            if e < nbeam {
                tt[(n + e, n + e)] = atten(self.tau, mu_x);
                continue;
            }
            dt[e - nbeam] = atten(self.tau, mu_x);
            if let Some(p) = probes.of(e) {
                let (rx, tx) = &vectors[p];
                for i in 0..n {
                    pr[(e - nbeam, i)] = rx[i];
                    pt[(e - nbeam, i)] = tx[i];
                }
            }
        }
        for (eb, ex) in extras[..nbeam].iter().enumerate() {
            let (true, Some(mu_b)) = (ex.beam, ex.mu) else { continue };
            let (cr, ct) = self.beam_response_rows(mu_b, extras, &probes, None, true, ws);
            for i in 0..n {
                rr[(i, n + eb)] = cr[i];
                tt[(i, n + eb)] = ct[i];
            }
            for e in nbeam..extras.len() {
                if probes.of(e).is_some() {
                    pr[(e - nbeam, n + eb)] = cr[n + e];
                    pt[(e - nbeam, n + eb)] = ct[n + e];
                }
            }
            ws.give(cr);
            ws.give(ct);
        }
        for (rx, tx) in vectors {
            ws.give(rx);
            ws.give(tx);
        }
        probes.recycle(ws);
        // The layer is symmetric: r_bottom = r_top, t_up = t_down.
        let core = LayerOperators { r_top: rr.clone(), t_down: tt.clone(), r_bottom: rr, t_up: tt };
        let probes = ProbeRows {
            r_top: pr.clone(),
            t_down: pt.clone(),
            r_bottom: pr,
            t_up: pt,
            diag: [vec![0.0; np], dt.clone(), vec![0.0; np], dt],
        };
        Augmented { core, probes }
    }

    /// `(R a + T b, T a + R b)` at the nodes (radiances), for down-going `a`
    /// entering at the top and up-going `b` at the bottom, by two vector
    /// solves (eq. S5): with `a~ = T a`, `b~ = T b`,
    /// `R~ a~ + T~ b~ = 1/2 [Cp_out Cp^-1 (a~ + b~) + Cm_out Cm^-1 (a~ - b~)]`.
    /// Also returns `Cp^-1 (a~ + b~)` and `Cm^-1 (a~ - b~)` (0 for a half-space).
    /// All four are vectors of the workspace `ws`.
    pub(super) fn homogeneous_out(
        &self,
        a: &[f64],
        b: &[f64],
        ws: &mut Workspace,
    ) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
        let n = self.n;
        // Half-space: R~ = Cp_out Cp^-1, T~ = 0 (nothing enters from below).
        let half = self.lu_m.is_none();
        let bh = |i: usize| if half { 0.0 } else { b[i] };
        // s, d, rs, td are written for every node before they are read (hp
        // and hm accumulate: zero-filled).
        let (mut s, mut d) = (ws.take_for_overwrite(n), ws.take_for_overwrite(n));
        for i in 0..n {
            s[i] = self.t[i] * (a[i] + bh(i));
            d[i] = self.t[i] * (a[i] - bh(i));
        }
        self.lu_p.solve(&mut s);
        let mut hp = ws.take(n);
        mat_vec_into(&self.cp_out, &s, &mut hp);
        let mut hm = ws.take(n);
        match &self.lu_m {
            Some(lu) => {
                lu.solve(&mut d);
                mat_vec_into(&self.cm_out, &d, &mut hm);
            }
            None => {
                d.iter_mut().for_each(|x| *x = 0.0);
                hm.copy_from_slice(&hp);
            }
        }
        let (mut rs, mut td) = (ws.take_for_overwrite(n), ws.take_for_overwrite(n));
        for i in 0..n {
            rs[i] = 0.5 * (hp[i] + hm[i]) / self.t[i];
            td[i] = if half { 0.0 } else { 0.5 * (hp[i] - hm[i]) / self.t[i] };
        }
        ws.give(hp);
        ws.give(hm);
        (rs, td, s, d)
    }

    /// The node-to-node `R` and `T` (eq. S5) from the kept factors.
    pub(super) fn node_operators(&self) -> (Mat<f64>, Mat<f64>) {
        let n = self.n;
        let mut r = Mat::<f64>::zeros(n, n);
        let mut tr = Mat::<f64>::zeros(n, n);
        // Row j of X = C_out C^-1 is C^-T applied to row j of C_out: all n
        // rows at once, right-hand side j in column j of a row-major block
        // (component i at [i * n + j], i.e. C_out transposed).
        let mut xp = vec![0.0; n * n];
        for j in 0..n {
            for i in 0..n {
                xp[i * n + j] = self.cp_out[(j, i)];
            }
        }
        self.lu_p.solve_transpose_rows(&mut xp, n);
        let xm = match &self.lu_m {
            Some(lu) => {
                let mut xm = vec![0.0; n * n];
                for j in 0..n {
                    for i in 0..n {
                        xm[i * n + j] = self.cm_out[(j, i)];
                    }
                }
                lu.solve_transpose_rows(&mut xm, n);
                xm
            }
            None => xp.clone(),
        };
        for j in 0..n {
            for i in 0..n {
                let f = self.t[i] / self.t[j];
                let (a, b) = (xp[i * n + j], xm[i * n + j]);
                r[(j, i)] = 0.5 * (a + b) * f;
                tr[(j, i)] = if self.lu_m.is_none() { 0.0 } else { 0.5 * (a - b) * f };
            }
        }
        (r, tr)
    }
}

/// Operators of a layer that does not scatter in this order (pure absorber,
/// or an order above the phase function's last moment): `R = 0`,
/// `T = diag(exp(-tau/mu))` (Beer–Lambert), no eigen-solve.
pub fn absorber_operators(mu: &[f64], extras: &[Extra], tau: f64) -> LayerOperators {
    let n = mu.len();
    let dim = n + extras.len();
    let mut tt = Mat::<f64>::zeros(dim, dim);
    for i in 0..n {
        tt[(i, i)] = atten(tau, mu[i]);
    }
    for (e, ex) in extras.iter().enumerate() {
        if let Some(mu_x) = ex.mu {
            tt[(n + e, n + e)] = atten(tau, mu_x);
        }
    }
    LayerOperators {
        r_top: Mat::zeros(dim, dim),
        t_down: tt.clone(),
        r_bottom: Mat::zeros(dim, dim),
        t_up: tt,
    }
}

/// Optical thickness below which a layer is taken for one that does not
/// scatter, relative to the smallest direction cosine of the request:
/// single scattering changes no operator element by more than about
/// `omega tau / mu_min`, so at `tau <= 1e-15 mu_min` the Beer–Lambert
/// shortcut is exact to rounding, while the eigen-solution loses every
/// digit (`1 - exp(-k tau)` rounds to 0 for every mode at `tau ~ 1e-19`,
/// and `I - R1' R2` came out singular).
const VANISHING_TAU: f64 = 1e-15;

/// Whether a layer of optical thickness `tau` is [`VANISHING_TAU`]-thin for
/// the node cosines `mu` and the extra directions' cosines.
fn vanishing(mu: &[f64], extras: &[Extra], tau: f64) -> bool {
    let mu_min = mu.iter().copied().chain(extras.iter().filter_map(|e| e.mu)).fold(1.0, f64::min);
    tau <= VANISHING_TAU * mu_min
}

/// Whether the layer of `p` scatters at this Fourier order (and is not
/// [`vanishing`]).
fn scatters(mu: &[f64], extras: &[Extra], p: &SlabOrder<'_>) -> bool {
    p.omega > 0.0
        && !vanishing(mu, extras, p.tau)
        && p.m < p.chi.len()
        && p.chi[p.m..].iter().any(|&c| c != 0.0)
}

/// Operators of one layer and order on the augmented space, choosing the
/// absorber shortcut when nothing scatters.
///
/// # Errors
/// Those of [`SlabSolution::new`].
pub fn slab_operators(
    mu: &[f64],
    w: &[f64],
    extras: &[Extra],
    p: &SlabOrder<'_>,
    tms: Option<&Tms>,
) -> Result<LayerOperators, MultifluxError> {
    let scatters = scatters(mu, extras, p);
    if !scatters {
        return Ok(absorber_operators(mu, extras, p.tau));
    }
    let s = SlabSolution::build(mu, w, p, true)?;
    Ok(with_workspace(|ws| {
        let ops = s.operators_in(extras, tms, ws);
        s.recycle(ws);
        ops
    }))
}

/// [`slab_operators`] on the core `[nodes, beams]` and the probes apart
/// ([`SlabSolution::augmented_in`]; `extras` holds `nbeam` beams first);
/// with `eigen` the eigen-solve is taken even when nothing scatters
/// (all effects), else the Beer–Lambert shortcut. The eigen-solution is
/// returned with the operators (`None` for the shortcut), kept for the
/// field inside the layer.
///
/// # Errors
/// Those of [`SlabSolution::new`].
pub(crate) fn slab_augmented_kept(
    mu: &[f64],
    w: &[f64],
    extras: &[Extra],
    nbeam: usize,
    p: &SlabOrder<'_>,
    eigen: bool,
) -> Result<(Augmented, Option<SlabSolution>), MultifluxError> {
    let scatters = scatters(mu, extras, p);
    if !(scatters || eigen && !vanishing(mu, extras, p.tau)) {
        let dense = absorber_operators(mu, &extras[..nbeam], p.tau);
        let mut aug = Augmented::core_only(dense);
        let d: Vec<f64> =
            extras[nbeam..].iter().map(|e| e.mu.map_or(0.0, |m| atten(p.tau, m))).collect();
        let np = d.len();
        let core = mu.len() + nbeam;
        aug.probes = ProbeRows::zeros(np, core, core);
        aug.probes.diag[1] = d.clone();
        aug.probes.diag[3] = d;
        return Ok((aug, None));
    }
    let s = SlabSolution::build(mu, w, p, true)?;
    let ops = with_workspace(|ws| s.augmented_in(extras, nbeam, ws));
    Ok((ops, Some(s)))
}

/// The column of the beam `extras[eb]` in the `r_top` and `t_down` of
/// [`slab_operators`] (the same numbers up to rounding), without the
/// node-to-node operators (eq. S5 by vector solves, eq. S6 and eq. 14 of
/// `docs/multiflux.md`): the whole answer for a layer alone under a
/// collimated beam, at about half the cost per Fourier order.
///
/// # Errors
/// Those of [`SlabSolution::new`].
pub fn slab_beam_response(
    mu: &[f64],
    w: &[f64],
    extras: &[Extra],
    eb: usize,
    p: &SlabOrder<'_>,
    tms: Option<&Tms>,
) -> Result<(Vec<f64>, Vec<f64>), MultifluxError> {
    beam_response_parts(mu, w, extras, eb, p, tms, true)
}

/// The `r_top` column of [`slab_beam_response`] alone (the same numbers bit
/// for bit), for a layer with nothing below it to receive what it transmits:
/// the probes' transmitted radiances are not computed.
///
/// # Errors
/// Those of [`SlabSolution::new`].
pub fn slab_beam_reflection(
    mu: &[f64],
    w: &[f64],
    extras: &[Extra],
    eb: usize,
    p: &SlabOrder<'_>,
    tms: Option<&Tms>,
) -> Result<Vec<f64>, MultifluxError> {
    let (cr, ct) = beam_response_parts(mu, w, extras, eb, p, tms, false)?;
    with_workspace(|ws| ws.give(ct));
    Ok(cr)
}

/// [`slab_beam_response`]; without `down` the probes' transmitted values are
/// zero, not computed.
fn beam_response_parts(
    mu: &[f64],
    w: &[f64],
    extras: &[Extra],
    eb: usize,
    p: &SlabOrder<'_>,
    tms: Option<&Tms>,
    down: bool,
) -> Result<(Vec<f64>, Vec<f64>), MultifluxError> {
    let scatters = scatters(mu, extras, p);
    if !scatters {
        // Beer–Lambert: only the unscattered beam.
        let dim = mu.len() + extras.len();
        let mut ct = vec![0.0; dim];
        if let Some(mu_b) = extras[eb].mu {
            ct[mu.len() + eb] = atten(p.tau, mu_b);
        }
        return Ok((vec![0.0; dim], ct));
    }
    let s = SlabSolution::build(mu, w, p, false)?;
    // The two vectors come from the workspace; the solver hands them back.
    Ok(with_workspace(|ws| {
        let out = s.beam_response_in(extras, eb, tms, down, ws);
        s.recycle(ws);
        out
    }))
}
