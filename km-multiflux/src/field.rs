//! The radiance field inside a stack at any depth, for one Fourier order
//! (seed eq. 19 generalised to the stack, eq. 19' of `docs/multiflux.md`).

use faer::Mat;
use km_core::{MonoScene, Substrate};

use crate::MultifluxError;
use crate::engine::{ExtraSetup, Extras, OrderPieces};
use crate::options::MultifluxOptions;
use crate::solver::{Scaled, media_grid, resolve_streams, scale_layers};

/// The radiance field at one depth of a stack, for one Fourier order.
#[derive(Debug, Clone, PartialEq)]
pub struct InternalField {
    /// Refractive index of the medium at that depth.
    pub n: f64,
    /// Node cosines `mu > 0` of that medium.
    pub mu: Vec<f64>,
    /// Node weights (`integral_0^1 dmu`).
    pub w: Vec<f64>,
    /// Down-going radiance at the nodes (Fourier order `m`, per unit incident irradiance).
    pub down: Vec<f64>,
    /// Up-going radiance at the nodes.
    pub up: Vec<f64>,
    /// Irradiance on a horizontal plane of the down-going collimated beam
    /// (delta-M scaled: the forward peak travels with it); 0 for diffuse light.
    pub beam_down: f64,
    /// The same for the beam reflected by interfaces below, going up.
    pub beam_up: f64,
}

impl InternalField {
    /// Net downward flux `2 pi sum w mu (down - up) + beam_down - beam_up` (order 0).
    pub fn net_flux(&self) -> f64 {
        let diffuse: f64 =
            (0..self.mu.len()).map(|i| self.w[i] * self.mu[i] * (self.down[i] - self.up[i])).sum();
        2.0 * std::f64::consts::PI * diffuse + self.beam_down - self.beam_up
    }
}

/// The radiance field `I(z, mu)` at geometric depth `z` (length units from
/// the top of the first layer, inside the stack) for Fourier order `m`
/// (`m = 0`: the azimuthal mean), at the nodes of the medium there (seed 000
/// eq. 19 generalised to the stack). The stack is cut at `z` into the part
/// above and the part below (each layer piece is a layer of its own optical
/// thickness); with their operators `A` and `B`,
/// `d = (I - A.r_bottom B.r_top)^-1 A.t_down a` and `u = B.r_top d` (eq. 19').
///
/// # Errors
/// A depth outside the stack ([`MultifluxError::Option`]), and those of [`crate::solve`].
pub fn internal_field(
    scene: &MonoScene,
    opts: &MultifluxOptions,
    z: f64,
    m: usize,
) -> Result<InternalField, MultifluxError> {
    resolve_streams(scene, opts)?;
    let total: f64 = scene.layers().iter().map(|l| l.thickness()).sum();
    if !(z >= 0.0 && z <= total && z.is_finite()) {
        return Err(MultifluxError::Option {
            name: "z",
            value: z,
            reason: "depth must lie in the stack",
        });
    }
    let (i_cut, dz) = locate(scene, z);
    field_in_layer(scene, opts, i_cut, dz, m)
}

/// The layer holding depth `z` (the upper one at an interface) and the depth
/// below its top.
fn locate(scene: &MonoScene, z: f64) -> (usize, f64) {
    let (mut i_cut, mut z_top) = (0, 0.0);
    for (i, l) in scene.layers().iter().enumerate() {
        i_cut = i;
        if z <= z_top + l.thickness() {
            break;
        }
        z_top += l.thickness();
    }
    (i_cut, (z - z_top).max(0.0))
}

/// [`internal_field`] at depth `dz` below the top of layer `i_cut` (inside
/// it: `0 <= dz <=` its thickness, not checked), so that either side of an
/// interface can be asked for.
///
/// # Errors
/// Those of [`internal_field`].
pub(crate) fn field_in_layer(
    scene: &MonoScene,
    opts: &MultifluxOptions,
    i_cut: usize,
    dz: f64,
    m: usize,
) -> Result<InternalField, MultifluxError> {
    let streams = resolve_streams(scene, opts)?;
    let n0 = scene.ambient_n();
    let (n_sub, grid) = media_grid(scene, streams);
    let layers = scale_layers(scene, opts, streams);
    // The beam alone as extra direction (no probe, so no marker).
    let beams: Vec<f64> = scene.beam_invariant().into_iter().collect();
    let setup =
        ExtraSetup { n0, n_sub, layers: &layers, tms_layers: &[], corr: &[], secondary: false };
    let extras = Extras::new(&beams, &[], &setup);
    let (above, below) = split_at_depth(scene, &layers, i_cut, dz);
    let lc = &scene.layers()[i_cut];
    let n_cut = lc.n();
    let scene_above = scene.with_substrate(Substrate::Transparent { n: n_cut })?;
    let scene_below = scene.with_ambient_n(n_cut)?;
    let pieces = OrderPieces {
        grid: &grid,
        extras: &extras,
        corr: &[],
        count: extras.ex.len(),
        m,
        orders: m + 1,
        all_effects: opts.all_effects,
    };
    let a_ops = pieces.stack(&scene_above, &above, Some(n_cut), opts.neumann_order)?.core;
    let b_ops = pieces.stack(&scene_below, &below, n_sub, opts.neumann_order)?.core;

    // Input at the top.
    let nodes0 = grid.medium(n0);
    let na0 = nodes0.mu.len();
    let mut a = Mat::<f64>::zeros(na0 + beams.len(), 1);
    if beams.is_empty() {
        if m == 0 {
            for i in 0..na0 {
                a[(i, 0)] = 1.0 / std::f64::consts::PI;
            }
        }
    } else {
        a[(na0, 0)] = 1.0;
    }
    // Eq. 19': the streams at the cut.
    let dim = b_ops.r_top.ncols();
    let mut x = Mat::<f64>::identity(dim, dim);
    x -= &a_ops.r_bottom * &b_ops.r_top;
    use faer::linalg::solvers::Solve;
    let d = x.partial_piv_lu().solve(&a_ops.t_down * &a);
    let u = &b_ops.r_top * &d;
    let nodes = grid.medium(n_cut);
    let nn = nodes.mu.len();
    let out = InternalField {
        n: n_cut,
        down: (0..nn).map(|i| d[(i, 0)]).collect(),
        up: (0..nn).map(|i| u[(i, 0)]).collect(),
        beam_down: if beams.is_empty() { 0.0 } else { d[(nn, 0)] },
        beam_up: if beams.is_empty() { 0.0 } else { u[(nn, 0)] },
        mu: nodes.mu,
        w: nodes.w,
    };
    let finite = out.down.iter().chain(&out.up).all(|v| v.is_finite());
    if !finite {
        return Err(MultifluxError::Numerical {
            what: "internal_field",
            detail: format!("layer {i_cut}, {dz} below its top"),
        });
    }
    Ok(out)
}

/// The stack cut at depth `dz` below the top of layer `i_cut`: the scaled
/// layers above the cut (that layer's upper piece last) and below it (its
/// lower piece first), each piece with its share of the optical thickness
/// (scaled and true).
fn split_at_depth(
    scene: &MonoScene,
    layers: &[Scaled],
    i_cut: usize,
    dz: f64,
) -> (Vec<Scaled>, Vec<Scaled>) {
    let lc = &scene.layers()[i_cut];
    let frac_tau = |tau: f64| if lc.thickness() > 0.0 { tau / lc.thickness() } else { 0.0 };
    let mut upper = layers[i_cut].clone();
    let mut lower = layers[i_cut].clone();
    // Piece above the cut: optical thickness (z - z_top) sigma_t (scaled and true).
    let (per_len, per_len_true) = if lc.thickness().is_infinite() {
        (lc.sigma_t() * layers[i_cut].factor, lc.sigma_t())
    } else {
        (frac_tau(layers[i_cut].tau), frac_tau(layers[i_cut].tau_true))
    };
    upper.tau = per_len * dz;
    upper.tau_true = per_len_true * dz;
    let rest = lc.thickness() - dz;
    lower.tau = if rest.is_infinite() { f64::INFINITY } else { per_len * rest };
    lower.tau_true = if rest.is_infinite() { f64::INFINITY } else { per_len_true * rest };
    let mut above: Vec<Scaled> = layers[..i_cut].to_vec();
    above.push(upper);
    let mut below = vec![lower];
    below.extend_from_slice(&layers[i_cut + 1..]);
    (above, below)
}
