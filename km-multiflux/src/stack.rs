//! A stack's operators for one Fourier order: its interfaces and layers added
//! top to bottom (seed eq. 14, or the truncated Neumann series of eq. 21),
//! closed by its substrate (seed §3.4); and the scalar pass of the delta
//! parts. The one stack builder of the Fourier–Gauss mode: the angular
//! engine ([`crate::engine`]) gives it its pieces for every request (solve,
//! BSDF table, internal field).

use km_core::microfacet::Microfacet;
use km_core::{MonoScene, Substrate};

use crate::MultifluxError;
use crate::adding::probed::{Augmented, add, add_truncated};
use crate::quadrature::mu_of_invariant;
use crate::slab::Tms;

/// Add `next` below `acc` (exact adding, seed eq. 14, or its Neumann series
/// truncated after `neumann` round trips, eq. 21); `acc = None` is the empty stack.
pub(crate) fn combine(
    acc: Option<Augmented>,
    next: Augmented,
    neumann: Option<usize>,
) -> Result<Augmented, MultifluxError> {
    match acc {
        None => Ok(next),
        Some(a) => match neumann {
            None => add(&a, &next),
            Some(k) => add_truncated(&a, &next, k),
        },
    }
}

/// How to build the pieces of a stack for [`add_stack`].
pub(crate) struct StackPieces<'a> {
    /// The interface from index `n_a` above to `n_b` below: smooth (Fresnel)
    /// or rough (`Some`: [`crate::rough`]).
    pub(crate) interface:
        &'a dyn Fn(f64, f64, Option<Microfacet>) -> Result<Augmented, MultifluxError>,
    /// A conductor floor `n + i k` under index `n_above` (`n_above, n, k,
    /// roughness`; nothing below it).
    pub(crate) conductor:
        &'a dyn Fn(f64, f64, f64, Option<Microfacet>) -> Result<Augmented, MultifluxError>,
    /// The operators of layer `i` (delta-M scaled).
    pub(crate) layer: &'a dyn Fn(usize, &Scaled) -> Result<Augmented, MultifluxError>,
    /// A Lambertian floor of `albedo` under index `n` (nothing below it).
    pub(crate) lambertian: &'a dyn Fn(f64, f64) -> Augmented,
}

/// The operators of the whole stack for one Fourier order: interfaces (only
/// between different indices, the plan's `interface` rule, unless
/// `all_effects`) and layers added top to bottom, then closed by the
/// substrate ([`close_stack`]).
///
/// # Errors
/// Those of the pieces and of the adding; an empty stack.
pub(crate) fn add_stack(
    scene: &MonoScene,
    layers: &[Scaled],
    n_sub: Option<f64>,
    neumann: Option<usize>,
    all_effects: bool,
    pieces: &StackPieces<'_>,
) -> Result<Augmented, MultifluxError> {
    let mut acc: Option<Augmented> = None;
    let mut n_above = scene.ambient_n();
    for (i, l) in layers.iter().enumerate() {
        // The plan's `interface` rule: equal indices are no interface (the
        // Fresnel operator would be the identity); built anyway with all effects.
        if l.n != n_above || all_effects {
            let rough = l.rough.filter(|_| l.n != n_above);
            acc = Some(combine(acc, (pieces.interface)(n_above, l.n, rough)?, neumann)?);
        }
        acc = Some(combine(acc, (pieces.layer)(i, l)?, neumann)?);
        n_above = l.n;
    }
    let half_space = layers.last().is_some_and(|l| l.tau.is_infinite());
    let close = Closing { half_space, n_above, n_sub, all_effects, neumann };
    close_stack(scene, acc, &close, pieces)
}

/// How a stack of layer operators ends (see [`close_stack`]).
pub(crate) struct Closing {
    /// The last layer is a half-space: nothing lies below it.
    pub(crate) half_space: bool,
    /// Refractive index of the last layer.
    pub(crate) n_above: f64,
    /// Index of a clear substrate (`None`: that of the last layer).
    pub(crate) n_sub: Option<f64>,
    /// Build the substrate's interface even between equal indices.
    pub(crate) all_effects: bool,
    /// Truncated adding (seed eq. 21), or exact.
    pub(crate) neumann: Option<usize>,
}

/// Close the operators `acc` of a stack's layers: refuse an empty stack, stop
/// at a half-space, then add the substrate (seed §3.4): the Fresnel interface
/// into a clear half-space of another index, or the Lambertian floor
/// `lambertian(n, albedo)`, or nothing for a black one.
pub(crate) fn close_stack(
    scene: &MonoScene,
    acc: Option<Augmented>,
    close: &Closing,
    pieces: &StackPieces<'_>,
) -> Result<Augmented, MultifluxError> {
    let Some(mut acc) = acc else {
        return Err(MultifluxError::Scene(km_core::CoreError::scene(
            "layer",
            None,
            "the stack has no layer",
        )));
    };
    if close.half_space {
        return Ok(acc);
    }
    if let Some(floor) = closing_piece(scene, close, pieces)? {
        acc = combine(Some(acc), floor, close.neumann)?;
    }
    Ok(acc)
}

/// The piece that closes a stack of layers that is not a half-space (seed
/// §3.4): the Fresnel interface into a clear half-space of another index,
/// or the Lambertian floor `lambertian(n, albedo)`, or the conductor floor;
/// `None` for a black substrate or a clear one of the last layer's index.
fn closing_piece(
    scene: &MonoScene,
    close: &Closing,
    pieces: &StackPieces<'_>,
) -> Result<Option<Augmented>, MultifluxError> {
    let n_above = close.n_above;
    Ok(match scene.substrate() {
        Substrate::Transparent { .. } => {
            let ns = close.n_sub.unwrap_or(n_above);
            if ns != n_above || close.all_effects {
                let rough = scene.substrate_roughness().filter(|_| ns != n_above);
                Some((pieces.interface)(n_above, ns, rough)?)
            } else {
                None
            }
        }
        Substrate::Lambertian { albedo } => Some((pieces.lambertian)(n_above, albedo)),
        Substrate::Black => None,
        Substrate::Conductor { n, k } => {
            Some((pieces.conductor)(n_above, n, k, scene.substrate_roughness())?)
        }
    })
}

/// The stack cut at both faces of one layer, inside the layer's medium:
/// the operators of everything above each face (the interface on top of the
/// layer included in `above_top`) and of everything below it (the substrate
/// included), `None` where nothing lies on that side.
pub(crate) struct LayerCuts {
    pub(crate) above_top: Option<Augmented>,
    pub(crate) below_top: Option<Augmented>,
    pub(crate) above_bottom: Option<Augmented>,
    pub(crate) below_bottom: Option<Augmented>,
}

/// [`LayerCuts`] of every layer from one top-down and one bottom-up pass of
/// the adding over the pieces of [`add_stack`] (each piece built once), the
/// partial sums kept at every face: `2 P` addings for `P` pieces, where
/// cutting the stack at each face anew costs `O(P)` addings per face.
///
/// # Errors
/// Those of the pieces and of the adding; an empty stack.
pub(crate) fn stack_cuts(
    scene: &MonoScene,
    layers: &[Scaled],
    n_sub: Option<f64>,
    neumann: Option<usize>,
    all_effects: bool,
    pieces: &StackPieces<'_>,
) -> Result<Vec<LayerCuts>, MultifluxError> {
    // The pieces top to bottom, each with the layer it is (`Some(i)`) or
    // `None` for an interface or the closing floor.
    let mut seq: Vec<(Option<usize>, Augmented)> = Vec::with_capacity(2 * layers.len() + 1);
    let mut n_above = scene.ambient_n();
    for (i, l) in layers.iter().enumerate() {
        if l.n != n_above || all_effects {
            let rough = l.rough.filter(|_| l.n != n_above);
            seq.push((None, (pieces.interface)(n_above, l.n, rough)?));
        }
        seq.push((Some(i), (pieces.layer)(i, l)?));
        n_above = l.n;
    }
    let half_space = layers.last().is_some_and(|l| l.tau.is_infinite());
    let close = Closing { half_space, n_above, n_sub, all_effects, neumann };
    if layers.is_empty() {
        // The empty stack's error.
        return close_stack(scene, None, &close, pieces).map(|_| Vec::new());
    }
    if !half_space && let Some(floor) = closing_piece(scene, &close, pieces)? {
        seq.push((None, floor));
    }
    let mut cuts: Vec<LayerCuts> = (0..layers.len())
        .map(|_| LayerCuts {
            above_top: None,
            below_top: None,
            above_bottom: None,
            below_bottom: None,
        })
        .collect();
    let mut acc: Option<Augmented> = None;
    for (tag, piece) in &seq {
        if let Some(i) = *tag {
            cuts[i].above_top.clone_from(&acc);
        }
        acc = Some(combine(acc, piece.clone(), neumann)?);
        if let Some(i) = *tag {
            cuts[i].above_bottom.clone_from(&acc);
        }
    }
    let mut acc: Option<Augmented> = None;
    for (tag, piece) in seq.into_iter().rev() {
        if let Some(i) = tag {
            cuts[i].below_bottom.clone_from(&acc);
        }
        acc = Some(match acc {
            None => piece,
            Some(below) => match neumann {
                None => add(&piece, &below)?,
                Some(k) => add_truncated(&piece, &below, k)?,
            },
        });
        if let Some(i) = tag {
            cuts[i].below_top.clone_from(&acc);
        }
    }
    Ok(cuts)
}

/// Mirror reflectance and unscattered transmittance of a direction of Snell
/// invariant `s` entering from above: a one-direction adding pass with the
/// true optical thicknesses and flux (not radiance) Fresnel factors.
pub(crate) fn delta_parts(
    scene: &MonoScene,
    layers: &[Scaled],
    n_sub: Option<f64>,
    s: f64,
) -> (f64, f64) {
    let iface = |na: f64, nb: f64| -> ScalarOp {
        match (mu_of_invariant(s, na), mu_of_invariant(s, nb)) {
            (Some(a), Some(b)) => {
                let ra = km_core::fresnel::reflectance(a, na, nb);
                let rb = km_core::fresnel::reflectance(b, nb, na);
                (ra, 1.0 - ra, rb, 1.0 - rb)
            }
            (Some(_), None) => (1.0, 0.0, 0.0, 0.0),
            (None, Some(_)) => (0.0, 0.0, 1.0, 0.0),
            (None, None) => (0.0, 0.0, 0.0, 0.0),
        }
    };
    // A rough face has no mirror part and passes no unscattered beam.
    let rough_face: ScalarOp = (0.0, 0.0, 0.0, 0.0);
    let mut acc: ScalarOp = (0.0, 1.0, 0.0, 1.0);
    let mut n_above = scene.ambient_n();
    for l in layers {
        if l.n != n_above {
            acc = star(acc, if l.rough.is_some() { rough_face } else { iface(n_above, l.n) });
        }
        let t = match mu_of_invariant(s, l.n) {
            Some(mu) if l.tau_true.is_finite() => (-l.tau_true / mu).exp(),
            _ => 0.0,
        };
        acc = star(acc, (0.0, t, 0.0, t));
        n_above = l.n;
    }
    let mut transmits = false;
    if let (Substrate::Transparent { .. }, Some(ns)) = (scene.substrate(), n_sub) {
        if ns != n_above {
            let rough = scene.substrate_roughness().is_some();
            acc = star(acc, if rough { rough_face } else { iface(n_above, ns) });
        }
        transmits = true;
    }
    // A smooth conductor floor: its mirror reflection (conductor Fresnel).
    let last_half = layers.last().is_some_and(|l| l.tau_true.is_infinite());
    if let (Substrate::Conductor { n, k }, None, false) =
        (scene.substrate(), scene.substrate_roughness(), last_half)
        && let Some(mu) = mu_of_invariant(s, n_above)
    {
        let r = km_core::microfacet::conductor_reflectance(mu, n_above, n, k);
        acc = star(acc, (r, 0.0, 0.0, 0.0));
    }
    (acc.0, if transmits { acc.1 } else { 0.0 })
}

/// Scalar operators `(r_top, t_down, r_bottom, t_up)` of a delta path.
pub(crate) type ScalarOp = (f64, f64, f64, f64);

/// The star product of two scalar operators (eq. A4 of the adding module
/// with 1 x 1 operators).
pub(crate) fn star((r1, t1, r1p, t1p): ScalarOp, (r2, t2, r2p, t2p): ScalarOp) -> ScalarOp {
    let x = 1.0 - r1p * r2;
    if x == 0.0 {
        // Facing total reflections with nothing between: nothing enters.
        return (r1, 0.0, r2p, 0.0);
    }
    (r1 + t1p * r2 * t1 / x, t2 * t1 / x, r2p + t2 * r1p * t2p / x, t1p * t2p / x)
}

/// One layer after delta-M scaling.
#[derive(Clone)]
pub(crate) struct Scaled {
    pub(crate) tau: f64,
    pub(crate) tau_true: f64,
    pub(crate) omega: f64,
    pub(crate) chi: Vec<f64>,
    pub(crate) n: f64,
    pub(crate) omega_true: f64,
    pub(crate) phase: km_core::phase::Phase,
    /// Delta-M factor on tau, `1 - omega f`.
    pub(crate) factor: f64,
    /// Apply the second-order (IMS) correction at exit directions.
    pub(crate) secondary: bool,
    /// Roughness of the layer's top face (`None`: smooth).
    pub(crate) rough: Option<Microfacet>,
    /// Legendre moments kept by delta-M (eq. 4b: `2N` or `3N/2`).
    pub(crate) n_keep: usize,
}

impl Scaled {
    /// The intensity correction of this layer (TMS and IMS, eq. 5–5h) with
    /// the moments its delta-M scaling kept (same `f`).
    pub(crate) fn correction(&self) -> Tms {
        Tms::new(self.phase.clone(), self.omega_true, self.n_keep, self.secondary)
    }
}
