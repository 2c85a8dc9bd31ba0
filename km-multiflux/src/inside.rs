//! Radiance at user directions inside the stack, `I(z, theta, phi)`, at any
//! depth (`docs/field.md` §2a, eq. D12–D15).
//!
//! The stack is cut at the depth `z` into the part above and the part below
//! (the layer holding `z` split into two pieces of its own optical
//! thickness, as [`crate::internal_field`] does), and each part's operators
//! carry the user directions as probes (exit directions of zero quadrature
//! weight, `docs/multiflux.md` §5 and [`crate::adding::probed`]): a probe's
//! row of a layer's operator is the integral of that layer's source function
//! along the probe's path, done analytically per eigenmode (Stamnes et al.
//! 1988 §3.6, eq. 14 of `docs/multiflux.md`), and the adding carries it
//! through the layers above and below. At the cut the core streams are those
//! of eq. 19' and each probe's pair of streams is eq. PA2 of the star
//! product read at the common boundary: the radiance arriving at `z` from
//! above in direction `mu` and from below, each with its own reflections
//! between the two parts. Fourier orders are summed as a cosine series in
//! the azimuth (`cos m (phi - 180 deg)`, the BSDF's convention: `phi = 180`
//! is the side towards which the beam travels).

use faer::Mat;
use km_core::{MonoScene, Substrate};

use crate::MultifluxError;
use crate::adding::probed::Augmented;
use crate::correction::PeakCorrection;
use crate::engine::rough_paths::InsidePath;
use crate::engine::{ExtraSetup, Extras, FourierStop, OrderPieces, corrected_layers, last_moment};
use crate::field::{input, locate, split_at_depth};
use crate::options::MultifluxOptions;
use crate::prepare::{media_grid, resolve_streams, scale_layers};
use crate::quadrature::{AngularGrid, mu_of_invariant};
use crate::stack::Scaled;

/// Radiance at user directions inside the stack, per unit incident
/// irradiance (per unit incident power), at each requested depth.
#[derive(Debug, Clone, PartialEq)]
pub struct InsideRadiance {
    /// The depths, in the scene's length unit from the top surface.
    pub depths: Vec<f64>,
    /// The directions `[theta, phi]` in degrees: `theta` from the downward
    /// normal (`theta < 90` down-going, `theta > 90` up-going), `phi` the
    /// azimuth with 180 on the side towards which the beam travels.
    pub directions: Vec<[f64; 2]>,
    /// `radiance[k][j]`: the diffuse radiance at depth `k` in direction `j`
    /// (1/sr; the collimated beams, deltas in angle, are apart), the
    /// single-scattering correction included.
    pub radiance: Vec<Vec<f64>>,
    /// `correction[k][j]`: the single-scattering correction (TMS,
    /// `docs/field.md` eq. D17) that `radiance` includes; 0 without a beam,
    /// without delta-M or without a layer to correct.
    pub correction: Vec<Vec<f64>>,
    /// Irradiance on a horizontal plane of the down-going collimated beam at
    /// each depth: the light not yet scattered (true optical depths) where a
    /// layer is corrected (its singly scattered forward peak is then in
    /// `radiance`), else delta-M scaled (the truncated forward peak travels
    /// with it); 0 for diffuse light.
    pub beam_down: Vec<f64>,
    /// The same for the beam reflected by interfaces below, going up.
    pub beam_up: Vec<f64>,
    /// Fourier orders summed.
    pub orders: usize,
}

/// Most depths times directions of one request.
pub const MAX_INSIDE_VALUES: usize = 1_000_000;

/// [`InsideRadiance`] of `scene` at `depths` (each finite, in `[0, D]`; at an
/// interface, the layer above's side) in `directions` (`[theta, phi]`
/// degrees, `theta` in `[0, 180]` but not 90, `phi` finite).
///
/// Orders: 0 for diffuse light; under a beam up to the last non-negligible
/// phase-function moment (every order the streams resolve with all
/// effects), stopping after two orders below `fourier_tol` of the largest
/// value (DISORT's test). Under a beam with delta-M, the single scattering
/// of the layers whose phase function the kept moments do not represent is
/// made exact (TMS, Nakajima & Tanaka 1988; `docs/field.md` eq. D17): the
/// markers of the exit correction carried to the cut, with the exits'
/// second-order (IMS) term near the beam's polar angle (eq. D18) when
/// `opts.secondary_correction` is on.
///
/// # Errors
/// An empty list, a depth outside the stack, a direction out of range, a
/// rough face, too many values ([`MultifluxError::Option`]), and those of
/// the solver.
///
/// ```
/// use km_multiflux::{MultifluxOptions, inside::inside_radiance};
/// // A clear slab on a Lambertian floor of albedo 0.5: the up-going radiance
/// // is the floor's albedo / pi at every depth and angle.
/// let s = km_core::Scene::from_toml_str(
///     "[[layer]]\nsigma_a = 0.0\nsigma_s = 0.0\nthickness = 1.0\n\
///      [substrate]\nkind = \"lambertian\"\nalbedo = 0.5\n").unwrap();
/// let r = inside_radiance(&s.channels()[0], &MultifluxOptions::default(), &[0.5], &[[150.0, 0.0]])
///     .unwrap();
/// assert!((r.radiance[0][0] - 0.5 / std::f64::consts::PI).abs() < 1e-12);
/// ```
pub fn inside_radiance(
    scene: &MonoScene,
    opts: &MultifluxOptions,
    depths: &[f64],
    directions: &[[f64; 2]],
) -> Result<InsideRadiance, MultifluxError> {
    check_request(scene, depths, directions)?;
    let streams = resolve_streams(scene, opts)?;
    let (n_sub, grid) = media_grid(scene, streams);
    let layers = scale_layers(scene, opts, streams);
    let beams: Vec<f64> = scene.beam_invariant().into_iter().collect();
    let diffuse = beams.is_empty();
    let (polar, p_of) = distinct_polar(directions);
    let last = last_order(scene, opts, &layers, diffuse, streams);
    let nd = depths.len();
    // The layers whose single scattering is made exact (as at the exits).
    let tms = if diffuse { Vec::new() } else { corrected_layers(scene, &layers, opts.delta_m) };
    let corr: Vec<Option<PeakCorrection>> =
        (0..layers.len()).map(|l| tms.contains(&l).then(|| layers[l].correction())).collect();
    let mut out = InsideRadiance {
        depths: depths.to_vec(),
        directions: directions.to_vec(),
        radiance: vec![vec![0.0; directions.len()]; nd],
        correction: vec![vec![0.0; directions.len()]; nd],
        beam_down: vec![0.0; nd],
        beam_up: vec![0.0; nd],
        orders: 0,
    };
    let shared = Shared {
        scene,
        opts,
        grid: &grid,
        layers: &layers,
        beams: &beams,
        polar: &polar,
        n_sub,
        diffuse,
        orders: last + 1,
        tms: &tms,
        corr: &corr,
    };
    let mut stop = FourierStop::new(opts.fourier_tol);
    let mut largest = 0.0f64;
    for m in 0..=last {
        let mut term = 0.0f64;
        for (k, &z) in depths.iter().enumerate() {
            let cut = shared.probes_at(z, m)?;
            if m == 0 {
                out.beam_down[k] = cut.beam_down;
                out.beam_up[k] = cut.beam_up;
                if !tms.is_empty() {
                    // The beams not yet scattered (the corrected radiance
                    // holds the peak the scaled beams carry).
                    (out.beam_down[k], out.beam_up[k]) = shared.true_beams(z)?;
                    shared.correct(&cut, directions, &p_of, &mut out.correction[k]);
                }
            }
            for (j, d) in directions.iter().enumerate() {
                let p = p_of[j];
                let v = if d[0] < 90.0 { cut.down[p] } else { cut.up[p] };
                let c = (m as f64 * (d[1] - 180.0).to_radians()).cos();
                out.radiance[k][j] += v * c;
                term = term.max(v.abs());
            }
        }
        out.orders = m + 1;
        if m == 0 {
            largest = term;
            continue;
        }
        if !opts.all_effects {
            let now = out.radiance.iter().flatten().fold(0.0f64, |a, &b| a.max(b.abs()));
            largest = largest.max(now);
            if stop.converged(term, largest) {
                break;
            }
        }
    }
    // The corrections after the orders (their stopping rule sees the
    // discrete-ordinate values alone): the single scattering's, and the
    // beam's single rough path exact in place of its truncated series (eq.
    // R18 at a depth).
    for (r, c) in out.radiance.iter_mut().zip(&out.correction) {
        r.iter_mut().zip(c).for_each(|(r, c)| *r += c);
    }
    if let (Some(&s_b), true) = (beams.first(), scene.has_rough_face()) {
        shared.exact_rough_path(s_b, &mut out);
    }
    if !out.radiance.iter().flatten().all(|v| v.is_finite()) {
        return Err(MultifluxError::Numerical {
            what: "inside_radiance",
            detail: "non-finite radiance".into(),
        });
    }
    Ok(out)
}

/// The last Fourier order of the radiance inside: 0 for diffuse light; every
/// order the streams resolve with all effects or a rough face (whose lobe
/// needs them, as at the exits; the azimuthal test ends the series early);
/// else the last non-negligible moment; never above the options' bound.
fn last_order(
    scene: &MonoScene,
    opts: &MultifluxOptions,
    layers: &[Scaled],
    diffuse: bool,
    streams: usize,
) -> usize {
    let last = if diffuse {
        0
    } else if opts.all_effects || scene.has_rough_face() {
        2 * streams - 1
    } else {
        last_moment(layers)
    };
    last.min(opts.max_fourier_order.unwrap_or(usize::MAX))
}

/// The distinct polar angles of `directions` in the local hemisphere
/// (theta and 180 - theta share a probe: its down- and up-going streams),
/// and per direction the index of its angle.
fn distinct_polar(directions: &[[f64; 2]]) -> (Vec<f64>, Vec<usize>) {
    let local = |t: f64| if t > 90.0 { 180.0 - t } else { t };
    let mut polar: Vec<f64> = Vec::new();
    let p_of = directions
        .iter()
        .map(|d| {
            let t = local(d[0]);
            polar.iter().position(|&p| p == t).unwrap_or_else(|| {
                polar.push(t);
                polar.len() - 1
            })
        })
        .collect();
    (polar, p_of)
}

/// What every depth and Fourier order of [`inside_radiance`] shares.
struct Shared<'a> {
    scene: &'a MonoScene,
    opts: &'a MultifluxOptions,
    grid: &'a AngularGrid,
    layers: &'a [Scaled],
    beams: &'a [f64],
    polar: &'a [f64],
    n_sub: Option<f64>,
    diffuse: bool,
    orders: usize,
    /// The corrected layers (their markers ride at `m = 0`).
    tms: &'a [usize],
    /// Per layer of the stack, its correction (corrected layers only).
    corr: &'a [Option<PeakCorrection>],
}

impl Shared<'_> {
    /// The beam's single rough path (invariant `s_b`) exact at every depth
    /// and direction of `out` in place of the truncated series its orders
    /// hold (eq. D14a of docs/field.md).
    fn exact_rough_path(&self, s_b: f64, out: &mut InsideRadiance) {
        let orders = (self.orders, out.orders);
        for (k, &z) in out.depths.iter().enumerate() {
            let cut = self.cut(self.layers, z);
            let halves = (&cut.above[..], &cut.below[..]);
            let Some(path) = InsidePath::new(self.scene, halves, self.n_sub, cut.n_cut, s_b) else {
                continue;
            };
            for (r, &d) in out.radiance[k].iter_mut().zip(&out.directions) {
                *r += path.correction(d, orders);
            }
        }
    }

    /// The probes' streams at depth `z` in Fourier order `m`: the stack cut
    /// at `z`, each half added with the probes as extra directions, and the
    /// two halves' adding read off at the cut.
    fn probes_at(&self, z: f64, m: usize) -> Result<ProbesAtCut, MultifluxError> {
        let cut = self.cut(self.layers, z);
        let (i_cut, n_cut) = (cut.i_cut, cut.n_cut);
        // The probes by Snell invariant in the medium at the cut, and at
        // m = 0 the markers of the corrected layers (eq. D17): per probe,
        // layer and slot (backward, forward), in the same order above and
        // below the cut. A marker names its layer by its index in the part
        // (above: the stack's own; below: from the lower piece of the cut
        // layer on, the layers above the cut by an index no layer has).
        // With the second-order term (eq. D18) a probe near the beam's polar
        // angle also has the far side's IMS marker (slot 2) per layer.
        let tms: &[usize] = if m == 0 { self.tms } else { &[] };
        let setup = ExtraSetup {
            n0: n_cut,
            n_sub: None,
            layers: self.layers,
            tms_layers: tms,
            corr: self.corr,
            secondary: self.opts.secondary_correction,
        };
        let extras_a = Extras::new(self.beams, self.polar, &setup);
        let below_index = |l: usize| if l >= i_cut { l - i_cut } else { usize::MAX - l };
        let mut extras_b = extras_a.clone();
        for e in &mut extras_b.ex {
            if let crate::engine::Kind::Marker { l, .. } = &mut e.1 {
                *l = below_index(*l);
            }
        }
        // The pieces' corrections (their IMS markers' path factors): the
        // upper piece of the cut layer from its top to `z`, the lower one on.
        let corr_of = |l: usize| self.corr.get(l).cloned().flatten();
        let corr_a: Vec<_> = (0..cut.above.len()).map(corr_of).collect();
        let corr_b: Vec<_> = (0..cut.below.len()).map(|k| corr_of(i_cut + k)).collect();
        let pieces_a = OrderPieces {
            grid: self.grid,
            extras: &extras_a,
            corr: &corr_a,
            count: extras_a.ex.len(),
            m,
            orders: self.orders,
            all_effects: self.opts.all_effects,
        };
        let pieces_b = OrderPieces { extras: &extras_b, corr: &corr_b, ..pieces_a };
        let extras = &extras_a;
        let n0 = self.scene.ambient_n();
        // Incident light on the probes themselves (diffuse light only: a
        // probe that propagates in the ambient medium receives 1/pi).
        // The markers receive nothing from outside.
        let probe_in: Vec<f64> = extras.ex[extras.r0..]
            .iter()
            .map(|&(s, kind)| {
                let probe = kind == crate::engine::Kind::Probe;
                if probe && self.diffuse && m == 0 && mu_of_invariant(s, n0).is_some() {
                    1.0 / std::f64::consts::PI
                } else {
                    0.0
                }
            })
            .collect();
        let mut at = self.add_halves(&cut, [&pieces_a, &pieces_b], m, &probe_in, || {
            format!("depth {z}, order {m}")
        })?;
        // The markers' streams: per marker its probe's polar angle, layer,
        // slot, Snell invariant and the weights down and up at the cut.
        let first = extras.base_len - extras.beams;
        at.markers = extras
            .marker_of
            .iter()
            .enumerate()
            .map(|(k, &(p, l, slot))| Marker {
                polar: p - extras.r0,
                layer: l,
                slot,
                invariant: extras.ex[p].0,
                down: at.down[first + k],
                up: at.up[first + k],
            })
            .collect();
        Ok(at)
    }

    /// The collimated beams at depth `z` not yet scattered: the stack's
    /// core at `m = 0` with every layer non-scattering of its true optical
    /// thickness (the beam column of the adding carries the beams alone:
    /// diffuse light never enters it), read at the cut.
    fn true_beams(&self, z: f64) -> Result<(f64, f64), MultifluxError> {
        let clear: Vec<Scaled> = self
            .layers
            .iter()
            .map(|l| {
                let mut c = l.clone();
                (c.tau, c.omega, c.omega_true) = (l.tau_true, 0.0, 0.0);
                c
            })
            .collect();
        let cut = self.cut(&clear, z);
        let setup = ExtraSetup {
            n0: cut.n_cut,
            n_sub: None,
            layers: &clear,
            tms_layers: &[],
            corr: &[],
            secondary: false,
        };
        let extras = Extras::new(self.beams, &[], &setup);
        let pieces = OrderPieces {
            grid: self.grid,
            extras: &extras,
            corr: &[],
            count: extras.ex.len(),
            m: 0,
            orders: 1,
            all_effects: self.opts.all_effects,
        };
        let at =
            self.add_halves(&cut, [&pieces, &pieces], 0, &[], || format!("depth {z}, the beams"))?;
        Ok((at.beam_down, at.beam_up))
    }

    /// `layers` (the stack's, scaled) cut at depth `z`.
    fn cut(&self, layers: &[Scaled], z: f64) -> Cut {
        let (i_cut, dz) = locate(self.scene, z);
        let (above, below) = split_at_depth(self.scene, layers, i_cut, dz);
        Cut { i_cut, n_cut: self.scene.layers()[i_cut].n(), above, below }
    }

    /// The two halves of `cut`, built by `pieces` (above, below) and each
    /// added, read at the cut for order `m`'s input on the top and
    /// `probe_in` on the probes; `detail` names the failure.
    fn add_halves(
        &self,
        cut: &Cut,
        pieces: [&OrderPieces<'_>; 2],
        m: usize,
        probe_in: &[f64],
        detail: impl FnOnce() -> String,
    ) -> Result<ProbesAtCut, MultifluxError> {
        let n_cut = cut.n_cut;
        let scene_above = self.scene.with_substrate(Substrate::Transparent { n: n_cut })?;
        let scene_below = self.scene.with_ambient_n(n_cut)?;
        let neumann = self.opts.neumann_order;
        let a_ops = pieces[0].stack(&scene_above, &cut.above, Some(n_cut), neumann)?;
        let b_ops = pieces[1].stack(&scene_below, &cut.below, self.n_sub, neumann)?;
        let a = input(self.scene, self.grid, m);
        probes_at_cut(&a_ops, &b_ops, &a, probe_in, self.grid, n_cut, self.beams.len())
            .ok_or_else(|| MultifluxError::Numerical { what: "inside_radiance", detail: detail() })
    }

    /// The single-scattering correction at the cut (eq. D17) into `out`,
    /// per direction: each marker's weight (down-going or up-going stream
    /// at the cut) times its layer's source difference at the scattering
    /// angle of its slot (backward for slot 0, forward for slot 1), in the
    /// layer's own cosines; the exits' eq. B1, second line.
    fn correct(&self, cut: &ProbesAtCut, directions: &[[f64; 2]], p_of: &[usize], out: &mut [f64]) {
        let Some(&beam) = self.beams.first() else { return };
        for (j, d) in directions.iter().enumerate() {
            let cphi = (d[1] - 180.0).to_radians().cos();
            for k in cut.markers.iter().filter(|k| k.polar == p_of[j]) {
                let Some(c) = self.corr.get(k.layer).and_then(Option::as_ref) else { continue };
                let n = self.layers[k.layer].n;
                let (Some(mu_b), Some(mu_x)) =
                    (mu_of_invariant(beam, n), mu_of_invariant(k.invariant, n))
                else {
                    continue;
                };
                let w = if d[0] < 90.0 { k.down } else { k.up };
                if w == 0.0 {
                    continue;
                }
                let s = ((1.0 - mu_x * mu_x).max(0.0) * (1.0 - mu_b * mu_b).max(0.0)).sqrt();
                let along = if k.slot == 0 { -mu_x * mu_b } else { mu_x * mu_b };
                out[j] += w * match k.slot {
                    0 | 1 => c.single_source(along + s * cphi, mu_b),
                    // The IMS marker (eq. D18): the peak's second order.
                    _ => c.peak_pspike(along + s * cphi),
                };
            }
        }
    }
}

/// The checks of [`inside_radiance`]'s request.
fn check_request(
    scene: &MonoScene,
    depths: &[f64],
    directions: &[[f64; 2]],
) -> Result<(), MultifluxError> {
    let bad = |name, value: f64, reason| Err(MultifluxError::Option { name, value, reason });
    if depths.is_empty() {
        return bad("depths", 0.0, "need at least one depth");
    }
    if directions.is_empty() {
        return bad("directions", 0.0, "need at least one direction");
    }
    if depths.len().saturating_mul(directions.len()) > MAX_INSIDE_VALUES {
        return bad(
            "directions",
            directions.len() as f64,
            "more than 10^6 depths x directions in one request",
        );
    }
    let total: f64 = scene.layers().iter().map(|l| l.thickness()).sum();
    if let Some(&z) = depths.iter().find(|&&z| !(z.is_finite() && z >= 0.0 && z <= total)) {
        return bad("depths", z, "every depth must be finite and lie in the stack");
    }
    for d in directions {
        if !(d[0] >= 0.0 && d[0] <= 180.0) || d[0] == 90.0 {
            return bad("directions", d[0], "theta must lie in [0, 180] degrees and not be 90");
        }
        if !d[1].is_finite() {
            return bad("directions", d[1], "phi must be finite");
        }
    }
    Ok(())
}

/// A stack cut at a depth: the layer holding it, the index of its medium,
/// and the layers above and below the cut (that layer split in two).
struct Cut {
    i_cut: usize,
    n_cut: f64,
    above: Vec<Scaled>,
    below: Vec<Scaled>,
}

/// The probes' streams at the cut, and the beams'.
struct ProbesAtCut {
    down: Vec<f64>,
    up: Vec<f64>,
    beam_down: f64,
    beam_up: f64,
    /// The markers' (order 0 of a corrected stack).
    markers: Vec<Marker>,
}

/// One marker of the single-scattering correction at the cut.
struct Marker {
    /// Its probe's polar angle (index into the request's).
    polar: usize,
    /// The layer whose single scattering it carries (the stack's index).
    layer: usize,
    /// 0: scattered backward from the beam; 1: forward.
    slot: usize,
    /// Snell invariant of its direction.
    invariant: f64,
    /// Its down-going and up-going streams at the cut.
    down: f64,
    up: f64,
}

/// The streams at the cut between the stack above (`above`) and below
/// (`below`) for the input `a` on the top's core and `probe_in` on the
/// top's probes (eq. D13–D14 of `docs/field.md`, eq. PA2 of
/// [`crate::adding::probed`] read at the common boundary):
///
/// ```text
/// d = (I - R1' R2)^-1 T1 a,   u = R2 d
/// DP = [T1_p a + t1 a_p + R1'_p u + r1' R2_p d] / (1 - r1' r2),   UP = R2_p d + r2 DP
/// ```
///
/// `None` if they are not finite.
fn probes_at_cut(
    above: &Augmented,
    below: &Augmented,
    a: &Mat<f64>,
    probe_in: &[f64],
    grid: &AngularGrid,
    n_cut: f64,
    beams: usize,
) -> Option<ProbesAtCut> {
    use faer::linalg::solvers::Solve;
    let ta = &above.core.t_down * a;
    let dim = below.core.r_top.ncols();
    let mut x = Mat::<f64>::identity(dim, dim);
    x -= &above.core.r_bottom * &below.core.r_top;
    let d = x.partial_piv_lu().solve(ta);
    let u = &below.core.r_top * &d;
    let (pa, pb) = (&above.probes, &below.probes);
    let np = pa.len();
    let row_dot = |m: &Mat<f64>, p: usize, v: &Mat<f64>| -> f64 {
        (0..m.ncols()).map(|j| m[(p, j)] * v[(j, 0)]).sum()
    };
    let (mut down, mut up) = (vec![0.0; np], vec![0.0; np]);
    for p in 0..np {
        let t1 = row_dot(&pa.t_down, p, a) + pa.diag[1][p] * probe_in[p];
        let r1u = row_dot(&pa.r_bottom, p, &u);
        let r2d = row_dot(&pb.r_top, p, &d);
        let (r1, r2) = (pa.diag[2][p], pb.diag[0][p]);
        let dp = (t1 + r1u + r1 * r2d) / (1.0 - r1 * r2);
        down[p] = dp;
        up[p] = r2d + r2 * dp;
    }
    let nn = grid.shared(n_cut).mu.len();
    let out = ProbesAtCut {
        beam_down: if beams == 0 { 0.0 } else { d[(nn, 0)] },
        beam_up: if beams == 0 { 0.0 } else { u[(nn, 0)] },
        down,
        up,
        markers: Vec::new(),
    };
    out.down.iter().chain(&out.up).all(|v| v.is_finite()).then_some(out)
}
