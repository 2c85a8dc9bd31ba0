//! One channel's BSDF table: the augmented operators per Fourier order with
//! the beam, probe and marker directions (eq. B1–B2 of `docs/multiflux.md`),
//! assembled by [`crate::stack::add_stack`].

use super::*;
use crate::quadrature::MediumNodes;

/// Kinds of extra directions in the augmented operators.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Beam,
    Probe,
    /// Marker of layer `l`: `slot` 0 for the path integral of the side the
    /// beam entered (`W_R`), 1 for the far side (`W_T`), 2 for the far side's
    /// second-order peak term (`W_I`, eq. B2).
    Marker {
        l: usize,
        slot: usize,
    },
}

/// Zero the rows of the marker extras in the node and beam columns of one
/// operator (a marker receives only its layer's correction path).
fn scrub(mat: &mut Mat<f64>, kinds: &[Kind]) {
    let e = kinds.len();
    if mat.nrows() < e || mat.ncols() < e {
        return;
    }
    let (nr, nc) = (mat.nrows() - e, mat.ncols() - e);
    for (x, k) in kinds.iter().enumerate() {
        if !matches!(k, Kind::Marker { .. }) {
            continue;
        }
        for col in 0..mat.ncols() {
            if col < nc || kinds[col - nc] == Kind::Beam {
                mat[(nr + x, col)] = 0.0;
            }
        }
    }
}

fn scrub_ops(ops: &mut LayerOperators, kinds: &[Kind]) {
    scrub(&mut ops.r_top, kinds);
    scrub(&mut ops.t_down, kinds);
    scrub(&mut ops.r_bottom, kinds);
    scrub(&mut ops.t_up, kinds);
}

/// The extra directions of one channel (eq. B1): beams, BRDF probes, BTDF
/// probes, then (for `m = 0`) the markers of the corrected layers, each as
/// `(Snell invariant, kind)`.
struct Extras {
    ex: Vec<(f64, Kind)>,
    /// First BRDF probe, first BTDF probe, end of beams and probes.
    r0: usize,
    t0: usize,
    base_len: usize,
    /// Per marker (in the order of `ex[base_len..]`): (probe extra, layer, slot).
    marker_of: Vec<(usize, usize, usize)>,
}

/// What one channel's extras need to know of its layers.
struct ExtraSetup<'a> {
    n0: f64,
    n_sub: Option<f64>,
    layers: &'a [Scaled],
    tms_layers: &'a [usize],
    corr: &'a [Option<crate::correction::PeakCorrection>],
    secondary: bool,
}

impl Extras {
    /// Beams at `theta_i`, probes at `theta_o` (above, and below if light
    /// leaves there), and per probe and corrected layer the markers R and T
    /// (and I where the second-order term can matter, eq. B2).
    fn new(theta_i: &[f64], theta_o: &[f64], c: &ExtraSetup<'_>) -> Self {
        let mut ex: Vec<(f64, Kind)> = Vec::new();
        for &t in theta_i {
            ex.push((c.n0 * t.to_radians().sin(), Kind::Beam));
        }
        let r0 = ex.len();
        for &t in theta_o {
            ex.push((c.n0 * t.to_radians().sin(), Kind::Probe));
        }
        let t0 = ex.len();
        if let Some(ns) = c.n_sub {
            for &t in theta_o {
                ex.push((ns * t.to_radians().sin(), Kind::Probe));
            }
        }
        let base_len = ex.len();
        let ni = theta_i.len();
        // Whether a layer's IMS term can matter: it scales as (omega f)^2 times
        // Legendre sums of at most ~1e3 (2N terms and the tails beyond them), so
        // below omega f = 1e-8 it is under ~1e-13 of a unit radiance and the
        // layer needs no IMS marker.
        let ims_on = |l: usize| {
            c.secondary && c.corr[l].as_ref().is_some_and(|k| c.layers[l].omega_true * k.f() > 1e-8)
        };
        // The IMS term lives only within the cone around the beam's polar angle
        // (in the layer): its marker is needed where some beam is that close
        // (a margin of 1e-6 rad; inside, the solver's own test decides).
        let in_cone = |p: usize, l: usize| {
            let n = c.layers[l].n;
            let cone = crate::correction::IMS_CONE_DEG.to_radians() + 1e-6;
            mu_of_invariant(ex[p].0, n).is_some_and(|mx| {
                (0..ni).any(|i| {
                    mu_of_invariant(ex[i].0, n)
                        .is_some_and(|mb| (mb.acos() - mx.acos()).abs() <= cone)
                })
            })
        };
        // Markers: per probe, per corrected layer, R and T kinds (and I).
        let slots: Vec<usize> = (r0..base_len)
            .flat_map(|p| c.tms_layers.iter().map(move |&l| (p, l)))
            .map(|(p, l)| if ims_on(l) && in_cone(p, l) { 3 } else { 2 })
            .collect();
        let mut slots = slots.into_iter();
        let mut marker_of = Vec::new();
        for p in r0..base_len {
            for &l in c.tms_layers {
                for slot in 0..slots.next().unwrap_or(2) {
                    marker_of.push((p, l, slot));
                    ex.push((ex[p].0, Kind::Marker { l, slot }));
                }
            }
        }
        Extras { ex, r0, t0, base_len, marker_of }
    }

    /// The first `count` extras as [`Extra`]s in the medium of index `n`.
    fn in_medium(&self, n: f64, count: usize) -> Vec<Extra> {
        self.ex[..count]
            .iter()
            .map(|&(s, k)| Extra { mu: mu_of_invariant(s, n), beam: k == Kind::Beam, phi_deg: 0.0 })
            .collect()
    }
}

/// One channel: returns its BSDF and the far-side index if light leaves there.
pub(super) fn channel(
    scene: &MonoScene,
    theta_i: &[f64],
    theta_o: &[f64],
    opts: &MultifluxOptions,
) -> Result<(ChannelBsdf, Option<f64>), BsdfError> {
    let streams = bsdf_streams(scene, theta_i, opts)?;
    let opts = MultifluxOptions { streams: Some(streams), ..opts.clone() };
    let (cut, _) = planned_cutoff(scene, &opts);
    let scene = cut.as_ref().unwrap_or(scene);
    let n0 = scene.ambient_n();
    let (n_sub, grid) = media_grid(scene, streams);
    let layers = scale_layers(scene, &opts, 2 * streams);
    let (ni, no) = (theta_i.len(), theta_o.len());
    let tms_layers = corrected_layers(&layers, opts.delta_m);
    // The solver's correction per layer (TMS and IMS, eq. C2-C4 of `docs/multiflux.md`).
    let corr: Vec<Option<crate::correction::PeakCorrection>> = (0..layers.len())
        .map(|l| tms_layers.contains(&l).then(|| layers[l].correction(2 * streams)))
        .collect();
    let setup = ExtraSetup {
        n0,
        n_sub,
        layers: &layers,
        tms_layers: &tms_layers,
        corr: &corr,
        secondary: opts.secondary_correction,
    };
    let extras = Extras::new(theta_i, theta_o, &setup);
    let kinds_all: Vec<Kind> = extras.ex.iter().map(|e| e.1).collect();

    // Fourier orders (as the solver: up to the last non-negligible moment).
    let m_max = last_moment(&layers).min(opts.max_fourier_order.unwrap_or(usize::MAX));
    // A rough face's lobe needs every order the streams resolve.
    let m_max = if scene.has_rough_face() {
        (2 * streams - 1).min(opts.max_fourier_order.unwrap_or(usize::MAX))
    } else {
        m_max
    };
    let nodes0 = grid.medium(n0);
    let nodes_sub = n_sub.map(|n| grid.medium(n));
    let mut coefs_r: Vec<Vec<f64>> = Vec::new(); // per m, [i * no + o]
    let mut coefs_t: Vec<Vec<f64>> = Vec::new();
    let mut out = empty_table(ni, streams);
    let mut largest = 0.0f64;
    let mut small_orders = 0;
    for m in 0..=m_max {
        // Markers only where the correction lives (m = 0).
        let count = if m == 0 { extras.ex.len() } else { extras.base_len };
        let kinds = &kinds_all[..count];
        let extras_in = |n: f64| extras.in_medium(n, count);
        // Order 0 has the markers (other extras): its rough faces alone.
        let mo = (m, if m == 0 { 1 } else { m_max + 1 });
        let ops =
            stack(scene, &grid, &layers, &corr, n_sub, &extras_in, kinds, mo, opts.neumann_order)?;
        let read = Readout {
            ops: &ops,
            extras: &extras,
            na0: nodes0.mu.len(),
            nb: nodes_sub.as_ref().map_or(0, |n| n.mu.len()),
            ni,
            no,
            below: n_sub.is_some(),
        };
        let (cr, ct, term) = read.coefficients();
        if m == 0 {
            // Totals from the azimuthal mean (nodes) plus the beams' delta parts.
            for i in 0..ni {
                (out.reflectance[i], out.transmittance[i]) =
                    read.totals(i, &nodes0, nodes_sub.as_ref());
                let (spec, direct) = delta_parts(scene, &layers, n_sub, extras.ex[i].0);
                out.reflectance_specular[i] = spec;
                out.transmittance_direct[i] = direct;
            }
            // Correction weights per layer from the markers.
            for &l in &tms_layers {
                let f = corr[l].as_ref().map_or(0.0, |c| c.f());
                out.tms.push(read.marker_weights(&layers[l], l, f, streams));
            }
        }
        coefs_r.push(cr);
        coefs_t.push(ct);
        // Azimuthal convergence, as the solver's (two consecutive small orders).
        largest = largest.max(if m == 0 { term } else { 0.0 });
        if m > 0 {
            small_orders = if term <= FOURIER_TOL * largest { small_orders + 1 } else { 0 };
            if small_orders == 2 {
                break;
            }
        }
    }
    out.orders = coefs_r.len();
    out.coef_r = by_pair(&coefs_r, ni * no);
    out.coef_t = by_pair(&coefs_t, ni * no);
    let finite =
        out.coef_r.iter().chain(&out.coef_t).chain(&out.reflectance).all(|x| x.is_finite());
    if !finite {
        return Err(
            MultifluxError::Numerical { what: "bsdf", detail: "non-finite table".into() }.into()
        );
    }
    Ok((out, n_sub))
}

/// A channel's table before its first order: no coefficients, zero totals
/// for `ni` incidence angles.
fn empty_table(ni: usize, streams: usize) -> ChannelBsdf {
    ChannelBsdf {
        coef_r: Vec::new(),
        coef_t: Vec::new(),
        orders: 0,
        tms: Vec::new(),
        reflectance: vec![0.0; ni],
        transmittance: vec![0.0; ni],
        reflectance_specular: vec![0.0; ni],
        transmittance_direct: vec![0.0; ni],
        streams,
    }
}

/// The operators of one Fourier order read out at the extras: the nodes of
/// the ambient medium (`na0`) and of the medium below (`nb`, 0 without one)
/// come first in each operator, the extras after them.
struct Readout<'a> {
    ops: &'a LayerOperators,
    extras: &'a Extras,
    na0: usize,
    nb: usize,
    /// Incidence and exit counts.
    ni: usize,
    no: usize,
    /// Light leaves below (a transparent substrate).
    below: bool,
}

impl Readout<'_> {
    /// The Fourier coefficients of this order between beams and probes,
    /// `[i * no + o]` for reflection and transmission (eq. B1), and the
    /// largest of them (the azimuthal convergence test).
    fn coefficients(&self) -> (Vec<f64>, Vec<f64>, f64) {
        let (ops, na0, nb, no) = (self.ops, self.na0, self.nb, self.no);
        let (mut cr, mut ct) = (vec![0.0; self.ni * no], vec![0.0; self.ni * no]);
        let mut term = 0.0f64;
        for i in 0..self.ni {
            for o in 0..no {
                let x = ops.r_top[(na0 + self.extras.r0 + o, na0 + i)];
                cr[i * no + o] = x;
                term = term.max(x.abs());
                if self.below {
                    let y = ops.t_down[(nb + self.extras.t0 + o, na0 + i)];
                    ct[i * no + o] = y;
                    term = term.max(y.abs());
                }
            }
        }
        (cr, ct, term)
    }

    /// Reflectance and transmittance of beam `i` from the azimuthal mean
    /// (`m = 0`): the flux of the node columns plus the beam's own extra.
    fn totals(
        &self,
        i: usize,
        nodes0: &MediumNodes,
        nodes_sub: Option<&MediumNodes>,
    ) -> (f64, f64) {
        let (ops, na0, nb) = (self.ops, self.na0, self.nb);
        let col: Vec<f64> = (0..na0).map(|q| ops.r_top[(q, na0 + i)]).collect();
        let r = flux(nodes0, &col) + ops.r_top[(na0 + i, na0 + i)];
        let t = nodes_sub.map_or(0.0, |ns| {
            let col: Vec<f64> = (0..nb).map(|q| ops.t_down[(q, na0 + i)]).collect();
            flux(ns, &col) + ops.t_down[(nb + i, na0 + i)]
        });
        (r, t)
    }

    /// The single-scattering correction of layer `l` (scaled as `s`, truncation
    /// fraction `f`; eq. B1–B2): its scaled moments and cosines, and the
    /// weights `W_R`, `W_T`, `W_I` per (incidence, exit) read from the marker
    /// rows of the `m = 0` operators.
    fn marker_weights(&self, s: &Scaled, l: usize, f: f64, streams: usize) -> TmsLayer {
        let (ops, extras, na0, nb, ni, no) =
            (self.ops, self.extras, self.na0, self.nb, self.ni, self.no);
        let (r0, t0) = (extras.r0, extras.t0);
        let chiw: Vec<f64> =
            s.chi.iter().enumerate().map(|(k, c)| (2 * k + 1) as f64 * c).collect();
        let mu_in = |a: usize| mu_of_invariant(extras.ex[a].0, s.n);
        let rec = km_core::legendre::legendre_coefficients(chiw.len());
        let mut tl = TmsLayer {
            omega_true: s.omega_true,
            f,
            omega: s.omega,
            chiw,
            rec,
            phase: s.phase,
            mu_b: (0..ni).map(mu_in).collect(),
            mu_r: (r0..r0 + no).map(mu_in).collect(),
            mu_t: if self.below { (t0..t0 + no).map(mu_in).collect() } else { vec![None; no] },
            w_r: vec![[0.0; 3]; ni * no],
            w_t: vec![[0.0; 3]; ni * no],
            corr: s.correction(2 * streams),
        };
        for (k, &(p, ml, slot)) in extras.marker_of.iter().enumerate() {
            if ml != l {
                continue;
            }
            let e = extras.base_len + k;
            for i in 0..ni {
                if p < t0 {
                    tl.w_r[i * no + (p - r0)][slot] = ops.r_top[(na0 + e, na0 + i)];
                } else {
                    tl.w_t[i * no + (p - t0)][slot] = ops.t_down[(nb + e, na0 + i)];
                }
            }
        }
        tl
    }
}

/// The stack's operators for order `m` on nodes plus extras, with the
/// marker rows of eq. B1 (as the solver's `stack_operators` without the
/// in-place correction, which the markers carry instead).
#[allow(clippy::too_many_arguments)]
fn stack(
    scene: &MonoScene,
    grid: &AngularGrid,
    layers: &[Scaled],
    corr: &[Option<crate::correction::PeakCorrection>],
    n_sub: Option<f64>,
    extras_in: &dyn Fn(f64) -> Vec<Extra>,
    kinds: &[Kind],
    (m, orders): (usize, usize),
    neumann: Option<usize>,
) -> Result<LayerOperators, MultifluxError> {
    let faces = crate::rough::Faces { grid, extras_in, m, orders };
    let interface = |na: f64, nb: f64, rough| {
        let mut ops = faces.interface(na, nb, rough);
        scrub_ops(&mut ops, kinds);
        ops
    };
    let conductor = |na: f64, n: f64, k: f64, rough| {
        let mut g = faces.conductor(na, n, k, rough);
        scrub(&mut g, kinds);
        g
    };
    let layer = |li: usize, l: &Scaled| {
        let nodes = grid.medium(l.n);
        let ex = extras_in(l.n);
        let p = SlabOrder { tau: l.tau, omega: l.omega, chi: &l.chi, m };
        let mut ops = slab_operators(&nodes.mu, &nodes.w, &ex, &p, None)?;
        scrub_ops(&mut ops, kinds);
        // This layer's correction paths into its markers (unit F).
        let nn = nodes.mu.len();
        for (x, k) in kinds.iter().enumerate() {
            let Kind::Marker { l: ml, slot } = *k else { continue };
            if ml != li {
                continue;
            }
            let Some(mu_x) = ex[x].mu else { continue };
            let beta = 1.0 / mu_x;
            for (b, kb) in kinds.iter().enumerate() {
                let (Kind::Beam, Some(mu_b)) = (kb, ex[b].mu) else { continue };
                let kb = 1.0 / mu_b;
                if slot == 0 {
                    let v = beta * phi(kb + beta, l.tau);
                    ops.r_top[(nn + x, nn + b)] = v;
                    ops.r_bottom[(nn + x, nn + b)] = v;
                } else {
                    let v = if slot == 1 {
                        beta * e2(kb, beta, l.tau)
                    } else {
                        // Eq. B2: the IMS path factor at the unscaled thickness,
                        // as the solver's `PeakCorrection::radiance`.
                        corr[li].as_ref().map_or(0.0, |c| {
                            c.secondary_path(mu_b, mu_x, l.tau / (1.0 - l.omega_true * c.f()))
                        })
                    };
                    ops.t_down[(nn + x, nn + b)] = v;
                    ops.t_up[(nn + x, nn + b)] = v;
                }
            }
        }
        Ok(ops)
    };
    let lambertian = |n: f64, albedo: f64| {
        let mut g = lambertian_reflection(&grid.medium(n), &extras_in(n), albedo, m);
        scrub(&mut g, kinds);
        g
    };
    let pieces = StackPieces {
        interface: &interface,
        layer: &layer,
        lambertian: &lambertian,
        conductor: &conductor,
    };
    add_stack(scene, layers, n_sub, neumann, false, &pieces)
}

/// The stream count: the options', or as `km solve` would choose it for the
/// most demanding incidence of `theta_i`.
fn bsdf_streams(
    scene: &MonoScene,
    theta_i: &[f64],
    opts: &MultifluxOptions,
) -> Result<usize, BsdfError> {
    Ok(match opts.streams {
        Some(_) => resolve_streams(scene, opts)?,
        None => default_bsdf_streams(scene, theta_i),
    })
}

/// Which layers carry a single-scattering correction: scattering ones whose
/// phase function the kept moments do not represent exactly.
fn corrected_layers(layers: &[Scaled], delta_m: bool) -> Vec<usize> {
    if delta_m {
        (0..layers.len())
            .filter(|&l| {
                let s = &layers[l];
                s.omega > 0.0
                    && s.tau > 0.0
                    && !matches!(s.phase, km_core::phase::Phase::Isotropic)
                    && !matches!(s.phase, km_core::phase::Phase::HenyeyGreenstein { g } if g == 0.0)
            })
            .collect()
    } else {
        Vec::new()
    }
}

/// Per-order coefficients (`coefs[m][k]`) reordered by pair, orders
/// contiguous: `out[k * orders + m]`.
fn by_pair(coefs: &[Vec<f64>], pairs: usize) -> Vec<f64> {
    let orders = coefs.len();
    let mut out = vec![0.0; pairs * orders];
    for (m, c) in coefs.iter().enumerate() {
        for k in 0..pairs {
            out[k * orders + m] = c[k];
        }
    }
    out
}
