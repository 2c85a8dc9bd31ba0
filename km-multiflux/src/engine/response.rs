//! The engine's answer for one channel: per Fourier order the coefficients
//! between incidences and exit polar angles read from the operators, the
//! correction weights from the markers, the totals; the azimuthal stopping
//! rule; and eq. B1 evaluated at any azimuth.

use km_core::phase::PhaseFunction;

use super::rough_paths::{AtPolar, RoughPath};
use super::{DirectionValues, Extras, FourierStop, Incidence, Prepared, Request, Stop};
use crate::MultifluxError;
use crate::adding::probed::Augmented;
use crate::exits::Azimuths;
use crate::prepare::flux;
use crate::quadrature::mu_of_invariant;
use crate::stack::Scaled;
use crate::workspace::zeros;

mod once;
use once::OnceOrders;

/// The correction data of one scattering layer (eq. B1, second line).
#[derive(Debug, Clone)]
pub(crate) struct TmsLayer {
    /// Unscaled albedo, truncation fraction, scaled albedo.
    omega_true: f64,
    f: f64,
    omega: f64,
    /// `(2l + 1) chi*_l`, the scaled moments.
    chiw: Vec<f64>,
    /// Legendre recurrence coefficients `((2l - 1)/l, (l - 1)/l)`.
    rec: Vec<(f64, f64)>,
    phase: km_core::phase::Phase,
    /// Cosines in this layer of the beams and of the BRDF / BTDF probes.
    mu_b: Vec<Option<f64>>,
    mu_r: Vec<Option<f64>>,
    mu_t: Vec<Option<f64>>,
    /// Weights `[W_R, W_T, W_I]` per (incidence, exit), for BRDF and BTDF
    /// exits (`W_I`: the second-order peak term, eq. B2).
    w_r: Vec<[f64; 3]>,
    w_t: Vec<[f64; 3]>,
    /// The layer's correction (its `peak_pspike` is the angular factor of
    /// the `W_I` term).
    corr: crate::correction::PeakCorrection,
}

impl TmsLayer {
    /// `F(cos Theta)` of eq. B1 at two cosines at once (the same sums as the
    /// correction's; the Legendre recurrence `P_l = a_l x P_{l-1} - b_l
    /// P_{l-2}` with `a_l = (2l-1)/l`, `b_l = (l-1)/l` from `rec`, two
    /// independent chains for instruction-level parallelism).
    fn fix2(&self, c1: f64, c2: f64, mu_b: f64) -> (f64, f64) {
        let (c1, c2) = (c1.clamp(-1.0, 1.0), c2.clamp(-1.0, 1.0));
        let k = self.omega_true / (1.0 - self.omega_true * self.f);
        let (e1, e2) = (k * self.phase.eval(c1), k * self.phase.eval(c2));
        let (mut s1, mut s2) = (self.chiw[0], self.chiw[0]);
        let (mut p0a, mut p1a, mut p0b, mut p1b) = (1.0, c1, 1.0, c2);
        if self.chiw.len() > 1 {
            s1 += self.chiw[1] * c1;
            s2 += self.chiw[1] * c2;
        }
        for l in 2..self.chiw.len() {
            let (a, b) = self.rec[l];
            let pa = a * c1 * p1a - b * p0a;
            let pb = a * c2 * p1b - b * p0b;
            s1 += self.chiw[l] * pa;
            s2 += self.chiw[l] * pb;
            (p0a, p1a, p0b, p1b) = (p1a, pa, p1b, pb);
        }
        let q = self.omega / (4.0 * std::f64::consts::PI);
        ((e1 - q * s1) / mu_b, (e2 - q * s2) / mu_b)
    }

    /// One of [`TmsLayer::fix2`]'s values alone (the same operations on
    /// one chain, so the same bits), for a pair whose other weight is zero.
    fn fix1(&self, c: f64, mu_b: f64) -> f64 {
        let c = c.clamp(-1.0, 1.0);
        let k = self.omega_true / (1.0 - self.omega_true * self.f);
        let e = k * self.phase.eval(c);
        let mut s = self.chiw[0];
        let (mut p0, mut p1) = (1.0, c);
        if self.chiw.len() > 1 {
            s += self.chiw[1] * c;
        }
        for l in 2..self.chiw.len() {
            let (a, b) = self.rec[l];
            let p = a * c * p1 - b * p0;
            s += self.chiw[l] * p;
            (p0, p1) = (p1, p);
        }
        let q = self.omega / (4.0 * std::f64::consts::PI);
        (e - q * s) / mu_b
    }

    /// `(F(c_R), F(c_T))` where their weights `w_r`, `w_t` need them (zero
    /// where the weight is zero: a reflected exit over a black floor has no
    /// transmitted path).
    fn fix_weighted(
        &self,
        (c_r, c_t): (f64, f64),
        mu_b: f64,
        (w_r, w_t): (f64, f64),
    ) -> (f64, f64) {
        match (w_r == 0.0, w_t == 0.0) {
            (false, false) => self.fix2(c_r, c_t, mu_b),
            (false, true) => (self.fix1(c_r, mu_b), 0.0),
            (true, false) => (0.0, self.fix1(c_t, mu_b)),
            (true, true) => (0.0, 0.0),
        }
    }
}

/// The BSDF of one spectral channel: Fourier coefficients and correction
/// weights per polar pair, totals and delta parts per incidence.
#[derive(Debug, Clone)]
pub struct ChannelBsdf {
    /// Fourier coefficients of the BRDF, `[(i * n_o + o) * (M + 1) + m]`, 1/sr.
    pub(crate) coef_r: Vec<f64>,
    /// The same for the BTDF (all zero for an opaque substrate).
    pub(crate) coef_t: Vec<f64>,
    pub(crate) orders: usize,
    /// Of those, the orders solved by the operators (the others are their
    /// once-scattered part alone, eq. 5k of docs/multiflux.md).
    pub(crate) solved: usize,
    pub(crate) tms: Vec<TmsLayer>,
    /// Exit polar angles and whether light leaves below.
    pub(crate) no: usize,
    pub(crate) transmits: bool,
    /// Total reflectance per incidence (delta parts included).
    pub reflectance: Vec<f64>,
    /// Total transmittance per incidence.
    pub transmittance: Vec<f64>,
    /// Mirror reflectance per incidence (delta part).
    pub reflectance_specular: Vec<f64>,
    /// Unscattered transmittance per incidence (delta part).
    pub transmittance_direct: Vec<f64>,
    /// Stream count used.
    pub streams: usize,
    /// The beams' single paths through the first rough face, exact (eq.
    /// R18): per incidence its path, per pair `[reflected, transmitted]`.
    pub(crate) rough: Option<RoughTable>,
}

/// The exact single rough path of every pair of a table (eq. R18 of
/// docs/rough.md), added at each azimuth in place of its truncated series.
#[derive(Debug, Clone)]
pub(crate) struct RoughTable {
    paths: Vec<Option<RoughPath>>,
    at: Vec<[Option<AtPolar>; 2]>,
}

impl ChannelBsdf {
    /// The Fourier coefficients `c_m` (eq. B1) of the pair `(i, o)`.
    pub(crate) fn coefficients(&self, i: usize, o: usize, transmitted: bool) -> &[f64] {
        let k = (i * self.no + o) * self.orders;
        let c = if transmitted { &self.coef_t } else { &self.coef_r };
        &c[k..k + self.orders]
    }

    /// Eq. B1 for one polar pair at every azimuth of `phi_deg` into `out`,
    /// and the exact single rough path in place of its truncated series
    /// (eq. R18 of docs/rough.md) where the table keeps one
    /// ([`ChannelBsdf::drop_exact_paths`]).
    pub(crate) fn eval_into(
        &self,
        i: usize,
        o: usize,
        phi_deg: &[f64],
        transmitted: bool,
        out: &mut [f64],
    ) {
        self.eval_series_into(i, o, phi_deg, transmitted, out);
        if let Some(r) = &self.rough
            && let (Some(path), Some(at)) =
                (&r.paths[i], &r.at[i * self.no + o][transmitted as usize])
        {
            for (v, &p) in out.iter_mut().zip(phi_deg) {
                *v += path.correction(at, p, self.orders);
            }
        }
    }

    /// Forget the exact single rough paths: [`ChannelBsdf::eval_into`] then
    /// gives the series of eq. B1 alone, band-limited to the table's orders
    /// (what a coarse grid interpolated by a renderer wants).
    pub(crate) fn drop_exact_paths(&mut self) {
        self.rough = None;
    }

    /// Eq. B1 for one polar pair at every azimuth of `phi_deg` into `out`
    /// (each azimuth a cosine recurrence of `M` steps and, with a peaked
    /// phase function, two Legendre sums per scattering layer).
    pub(crate) fn eval_series_into(
        &self,
        i: usize,
        o: usize,
        phi_deg: &[f64],
        transmitted: bool,
        out: &mut [f64],
    ) {
        if transmitted && !self.transmits {
            out.iter_mut().for_each(|x| *x = 0.0);
            return;
        }
        let coef = self.coefficients(i, o, transmitted);
        for (k, &p) in phi_deg.iter().enumerate() {
            // cos m x by the Chebyshev recurrence, x = phi - 180 deg.
            let cx = (p - 180.0).to_radians().cos();
            let (mut c_prev, mut c_cur) = (cx, 1.0);
            let mut v = 0.0;
            for &a in coef {
                v += a * c_cur;
                let next = 2.0 * cx * c_cur - c_prev;
                c_prev = c_cur;
                c_cur = next;
            }
            out[k] = v;
        }
        self.add_correction(i, o, phi_deg, transmitted, out);
    }

    /// Add the single-scattering correction (eq. B1, second line) of the
    /// pair `(i, o)` at every azimuth of `phi_deg` to `out`.
    pub(crate) fn add_correction(
        &self,
        i: usize,
        o: usize,
        phi_deg: &[f64],
        transmitted: bool,
        out: &mut [f64],
    ) {
        let cosines = phi_deg.iter().map(|&p| (p - 180.0).to_radians().cos());
        self.add_correction_at(i, o, cosines, transmitted, out);
    }

    /// [`ChannelBsdf::add_correction`] at the azimuths whose
    /// `cos(phi - 180 deg)` are `cosines` (a solve's exit directions share
    /// a few azimuths, whose cosines it has already).
    pub(crate) fn add_correction_at(
        &self,
        i: usize,
        o: usize,
        cosines: impl Iterator<Item = f64> + Clone,
        transmitted: bool,
        out: &mut [f64],
    ) {
        let no = self.no;
        for l in &self.tms {
            let w = if transmitted { l.w_t[i * no + o] } else { l.w_r[i * no + o] };
            if w == [0.0; 3] {
                continue;
            }
            let mu_x = if transmitted { l.mu_t[o] } else { l.mu_r[o] };
            let (Some(mu_b), Some(mu_x)) = (l.mu_b[i], mu_x) else { continue };
            let (sx, sb) =
                ((1.0 - mu_x * mu_x).max(0.0).sqrt(), (1.0 - mu_b * mu_b).max(0.0).sqrt());
            for (k, cphi) in cosines.clone().enumerate() {
                let c_t = mu_x * mu_b + sx * sb * cphi;
                let c_r = -mu_x * mu_b + sx * sb * cphi;
                let (f_r, f_t) = l.fix_weighted((c_r, c_t), mu_b, (w[0], w[1]));
                out[k] += w[0] * f_r + w[1] * f_t;
                if w[2] != 0.0 {
                    out[k] += w[2] * l.corr.peak_pspike(c_t);
                }
            }
        }
    }
}

/// One order's operators: the stack's, or a lone layer's beam column.
pub(crate) enum Order {
    Stack(Box<Augmented>),
    /// The beam's reflected and transmitted columns on `[nodes, beam,
    /// probes]` and the markers' values.
    Lone {
        up: Vec<f64>,
        down: Vec<f64>,
        markers: Vec<f64>,
    },
}

/// One order's operators read out at the extras.
pub(crate) struct Readout<'a> {
    pub(crate) prep: &'a Prepared<'a>,
    pub(crate) order: &'a Order,
    pub(crate) extras: &'a Extras,
    /// Incidences (1 for diffuse light).
    pub(crate) ni: usize,
}

impl Readout<'_> {
    /// The value of extra `e` (a probe or marker; reflected above when `up`,
    /// else transmitted below) for incidence `i`.
    fn probe(&self, e: usize, i: usize, up: bool, diffuse: bool) -> f64 {
        let (na0, nb) = self.prep.exit_counts();
        let nbeam = self.extras.beams;
        match self.order {
            Order::Stack(ops) => {
                let p = e - nbeam;
                let (rows, diag) = if up {
                    (&ops.probes.r_top, &ops.probes.diag[0])
                } else {
                    (&ops.probes.t_down, &ops.probes.diag[1])
                };
                if !diffuse {
                    // The beam's column of the top side's core.
                    return rows[(p, na0 + i)];
                }
                // Diffuse light: 1/pi on every node and every probe present above.
                let pi = std::f64::consts::PI;
                let mut v: f64 = (0..na0).map(|j| rows[(p, j)]).sum::<f64>() / pi;
                if mu_of_invariant(self.extras.ex[e].0, self.prep.scene.ambient_n()).is_some() {
                    v += diag[p] / pi;
                }
                v
            }
            Order::Lone { up: u, down: d, markers } if e < self.extras.base_len => {
                if up {
                    u[na0 + e]
                } else {
                    d[nb + e]
                }
            }
            Order::Lone { markers, .. } => markers[e - self.extras.base_len],
        }
    }

    /// Reflectance and transmittance of incidence `i` from the azimuthal
    /// mean (`m = 0`): the flux of the node columns plus the beam's own extra.
    fn totals(&self, i: usize, diffuse: bool) -> (f64, f64) {
        let (nodes0, nodes_sub) = (&self.prep.nodes0, self.prep.nodes_sub.as_ref());
        let (na0, nb) = self.prep.exit_counts();
        let col = |m: &faer::Mat<f64>, rows: usize, c0: usize| -> Vec<f64> {
            if diffuse {
                let pi = std::f64::consts::PI;
                (0..rows).map(|q| (0..na0).map(|j| m[(q, j)]).sum::<f64>() / pi).collect()
            } else {
                (0..rows).map(|q| m[(q, c0 + i)]).collect()
            }
        };
        match self.order {
            Order::Stack(ops) => {
                let c = &ops.core;
                let mut r = flux(nodes0, &col(&c.r_top, na0, na0));
                let mut t = nodes_sub.map_or(0.0, |ns| flux(ns, &col(&c.t_down, nb, na0)));
                if !diffuse {
                    r += c.r_top[(na0 + i, na0 + i)];
                    if nodes_sub.is_some() {
                        t += c.t_down[(nb + i, na0 + i)];
                    }
                }
                (r, t)
            }
            Order::Lone { up, down, .. } => {
                let r = flux(nodes0, &up[..na0]) + up[na0];
                let t = nodes_sub.map_or(0.0, |ns| flux(ns, &down[..nb]) + down[nb]);
                (r, t)
            }
        }
    }

    /// The Fourier coefficients of this order between incidences and exits,
    /// `[i * no + o]`, reflected into `cr` and transmitted into `ct` (zero
    /// on entry, `ni * no` values each); returns the largest of them.
    fn coefficients(&self, diffuse: bool, cr: &mut [f64], ct: &mut [f64]) -> f64 {
        let (ex, no) = (self.extras, self.extras.t0 - self.extras.r0);
        let below = self.prep.n_sub.is_some();
        let mut term = 0.0f64;
        for i in 0..self.ni {
            for o in 0..no {
                let x = self.probe(ex.r0 + o, i, true, diffuse);
                cr[i * no + o] = x;
                term = term.max(x.abs());
                if below {
                    let y = self.probe(ex.t0 + o, i, false, diffuse);
                    ct[i * no + o] = y;
                    term = term.max(y.abs());
                }
            }
        }
        term
    }

    /// The single-scattering correction of layer `l` (scaled as `s`): its
    /// scaled moments and cosines, and the weights `W_R`, `W_T`, `W_I` per
    /// (incidence, exit) read from the marker rows of the `m = 0` operators.
    fn marker_weights(&self, s: &Scaled, l: usize) -> TmsLayer {
        let (ex, ni) = (self.extras, self.ni);
        let (r0, t0, no) = (ex.r0, ex.t0, ex.t0 - ex.r0);
        let below = self.prep.n_sub.is_some();
        let chiw: Vec<f64> =
            s.chi.iter().enumerate().map(|(k, c)| (2 * k + 1) as f64 * c).collect();
        let mu_in = |a: usize| mu_of_invariant(ex.ex[a].0, s.n);
        let rec = km_core::legendre::legendre_coefficients(chiw.len());
        let corr = self.prep.corr[l].clone().unwrap_or_else(|| s.correction());
        let mut tl = TmsLayer {
            omega_true: s.omega_true,
            f: corr.f(),
            omega: s.omega,
            chiw,
            rec,
            phase: s.phase.clone(),
            mu_b: (0..ni).map(mu_in).collect(),
            mu_r: (r0..r0 + no).map(mu_in).collect(),
            mu_t: if below { (t0..t0 + no).map(mu_in).collect() } else { vec![None; no] },
            w_r: vec![[0.0; 3]; ni * no],
            w_t: vec![[0.0; 3]; ni * no],
            corr,
        };
        for (k, &(p, ml, slot)) in ex.marker_of.iter().enumerate() {
            if ml != l {
                continue;
            }
            let e = ex.base_len + k;
            for i in 0..ni {
                if p < t0 {
                    tl.w_r[i * no + (p - r0)][slot] = self.probe(e, i, true, false);
                } else {
                    tl.w_t[i * no + (p - t0)][slot] = self.probe(e, i, false, false);
                }
            }
        }
        tl
    }
}

/// The values at a solve's own exit directions as the orders are summed
/// (the request's `directions`).
struct AtDirections {
    /// The exit polar angle (index into the request's) and azimuth of each direction.
    o: Vec<usize>,
    phi: Vec<f64>,
    azimuths: Azimuths,
    cos_m: Vec<f64>,
    values: DirectionValues,
}

impl AtDirections {
    /// Order `m`'s coefficients `cr`, `ct` (`[o]`, incidence 0) times
    /// `cos m(phi - 180 deg)` into the values (the BTDF's when light
    /// leaves `below`).
    fn add_order(&mut self, m: usize, cr: &[f64], ct: &[f64], below: bool) {
        self.azimuths.cos_order(m, &mut self.cos_m);
        for (k, (&o, &a)) in self.o.iter().zip(&self.azimuths.of).enumerate() {
            self.values.brdf[k] += cr[o] * self.cos_m[a];
            if below {
                self.values.btdf[k] += ct[o] * self.cos_m[a];
            }
        }
    }
}

/// The orders of one request summed up, and its stopping rule.
pub(crate) struct Accumulator<'a> {
    prep: &'a Prepared<'a>,
    req: &'a Request<'a>,
    ni: usize,
    no: usize,
    diffuse: bool,
    /// The orders' coefficients, order after order (`[m * ni * no + k]`),
    /// and how many orders they hold.
    coefs_r: Vec<f64>,
    coefs_t: Vec<f64>,
    orders: usize,
    out: ChannelBsdf,
    stop: FourierStop,
    largest: f64,
    at: Option<AtDirections>,
    /// The once-scattered part of each order (eq. 5i of docs/multiflux.md),
    /// where the corrected layers give it and the series may stop early.
    once: Option<OnceOrders>,
}

impl<'a> Accumulator<'a> {
    pub(crate) fn new(
        prep: &'a Prepared<'a>,
        extras: &Extras,
        req: &'a Request<'a>,
        ni: usize,
    ) -> Self {
        let no = extras.t0 - extras.r0;
        let out = ChannelBsdf {
            coef_r: Vec::new(),
            coef_t: Vec::new(),
            orders: 0,
            solved: 0,
            tms: Vec::new(),
            no,
            transmits: prep.n_sub.is_some(),
            reflectance: zeros(ni),
            transmittance: zeros(ni),
            reflectance_specular: zeros(ni),
            transmittance_direct: zeros(ni),
            streams: prep.streams,
            rough: None,
        };
        let at = match req.directions {
            [] => None,
            dirs => {
                let o = req.o_of.to_vec();
                let azimuths = Azimuths::new(dirs);
                let cos_m = zeros(azimuths.values.len());
                let values = DirectionValues { brdf: zeros(dirs.len()), btdf: zeros(dirs.len()) };
                let phi = dirs.iter().map(|d| d[1]).collect();
                Some(AtDirections { o, phi, azimuths, cos_m, values })
            }
        };
        let diffuse = matches!(req.incidence, Incidence::Diffuse);
        Accumulator {
            prep,
            req,
            ni,
            no,
            diffuse,
            coefs_r: Vec::with_capacity(ni * no * (req.last_order + 1)),
            coefs_t: Vec::with_capacity(ni * no * (req.last_order + 1)),
            orders: 0,
            out,
            stop: FourierStop::new(prep.opts.fourier_tol),
            largest: 0.0,
            at,
            once: None,
        }
    }

    /// Take order `m`; returns whether the series has converged.
    pub(crate) fn add_order(
        &mut self,
        read: &Readout<'_>,
        m: usize,
    ) -> Result<bool, MultifluxError> {
        // This order's coefficients go straight to the end of the record.
        let (start, pairs) = (self.coefs_r.len(), self.ni * self.no);
        let (mut cr, mut ct) =
            (std::mem::take(&mut self.coefs_r), std::mem::take(&mut self.coefs_t));
        cr.resize(start + pairs, 0.0);
        ct.resize(start + pairs, 0.0);
        let term = read.coefficients(self.diffuse, &mut cr[start..], &mut ct[start..]);
        if m == 0 {
            self.totals(read);
        }
        // The stopping rule reads the light scattered more than once (not
        // needed at the last order: nothing is left to save).
        let rest = match &mut self.once {
            Some(once) if m > 0 && m < self.req.last_order => {
                once.order(&self.out.tms, m, pairs);
                once.rest(&cr[start..], &ct[start..])
            }
            _ => term,
        };
        let done = self.sum_at_directions(&cr[start..], &ct[start..], m, (term, rest));
        (self.coefs_r, self.coefs_t) = (cr, ct);
        self.orders += 1;
        self.out.solved = self.orders;
        if done {
            self.once_tail(m);
        }
        Ok(done)
    }

    /// After the series stopped at order `last`: the orders up to the
    /// request's last as their once-scattered part alone (eq. 5k of
    /// docs/multiflux.md), into the record and the directions' values.
    fn once_tail(&mut self, last: usize) {
        let Some(once) = &mut self.once else { return };
        let pairs = self.ni * self.no;
        let below = self.prep.n_sub.is_some();
        for m in last + 1..=self.req.last_order {
            once.order(&self.out.tms, m, pairs);
            self.coefs_r.extend_from_slice(&once.sr);
            self.coefs_t.extend_from_slice(&once.st);
            self.orders += 1;
            if let Some(at) = &mut self.at {
                at.add_order(m, &once.sr, &once.st, below);
            }
        }
    }

    /// Totals and delta parts per incidence, and the correction weights.
    fn totals(&mut self, read: &Readout<'_>) {
        for i in 0..self.ni {
            (self.out.reflectance[i], self.out.transmittance[i]) = read.totals(i, self.diffuse);
            if let Incidence::Beams(b) = self.req.incidence {
                let (spec, direct) = self.prep.delta_parts(b[i]);
                self.out.reflectance_specular[i] = spec;
                self.out.transmittance_direct[i] = direct;
            }
        }
        if !read.extras.marker_of.is_empty() {
            for &l in &self.prep.tms_layers {
                self.out.tms.push(read.marker_weights(&self.prep.layers[l], l));
            }
        }
        // A rough face's exact path (eq. R18 of docs/rough.md) replaces
        // the summed orders of its series, so every order is summed there.
        if !self.out.tms.is_empty()
            && !self.prep.scene.has_rough_face()
            && self.req.stop != Stop::Never
        {
            self.once = Some(OnceOrders::default());
        }
    }

    /// Sum order `m` into the values at the solve's directions (with the
    /// correction after order 0) and apply the stopping rule.
    /// `term` is the order's largest coefficient, `rest` the largest of
    /// what the stopping rule tests (the multiply scattered part, or the
    /// whole where the once-scattered part is not known).
    fn sum_at_directions(
        &mut self,
        cr: &[f64],
        ct: &[f64],
        m: usize,
        (term, rest): (f64, f64),
    ) -> bool {
        if m == 0 {
            self.largest = term;
        }
        let Some(at) = &mut self.at else {
            // The table's rule: against the largest order-0 coefficient.
            return m > 0
                && matches!(self.req.stop, Stop::Table)
                && self.stop.converged(rest, self.largest);
        };
        let below = self.prep.n_sub.is_some();
        at.add_order(m, cr, ct, below);
        if m == 0 && !self.out.tms.is_empty() {
            // cos(phi - 180 deg) per distinct azimuth: order 1's cosines.
            at.azimuths.cos_order(1, &mut at.cos_m);
            for (k, (&o, &a)) in at.o.iter().zip(&at.azimuths.of).enumerate() {
                let c = std::iter::once(at.cos_m[a]);
                self.out.add_correction_at(0, o, c.clone(), false, &mut at.values.brdf[k..k + 1]);
                if below {
                    self.out.add_correction_at(0, o, c, true, &mut at.values.btdf[k..k + 1]);
                }
            }
        }
        if m == 0 {
            return false;
        }
        match self.req.stop {
            Stop::Never => false,
            Stop::Table => self.stop.converged(rest, self.largest),
            Stop::Values => {
                let v = &at.values;
                let largest = v.brdf.iter().chain(&v.btdf).fold(0.0f64, |a, &b| a.max(b.abs()));
                self.stop.converged(rest, largest)
            }
        }
    }

    /// The channel's table (coefficients by pair) and the directions' values.
    pub(crate) fn finish(
        mut self,
    ) -> Result<(ChannelBsdf, Option<DirectionValues>), MultifluxError> {
        self.exact_rough_path();
        let pairs = self.ni * self.no;
        self.out.orders = self.orders;
        self.out.coef_r = by_pair(&self.coefs_r, pairs, self.orders);
        self.out.coef_t = by_pair(&self.coefs_t, pairs, self.orders);
        let o = &self.out;
        let values = self.at.map(|a| a.values);
        let finite = o.coef_r.iter().chain(&o.coef_t).chain(&o.reflectance).all(|x| x.is_finite())
            && o.transmittance.iter().all(|x| x.is_finite())
            && values.as_ref().is_none_or(|v| v.brdf.iter().chain(&v.btdf).all(|x| x.is_finite()));
        if !finite {
            return Err(MultifluxError::Numerical {
                what: "solve",
                detail: "non-finite result".into(),
            });
        }
        Ok((self.out, values))
    }
}

impl Accumulator<'_> {
    /// The beam's single path through the first rough face, exact at the
    /// solve's directions (eq. R18, [`RoughPath`]), or for every pair of a
    /// table ([`RoughTable`], added at each azimuth by
    /// [`ChannelBsdf::eval_into`]).
    fn exact_rough_path(&mut self) {
        let prep = self.prep;
        if !prep.scene.has_rough_face() {
            return;
        }
        if self.at.is_none() && matches!(self.req.stop, Stop::Table) {
            self.rough_table();
            return;
        }
        let (Some(at), Incidence::Beams(&[s_b])) = (&mut self.at, self.req.incidence) else {
            return;
        };
        let Some(path) = RoughPath::new(&prep.scene, &prep.layers, prep.n_sub, s_b, &prep.grid)
        else {
            return;
        };
        let (built, summed) = (self.req.last_order + 1, self.orders);
        // Per exit polar angle and side once; then per direction its azimuth.
        let sides: &[bool] = if prep.n_sub.is_some() { &[false, true] } else { &[false] };
        for &transmit in sides {
            let polar: Vec<_> =
                self.req.theta_o.iter().map(|&t| path.at_polar(t, transmit, built, true)).collect();
            let values = if transmit { &mut at.values.btdf } else { &mut at.values.brdf };
            for ((v, &o), &phi) in values.iter_mut().zip(&at.o).zip(&at.phi) {
                if let Some(p) = &polar[o] {
                    *v += path.correction(p, phi, summed);
                }
            }
        }
    }
}

impl Accumulator<'_> {
    /// [`RoughTable`]: per incidence its single rough path, per pair and
    /// side its exit's data (the face's coefficients of the `built` orders).
    fn rough_table(&mut self) {
        let Incidence::Beams(beams) = self.req.incidence else { return };
        let prep = self.prep;
        let built = self.req.last_order + 1;
        let paths: Vec<Option<RoughPath>> = beams
            .iter()
            .map(|&s_b| RoughPath::new(&prep.scene, &prep.layers, prep.n_sub, s_b, &prep.grid))
            .collect();
        let mut at = Vec::with_capacity(paths.len() * self.req.theta_o.len());
        for path in &paths {
            for &t in self.req.theta_o {
                // (`at_polar` gives no transmitted exit without a substrate;
                // the double path of eq. R19 stays the series here: its
                // cost per pair, docs/rough.md §7.)
                let pair = |transmit: bool| {
                    path.as_ref().and_then(|p| p.at_polar(t, transmit, built, false))
                };
                at.push([pair(false), pair(true)]);
            }
        }
        self.out.rough = Some(RoughTable { paths, at });
    }
}

/// The coefficients of `orders` orders, order after order
/// (`coefs[m * pairs + k]`), reordered by pair, orders contiguous:
/// `out[k * orders + m]`.
fn by_pair(coefs: &[f64], pairs: usize, orders: usize) -> Vec<f64> {
    let mut out = zeros(pairs * orders);
    for (m, c) in coefs.chunks_exact(pairs.max(1)).take(orders).enumerate() {
        for (k, &x) in c.iter().enumerate() {
            out[k * orders + m] = x;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`TmsLayer::fix1`] is either value of [`TmsLayer::fix2`] bit for bit
    /// (the correction of a pair with one weight zero skips the other chain
    /// without moving a solve's output), and `fix_weighted` leaves out only
    /// the side whose weight is zero.
    #[test]
    fn one_chain_is_either_of_the_two_bit_for_bit() {
        let phase = km_core::phase::Phase::henyey_greenstein(0.8).unwrap();
        let corr = crate::correction::PeakCorrection::new(phase.clone(), 0.95, 8, false);
        let f = corr.f();
        let chiw: Vec<f64> = (0..8)
            .map(|l| (2 * l + 1) as f64 * (phase.legendre_moment(l) - f) / (1.0 - f))
            .collect();
        let layer = TmsLayer {
            omega_true: 0.95,
            f,
            omega: 0.95 * (1.0 - f) / (1.0 - 0.95 * f),
            rec: km_core::legendre::legendre_coefficients(chiw.len()),
            chiw,
            phase,
            mu_b: Vec::new(),
            mu_r: Vec::new(),
            mu_t: Vec::new(),
            w_r: Vec::new(),
            w_t: Vec::new(),
            corr,
        };
        for (c1, c2) in [(-0.9, 0.3), (0.2, 0.99), (-1.0, 1.0), (0.5, -0.25)] {
            let (a, b) = layer.fix2(c1, c2, 0.7);
            assert_eq!(layer.fix1(c1, 0.7).to_bits(), a.to_bits());
            assert_eq!(layer.fix1(c2, 0.7).to_bits(), b.to_bits());
            assert_eq!(layer.fix_weighted((c1, c2), 0.7, (1.0, 0.0)), (a, 0.0));
            assert_eq!(layer.fix_weighted((c1, c2), 0.7, (0.0, 2.0)), (0.0, b));
            assert_eq!(layer.fix_weighted((c1, c2), 0.7, (1.0, 2.0)), (a, b));
        }
    }
}
