//! The radiance field inside a stack at any depth, for one Fourier order
//! (seed eq. 19 generalised to the stack, eq. 19' of `docs/multiflux.md`).

use faer::Mat;
use km_core::{MonoScene, Substrate};

use crate::MultifluxError;
use crate::adding::probed::Augmented;
use crate::engine::{ExtraSetup, Extras, OrderPieces};
use crate::options::MultifluxOptions;
use crate::prepare::{media_grid, resolve_streams, scale_layers};
use crate::quadrature::AngularGrid;
use crate::slab::{SlabOrder, SlabSolution};
use crate::stack::Scaled;

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
pub(crate) fn locate(scene: &MonoScene, z: f64) -> (usize, f64) {
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
    let a_ops = pieces.stack(&scene_above, &above, Some(n_cut), opts.neumann_order)?;
    let b_ops = pieces.stack(&scene_below, &below, n_sub, opts.neumann_order)?;
    let a = input(scene, &grid, m);
    let out = streams_at_cut(Some(&a_ops), Some(&b_ops), &a, &grid, n_cut, beams.len());
    out.ok_or_else(|| MultifluxError::Numerical {
        what: "internal_field",
        detail: format!("layer {i_cut}, {dz} below its top"),
    })
}

/// The light entering the stack's top for Fourier order `m`: the unit beam
/// (its own column after the ambient medium's nodes), or diffuse light of
/// unit irradiance (radiance `1/pi` at every node, order 0 only).
pub(crate) fn input(scene: &MonoScene, grid: &AngularGrid, m: usize) -> Mat<f64> {
    let na0 = grid.shared(scene.ambient_n()).mu.len();
    let beams = usize::from(scene.beam_invariant().is_some());
    let mut a = Mat::<f64>::zeros(na0 + beams, 1);
    if beams == 0 {
        if m == 0 {
            for i in 0..na0 {
                a[(i, 0)] = 1.0 / std::f64::consts::PI;
            }
        }
    } else {
        a[(na0, 0)] = 1.0;
    }
    a
}

/// The streams at a cut of the stack inside a medium of index `n_cut`
/// (eq. 19'): `d = (I - A.r_bottom B.r_top)^-1 A.t_down a`, `u = B.r_top d`,
/// for the operators `A` of the stack above the cut (`None`: nothing above,
/// `d = a`) and `B` below it (`None`: nothing below, `u = 0`); `None` if
/// they are not finite.
fn streams_at_cut(
    above: Option<&Augmented>,
    below: Option<&Augmented>,
    a: &Mat<f64>,
    grid: &AngularGrid,
    n_cut: f64,
    beams: usize,
) -> Option<InternalField> {
    use faer::linalg::solvers::Solve;
    let d = match above {
        None => a.clone(),
        Some(ops) => {
            let ta = &ops.core.t_down * a;
            match below {
                None => ta,
                Some(b) => {
                    let dim = b.core.r_top.ncols();
                    let mut x = Mat::<f64>::identity(dim, dim);
                    x -= &ops.core.r_bottom * &b.core.r_top;
                    x.partial_piv_lu().solve(ta)
                }
            }
        }
    };
    let u = match below {
        None => Mat::<f64>::zeros(d.nrows(), 1),
        Some(b) => &b.core.r_top * &d,
    };
    let nodes = grid.medium(n_cut);
    let nn = nodes.mu.len();
    let out = InternalField {
        n: n_cut,
        down: (0..nn).map(|i| d[(i, 0)]).collect(),
        up: (0..nn).map(|i| u[(i, 0)]).collect(),
        beam_down: if beams == 0 { 0.0 } else { d[(nn, 0)] },
        beam_up: if beams == 0 { 0.0 } else { u[(nn, 0)] },
        mu: nodes.mu,
        w: nodes.w,
    };
    let finite = out.down.iter().chain(&out.up).all(|v| v.is_finite());
    finite.then_some(out)
}

/// One layer of positive thickness for the field inside it: the fields at
/// both faces, inside the layer, and the layer's eigen-solution (order 0).
pub(crate) struct LayerFace {
    pub(crate) top: InternalField,
    /// `None` in a half-space.
    pub(crate) bottom: Option<InternalField>,
    pub(crate) sol: SlabSolution,
}

/// [`LayerFace`] of every layer of positive thickness (`None` for the
/// others), from one top-down and one bottom-up pass of the adding
/// ([`crate::stack::stack_cuts`]): the same numbers as [`field_in_layer`]
/// at `dz = 0` and at the layer's thickness, without cutting the stack anew
/// at each face; each layer's eigen-solution serves both its operators and
/// the field. `layers` are the scene's layers scaled for `streams`.
///
/// # Errors
/// Those of [`internal_field`].
pub(crate) fn layer_faces(
    scene: &MonoScene,
    opts: &MultifluxOptions,
    streams: usize,
    layers: &[Scaled],
) -> Result<Vec<Option<LayerFace>>, MultifluxError> {
    let (n_sub, grid) = media_grid(scene, streams);
    let beams: Vec<f64> = scene.beam_invariant().into_iter().collect();
    let setup = ExtraSetup {
        n0: scene.ambient_n(),
        n_sub,
        layers,
        tms_layers: &[],
        corr: &[],
        secondary: false,
    };
    let extras = Extras::new(&beams, &[], &setup);
    let pieces = OrderPieces {
        grid: &grid,
        extras: &extras,
        corr: &[],
        count: extras.ex.len(),
        m: 0,
        orders: 1,
        all_effects: opts.all_effects,
    };
    // Each layer of positive thickness: its operators and eigen-solution
    // (solved here also where the operators take the Beer–Lambert shortcut).
    let mut built = Vec::with_capacity(layers.len());
    let mut sols = Vec::with_capacity(layers.len());
    for (i, (l, sl)) in scene.layers().iter().zip(layers).enumerate() {
        let thickness = l.thickness();
        if thickness <= 0.0 || thickness.is_nan() {
            built.push(None);
            sols.push(None);
            continue;
        }
        let (aug, sol) = pieces.layer_kept(i, sl)?;
        let sol = match sol {
            Some(s) => s,
            None => {
                let nodes = grid.medium(sl.n);
                let omega = if sl.omega.is_finite() { sl.omega } else { 0.0 };
                let p = SlabOrder { tau: sl.tau, omega, chi: &sl.chi, m: 0 };
                SlabSolution::new(&nodes.mu, &nodes.w, &p)?
            }
        };
        built.push(Some(aug));
        sols.push(Some(sol));
    }
    let cuts = pieces.cuts(scene, layers, n_sub, opts.neumann_order, built)?;
    let a = input(scene, &grid, 0);
    let fail = |i: usize, dz: f64| MultifluxError::Numerical {
        what: "internal_field",
        detail: format!("layer {i}, {dz} below its top"),
    };
    let mut out = Vec::with_capacity(cuts.len());
    for (i, ((c, l), sol)) in cuts.iter().zip(scene.layers()).zip(sols).enumerate() {
        let thickness = l.thickness();
        let Some(sol) = sol else {
            out.push(None);
            continue;
        };
        let f = |above: &Option<Augmented>, below: &Option<Augmented>| {
            streams_at_cut(above.as_ref(), below.as_ref(), &a, &grid, l.n(), beams.len())
        };
        let top = f(&c.above_top, &c.below_top).ok_or_else(|| fail(i, 0.0))?;
        let bottom = if thickness.is_infinite() {
            None
        } else {
            Some(f(&c.above_bottom, &c.below_bottom).ok_or_else(|| fail(i, thickness))?)
        };
        out.push(Some(LayerFace { top, bottom, sol }));
    }
    Ok(out)
}

/// The stack cut at depth `dz` below the top of layer `i_cut`: the scaled
/// layers above the cut (that layer's upper piece last) and below it (its
/// lower piece first), each piece with its share of the optical thickness
/// (scaled and true).
pub(crate) fn split_at_depth(
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The faces' fields from the two passes of the adding equal those of
    /// the stack cut and added anew at each face (eq. 19', an independent
    /// grouping of the same addings: adding is associative, so only
    /// rounding separates them: measured 1.7e-16 of the largest stream,
    /// bound 1e-12): refracting
    /// layers at oblique incidence with a zero-thickness layer between,
    /// diffuse light, a Lambertian floor, a rough face over a conductor, a
    /// half-space, all effects.
    #[test]
    fn face_fields_equal_the_stack_cut_anew() {
        let scenes = [
            "[light]\ntheta_deg = 30.0\n\
             [[layer]]\nsigma_a = 0.2\nsigma_s = 1.0\nthickness = 0.5\ng = 0.6\nn = 1.5\n\
             [[layer]]\nsigma_a = 0.2\nsigma_s = 1.0\nthickness = 0.0\ng = 0.6\nn = 1.6\n\
             [[layer]]\nsigma_a = 0.05\nsigma_s = 2.0\nthickness = 1.0\ng = 0.2\nn = 1.3\n\
             [substrate]\nkind = \"transparent\"\nn = 1.2\n",
            "[light]\nkind = \"diffuse\"\n[[layer]]\nsigma_a = 0.5\nsigma_s = 4.0\n\
             thickness = 0.3\nn = 1.0\n[[layer]]\nsigma_a = 0.1\nsigma_s = 20.0\n\
             thickness = 0.4\ng = 0.95\nn = 1.4\n",
            "[light]\ntheta_deg = 50.0\n[[layer]]\nsigma_a = 0.3\nsigma_s = 3.0\nthickness = 1.0\n\
             g = 0.7\nn = 1.33\n[substrate]\nkind = \"lambertian\"\nalbedo = 0.6\n",
            "[light]\ntheta_deg = 30.0\n[[layer]]\ntau = 1.0\nalbedo = 0.9\ng = 0.5\nn = 1.5\n\
             roughness = 0.3\n[substrate]\nkind = \"conductor\"\nn = 0.35\nk = 2.7\n\
             roughness = 0.2\n",
            "[[layer]]\nsigma_a = 0.4\nsigma_s = 4.0\nthickness = \"inf\"\ng = 0.8\nn = 1.4\n",
        ];
        for (k, text) in scenes.iter().enumerate() {
            let scene = km_core::Scene::from_toml_str(text).unwrap();
            let mono = &scene.channels()[0];
            for all_effects in [false, true] {
                let opts = MultifluxOptions { streams: Some(8), all_effects, ..Default::default() };
                let layers = scale_layers(mono, &opts, 8);
                let faces = layer_faces(mono, &opts, 8, &layers).unwrap();
                for (i, face) in faces.iter().enumerate() {
                    let th = mono.layers()[i].thickness();
                    let Some(LayerFace { top, bottom, .. }) = face else {
                        assert!(th == 0.0, "scene {k}: layer {i} skipped");
                        continue;
                    };
                    let mut pairs = vec![(top, field_in_layer(mono, &opts, i, 0.0, 0).unwrap())];
                    if let Some(b) = bottom {
                        pairs.push((b, field_in_layer(mono, &opts, i, th, 0).unwrap()));
                    }
                    for (new, old) in pairs {
                        let all = |f: &InternalField| {
                            let mut v = f.down.clone();
                            v.extend(&f.up);
                            v.extend([f.beam_down, f.beam_up]);
                            v
                        };
                        let (a, b) = (all(new), all(&old));
                        assert_eq!(a.len(), b.len());
                        let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                        let diff = a.iter().zip(&b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
                        assert!(
                            diff <= 1e-12 * scale,
                            "scene {k}, layer {i}, all effects {all_effects}: {diff:e} of {scale}"
                        );
                    }
                }
            }
        }
    }
}
