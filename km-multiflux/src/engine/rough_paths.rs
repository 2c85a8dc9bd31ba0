//! The beam's single rough path, exact (docs/rough.md eq. R18): the light
//! that reaches the first rough face along the beam's unscattered path, is
//! reflected or transmitted by that face once, and leaves along the exit
//! direction's unscattered path.
//!
//! A rough face sends the beam into the cells and the probes (eq. R14–R15),
//! and the probes carry the lobe as its Fourier series, which a narrow lobe
//! needs far more orders for than the streams resolve: truncated, it rings
//! (negative values opposite the peak, a peak too low or too high). As the
//! single-scattering correction does for a peaked phase function (eq. B1 of
//! docs/bsdf.md), the exit value gets the lobe's exact value in place of the
//! truncated series it holds:
//!
//! ```text
//!   f_exit += A(s_o) B(s_b) [ f(o <- i) - sum_{m < M} (2 - delta_m0)/(2 pi) F^m cos(m phi) ]            (R18)
//! ```
//!
//! `B` is the beam's irradiance arriving at the face (unscattered, through the
//! smooth faces and layers above it and their bounces), `A` the exit
//! direction's radiance transmission from the face to the outside (above for
//! reflection, below for transmission), both as the engine's slots carry them
//! (delta-M scaled optical depths; the face itself passes no delta path, so
//! it ends every bounce), and `F^m` the face's coefficients as its operators
//! hold them (the same rule and order count, [`Microfacet::fourier`]).

use std::f64::consts::PI;

use km_core::microfacet::{Far, Microfacet, conductor_reflectance};
use km_core::{MonoScene, Substrate};

use crate::quadrature::{AngularGrid, MediumNodes, mu_of_invariant};
use crate::rough::{DoublePath, Exit, RoughFace, TwoFaces, double_path};
use crate::stack::{ScalarOp as Op, Scaled, star};

/// A piece that passes every delta path unchanged.
const CLEAR: Op = (0.0, 1.0, 0.0, 1.0);

/// One piece of the stack as a delta path sees it.
#[derive(Debug, Clone, Copy)]
enum Piece {
    /// A face from index `na` above to `nb` below (`rough`: its microfacets).
    Face { na: f64, nb: f64, rough: Option<Microfacet> },
    /// A layer of (scaled) optical depth `tau` and index `n`.
    Layer { tau: f64, n: f64 },
    /// A conductor floor under index `na`.
    Conductor { na: f64, n: f64, k: f64, rough: Option<Microfacet> },
    /// A floor that ends every delta path (Lambertian, black).
    Dark,
}

impl Piece {
    /// The piece's scalar operators at Snell invariant `s`; `radiance`:
    /// transmission of a radiance (times `(n_to / n_from)^2`), else of an
    /// irradiance on a horizontal plane. A rough face passes no delta path.
    fn op(&self, s: f64, radiance: bool) -> Op {
        match *self {
            Piece::Face { rough: Some(_), .. } | Piece::Dark => (0.0, 0.0, 0.0, 0.0),
            Piece::Conductor { rough: Some(_), .. } => (0.0, 0.0, 0.0, 0.0),
            Piece::Face { na, nb, rough: None } => {
                match (mu_of_invariant(s, na), mu_of_invariant(s, nb)) {
                    (Some(a), Some(b)) => {
                        let ra = km_core::fresnel::reflectance(a, na, nb);
                        let rb = km_core::fresnel::reflectance(b, nb, na);
                        let (fd, fu) = if radiance {
                            ((nb / na).powi(2), (na / nb).powi(2))
                        } else {
                            (1.0, 1.0)
                        };
                        (ra, (1.0 - ra) * fd, rb, (1.0 - rb) * fu)
                    }
                    (Some(_), None) => (1.0, 0.0, 0.0, 0.0),
                    (None, Some(_)) => (0.0, 0.0, 1.0, 0.0),
                    (None, None) => (0.0, 0.0, 0.0, 0.0),
                }
            }
            Piece::Layer { tau, n } => {
                let t = match mu_of_invariant(s, n) {
                    Some(mu) if tau.is_finite() => (-tau / mu).exp(),
                    _ => 0.0,
                };
                (0.0, t, 0.0, t)
            }
            Piece::Conductor { na, n, k, rough: None } => match mu_of_invariant(s, na) {
                Some(mu) => (conductor_reflectance(mu, na, n, k), 0.0, 0.0, 0.0),
                None => (0.0, 0.0, 0.0, 0.0),
            },
        }
    }
}

/// The stack as delta paths see it, top down.
fn pieces(scene: &MonoScene, layers: &[Scaled], n_sub: Option<f64>) -> Vec<Piece> {
    pieces_cut(scene, layers, &[], n_sub).0
}

/// [`pieces`] of the layers `above` a cut and `below` it, and the index of
/// the first piece below the cut.
fn pieces_cut(
    scene: &MonoScene,
    above: &[Scaled],
    below: &[Scaled],
    n_sub: Option<f64>,
) -> (Vec<Piece>, usize) {
    let mut out = Vec::new();
    let mut n_prev = scene.ambient_n();
    let mut cut = 0;
    for (i, l) in above.iter().chain(below).enumerate() {
        if i == above.len() {
            cut = out.len();
        }
        if l.n != n_prev {
            out.push(Piece::Face { na: n_prev, nb: l.n, rough: l.rough });
        }
        out.push(Piece::Layer { tau: l.tau, n: l.n });
        n_prev = l.n;
    }
    if below.is_empty() {
        cut = out.len();
    }
    match (scene.substrate(), n_sub) {
        (Substrate::Transparent { .. }, Some(ns)) if ns != n_prev => {
            out.push(Piece::Face { na: n_prev, nb: ns, rough: scene.substrate_roughness() });
        }
        (Substrate::Transparent { .. }, _) => {}
        (Substrate::Conductor { n, k }, _) => {
            out.push(Piece::Conductor { na: n_prev, n, k, rough: scene.substrate_roughness() })
        }
        _ => out.push(Piece::Dark),
    }
    (out, cut)
}

/// The first rough face under a beam and the delta paths to and from it.
#[derive(Debug, Clone)]
pub(crate) struct RoughPath {
    mf: Microfacet,
    /// Index above the face, and what lies below it.
    n_above: f64,
    far: Far,
    /// The beam's Snell invariant and its irradiance at the face (`B`).
    s_b: f64,
    b: f64,
    /// Pieces above and below the face (below: `None` for a conductor floor).
    above: Vec<Piece>,
    below: Option<Vec<Piece>>,
    /// Index of the ambient medium and of the substrate light leaves into.
    n0: f64,
    n_sub: Option<f64>,
    /// A second rough face under layers alone (eq. R19, transmitted).
    second: Option<Second>,
    /// The nodes above and below a dielectric first face whose delta paths
    /// below reflect (eq. R19, back up through the face).
    back: Option<[MediumNodes; 2]>,
}

/// The second rough face of eq. R19: layers alone (optical depth `tau`)
/// between it and the first, the pieces below it, and the nodes of the media
/// above the first face, between the faces and below the second.
#[derive(Debug, Clone)]
struct Second {
    mf: Microfacet,
    tau: f64,
    below: Vec<Piece>,
    nodes: [MediumNodes; 3],
}

/// Orders the exact sum of eq. R19 takes: a GGX lobe's coefficients fall
/// about as `(1 + alpha m) exp(-alpha m)` (a Lorentzian's transform), and
/// the path's as their product, below 1e-6 of order 0 from `m = 10 / alpha`;
/// never fewer than the operators'.
fn exact_orders(alpha: f64, built: usize) -> usize {
    ((10.0 / alpha).ceil() as usize).min(1024).max(built.max(1))
}

impl RoughPath {
    /// The first rough face the beam of invariant `s_b` meets, if any.
    pub(crate) fn new(
        scene: &MonoScene,
        layers: &[Scaled],
        n_sub: Option<f64>,
        s_b: f64,
        grid: &AngularGrid,
    ) -> Option<RoughPath> {
        let all = pieces(scene, layers, n_sub);
        let k = all.iter().position(|p| {
            matches!(
                p,
                Piece::Face { rough: Some(_), .. } | Piece::Conductor { rough: Some(_), .. }
            )
        })?;
        let (mf, n_above, far, below) = match all[k] {
            Piece::Face { na, nb, rough: Some(mf) } => {
                (mf, na, Far::Dielectric(nb), Some(all[k + 1..].to_vec()))
            }
            Piece::Conductor { na, n, k: kk, rough: Some(mf) } => {
                (mf, na, Far::Conductor(n, kk), None)
            }
            _ => return None,
        };
        let above = all[..k].to_vec();
        let b = above.iter().fold(CLEAR, |acc, p| star(acc, p.op(s_b, false))).1;
        let second = below.as_deref().and_then(|b| second_face(b, n_above, far, grid));
        let back = match (far, below.as_deref()) {
            (Far::Dielectric(nb), Some(b)) if reflects(b) => {
                Some([grid.medium(n_above), grid.medium(nb)])
            }
            _ => None,
        };
        let n0 = scene.ambient_n();
        Some(RoughPath { mf, n_above, far, s_b, b, above, below, n0, n_sub, second, back })
    }

    /// What the single rough path needs at exit polar angle `theta_deg`,
    /// above (`transmit = false`) or below, whatever the azimuth: `A B`, the
    /// directions' cosines and the face's coefficients as its operators hold
    /// them (`built` orders). With `double`, the double path of eq. R19 too:
    /// below a second rough face reached through layers alone, or back up
    /// through the first face. `None` where no such path reaches the exit.
    pub(crate) fn at_polar(
        &self,
        theta_deg: f64,
        transmit: bool,
        built: usize,
        double: bool,
    ) -> Option<AtPolar> {
        if self.b == 0.0 {
            return None;
        }
        if transmit && let Some(second) = &self.second {
            return if double { self.through_second(second, theta_deg, built) } else { None };
        }
        let sin_o = theta_deg.to_radians().sin();
        // The exit's invariant, and its radiance transmission from the face.
        let (s_x, a) = if transmit {
            let (Some(below), Some(ns)) = (&self.below, self.n_sub) else { return None };
            let s = ns * sin_o;
            (s, below.iter().fold(CLEAR, |acc, p| star(acc, p.op(s, true))).1)
        } else {
            let s = self.n0 * sin_o;
            (s, self.above.iter().fold(CLEAR, |acc, p| star(acc, p.op(s, true))).3)
        };
        if a == 0.0 {
            return None;
        }
        let n_o = match (transmit, self.far) {
            (true, Far::Dielectric(nb)) => nb,
            (true, Far::Conductor(..)) => return None,
            (false, _) => self.n_above,
        };
        let mu_i = mu_of_invariant(self.s_b, self.n_above)?;
        let mu_o = mu_of_invariant(s_x, n_o)?;
        let mut coef = vec![0.0; built.max(1)];
        self.mf.fourier(mu_o, mu_i, self.n_above, self.far, transmit, &mut coef);
        let double = match (&self.back, double) {
            (Some(nodes), true) => {
                let exit = if transmit { Exit::Inside } else { Exit::Back };
                self.reflected_below(nodes, s_x, exit, built)
            }
            _ => None,
        };
        Some(AtPolar { ab: a * self.b, mu_i, mu_o, transmit, single: Some(coef), double })
    }

    /// Eq. R19 to the exit below the second face.
    fn through_second(&self, second: &Second, theta_deg: f64, built: usize) -> Option<AtPolar> {
        let ns = self.n_sub?;
        let s_o = ns * theta_deg.to_radians().sin();
        let a = second.below.iter().fold(CLEAR, |acc, p| star(acc, p.op(s_o, true))).1;
        let [up, mid, down] = &second.nodes;
        let (mu_i, mu_o) = (mu_of_invariant(self.s_b, up.n)?, mu_of_invariant(s_o, down.n)?);
        // (Facets refract any direction: u_b or u_o beyond the medium
        // between, n^2, still meet its cells.)
        if a == 0.0 {
            return None;
        }
        let tau = second.tau;
        let att = move |mu: f64| if mu > 0.0 { (-tau / mu).exp() } else { 0.0 };
        let f2 = RoughFace { mf: second.mf, n_above: mid.n, below: Far::Dielectric(down.n) };
        let faces = TwoFaces {
            first: (RoughFace { mf: self.mf, n_above: up.n, below: Far::Dielectric(mid.n) }, up),
            mid,
            between: &att,
            exit: Exit::Below(f2, down),
        };
        let m = exact_orders(self.mf.alpha().min(second.mf.alpha()), built);
        let d = double_path(&faces, (self.s_b * self.s_b, s_o * s_o), built, m);
        Some(AtPolar { ab: a * self.b, mu_i, mu_o, transmit: true, single: None, double: Some(d) })
    }

    /// Eq. R19 with the delta paths below the first face reflecting between
    /// its two meetings: back up through it, or reflected down by it again
    /// (`exit`); `s_o` the exit's invariant.
    fn reflected_below(
        &self,
        nodes: &[MediumNodes; 2],
        s_o: f64,
        exit: Exit<'_>,
        built: usize,
    ) -> Option<DoublePath> {
        let [up, mid] = nodes;
        let below = self.below.as_ref()?;
        let n = mid.n;
        let refl = |mu: f64| {
            let s = n * (1.0 - mu * mu).max(0.0).sqrt();
            below.iter().fold(CLEAR, |acc, p| star(acc, p.op(s, false))).0
        };
        let faces = TwoFaces {
            first: (RoughFace { mf: self.mf, n_above: up.n, below: Far::Dielectric(n) }, up),
            mid,
            between: &refl,
            exit,
        };
        let m = exact_orders(self.mf.alpha(), built);
        Some(double_path(&faces, (self.s_b * self.s_b, s_o * s_o), built, m))
    }

    /// The exact values of the single rough path (eq. R18) and of the double
    /// one (eq. R19) minus their truncated series at azimuth `phi_deg` of
    /// the polar angle `at`, `summed` of its orders in the exit values.
    pub(crate) fn correction(&self, at: &AtPolar, phi_deg: f64, summed: usize) -> f64 {
        let phi = phi_deg.to_radians();
        // The operators' coefficients are in the azimuth between the
        // directions of travel (0 on the mirror plane, phi = 180 degrees).
        let c1 = (phi - PI).cos();
        let mut value = 0.0;
        if let Some(coef) = &at.single {
            let (mu_i, mu_o) = (at.mu_i, at.mu_o);
            let si = (1.0 - mu_i * mu_i).max(0.0).sqrt();
            let so = (1.0 - mu_o * mu_o).max(0.0).sqrt();
            let z = if at.transmit { -mu_o } else { mu_o };
            let o = [so * phi.cos(), so * phi.sin(), z];
            let exact = self.mf.bsdf([si, 0.0, mu_i], o, self.n_above, self.far);
            value += exact - cosine_series(coef, c1, summed);
        }
        if let Some(d) = &at.double {
            value +=
                cosine_series(&d.exact, c1, d.exact.len()) - cosine_series(&d.held, c1, summed);
        }
        at.ab * value
    }
}

/// `sum_{m < count} (2 - delta_m0) / (2 pi) c_m cos(m psi)` from `cos psi`
/// (Chebyshev's recurrence).
fn cosine_series(c: &[f64], c1: f64, count: usize) -> f64 {
    let (mut prev, mut cur, mut series) = (c1, 1.0, 0.0);
    for (m, x) in c.iter().take(count).enumerate() {
        series += if m == 0 { 1.0 } else { 2.0 } / (2.0 * PI) * x * cur;
        (prev, cur) = (cur, if m == 0 { c1 } else { 2.0 * c1 * cur - prev });
    }
    series
}

/// Whether the delta paths of the pieces `below` a face reflect: the first
/// piece other than a layer is a smooth face or a smooth conductor.
fn reflects(below: &[Piece]) -> bool {
    matches!(
        below.iter().find(|p| !matches!(p, Piece::Layer { .. })),
        Some(Piece::Face { rough: None, .. } | Piece::Conductor { rough: None, .. })
    )
}

/// The second rough face of eq. R19 in the pieces `below` the first (a
/// dielectric face from `n_above` to `far`): one reached through layers
/// alone, a dielectric.
fn second_face(below: &[Piece], n_above: f64, far: Far, grid: &AngularGrid) -> Option<Second> {
    let Far::Dielectric(n_mid) = far else { return None };
    let mut tau = 0.0;
    for (j, p) in below.iter().enumerate() {
        match *p {
            Piece::Layer { tau: t, .. } => tau += t,
            Piece::Face { na, nb, rough: Some(mf) } if na == n_mid => {
                let nodes = [grid.medium(n_above), grid.medium(n_mid), grid.medium(nb)];
                return Some(Second { mf, tau, below: below[j + 1..].to_vec(), nodes });
            }
            _ => return None,
        }
    }
    None
}

/// The rough paths at one exit polar angle ([`RoughPath::at_polar`]).
#[derive(Debug, Clone)]
pub(crate) struct AtPolar {
    ab: f64,
    mu_i: f64,
    mu_o: f64,
    transmit: bool,
    /// The single path's coefficients as the operators hold them (eq. R18).
    single: Option<Vec<f64>>,
    /// The double path (eq. R19).
    double: Option<DoublePath>,
}

/// The beam's single rough path to the directions inside the stack at one
/// depth (eq. R18 at a depth, eq. D14a of docs/field.md): the stack's
/// layers cut there into `above` and `below` (the cut in a medium of index
/// `n_cut`), and the first rough face under the beam.
///
/// With that face above the cut, it transmits the beam and the pieces
/// between carry it down to the cut (`t`), where the probe's own reflections
/// between the two parts (`r'` of the part above, from below; `r` of the
/// part below) divide it by `1 - r' r` (eq. D14): down-going
/// `t / (1 - r' r)`, up-going `t r / (1 - r' r)`. With the face below the
/// cut it reflects the beam, and the pieces between carry it up: up-going
/// `t / (1 - r' r)`, down-going `t r' / (1 - r' r)`.
pub(crate) struct InsidePath {
    all: Vec<Piece>,
    /// The first piece below the cut, and the first rough face.
    cut: usize,
    face: usize,
    mf: Microfacet,
    n_face: f64,
    far: Far,
    n_cut: f64,
    s_b: f64,
    /// The beam's irradiance at the face.
    b: f64,
}

impl InsidePath {
    /// The path of the beam of invariant `s_b`, if it meets a rough face.
    pub(crate) fn new(
        scene: &MonoScene,
        (above, below): (&[Scaled], &[Scaled]),
        n_sub: Option<f64>,
        n_cut: f64,
        s_b: f64,
    ) -> Option<InsidePath> {
        let (all, cut) = pieces_cut(scene, above, below, n_sub);
        let (face, mf, n_face, far) = all.iter().enumerate().find_map(|(k, p)| match *p {
            Piece::Face { na, nb, rough: Some(mf) } => Some((k, mf, na, Far::Dielectric(nb))),
            Piece::Conductor { na, n, k: kk, rough: Some(mf) } => {
                Some((k, mf, na, Far::Conductor(n, kk)))
            }
            _ => None,
        })?;
        let b = all[..face].iter().fold(CLEAR, |acc, p| star(acc, p.op(s_b, false))).1;
        (b != 0.0).then_some(InsidePath { all, cut, face, mf, n_face, far, n_cut, s_b, b })
    }

    /// The exact value minus the truncated series the probes hold at the
    /// direction `[theta, phi]` (degrees; theta from the downward normal,
    /// above 90 up-going), the face's `built` orders and the `summed` ones; 0
    /// where the single rough path does not reach it.
    pub(crate) fn correction(&self, dir: [f64; 2], (built, summed): (usize, usize)) -> f64 {
        let (all, c, k) = (&self.all, self.cut, self.face);
        let down = dir[0] < 90.0;
        let local = if down { dir[0] } else { 180.0 - dir[0] };
        let s = self.n_cut * local.to_radians().sin();
        let fold = |ps: &[Piece]| ps.iter().fold(CLEAR, |acc, p| star(acc, p.op(s, true)));
        // A face above the cut (a dielectric: a conductor is the floor)
        // transmits; one below reflects.
        let transmit = k < c;
        let a = if transmit {
            let (between, r) = (fold(&all[k + 1..c]), fold(&all[c..]).0);
            let den = 1.0 - between.2 * r;
            if down { between.1 / den } else { between.1 * r / den }
        } else {
            let (between, r1) = (fold(&all[c..k]), fold(&all[..c]).2);
            let den = 1.0 - r1 * between.0;
            if down { between.3 * r1 / den } else { between.3 / den }
        };
        let n_o = match self.far {
            Far::Dielectric(nb) if transmit => nb,
            _ => self.n_face,
        };
        let (Some(mu_i), Some(mu_o)) =
            (mu_of_invariant(self.s_b, self.n_face), mu_of_invariant(s, n_o))
        else {
            return 0.0;
        };
        if a == 0.0 || !a.is_finite() {
            return 0.0;
        }
        let (si, so) = ((1.0 - mu_i * mu_i).max(0.0).sqrt(), (1.0 - mu_o * mu_o).max(0.0).sqrt());
        let phi = dir[1].to_radians();
        let o = [so * phi.cos(), so * phi.sin(), if transmit { -mu_o } else { mu_o }];
        let exact = self.mf.bsdf([si, 0.0, mu_i], o, self.n_face, self.far);
        let mut coef = vec![0.0; built.max(1)];
        self.mf.fourier(mu_o, mu_i, self.n_face, self.far, transmit, &mut coef);
        a * self.b * (exact - cosine_series(&coef, (phi - PI).cos(), summed))
    }
}
