//! Depth-resolved output of the multi-flux solver: the fluence rate
//! `phi(z)`, the absorbed power density `A(z)` and the net flux `F(z)` at
//! any depth, and the absorptance of every layer (`docs/field.md`, eq.
//! D1–D6).
//!
//! The streams entering each layer come from one top-down and one
//! bottom-up pass of the adding with the partial stacks kept at every layer
//! face (the stack cut there, eq. 13' of `docs/multiflux.md`); inside a layer
//! the field is the layer's own eigen-solution fixed by those streams (eq.
//! 13 of `docs/multiflux.md`), so a depth costs `O(N)` once the layers are
//! prepared. Delta-M: the scaled direct beam `F e^{-tau*/mu_b}` carries the
//! truncated forward peak with it, and its fluence `F e^{-tau*/mu_b}/mu_b`
//! is added to the diffuse part (eq. D2), so that `phi` is the whole
//! fluence that Monte Carlo tallies.

use std::f64::consts::PI;

use km_core::MonoScene;

use crate::MultifluxError;
use crate::correction::phi;
use crate::field::{LayerFace, layer_faces};
use crate::options::MultifluxOptions;
use crate::prepare::{resolve_streams, scale_layers};
use crate::quadrature::mu_of_invariant;
use crate::slab::{FieldModes, FieldWeights, SlabSolution};

/// `phi`, `A` and `F` at requested depths of one channel, per unit incident
/// irradiance on the surface (per unit incident power).
#[derive(Debug, Clone, PartialEq)]
pub struct DepthProfile {
    /// The depths, in the scene's length unit from the top surface.
    pub depths: Vec<f64>,
    /// Fluence rate `phi(z)` (4 pi times the mean radiance; dimensionless).
    pub fluence: Vec<f64>,
    /// Absorbed power per unit depth `A(z) = sigma_a phi(z)` (1/length).
    pub absorbed: Vec<f64>,
    /// Net downward flux `F(z)` (dimensionless).
    pub net_flux: Vec<f64>,
}

/// One layer's field, ready to be evaluated at any depth.
struct LayerField {
    sol: SlabSolution,
    /// Homogeneous part and down-going beam.
    modes: FieldModes,
    fw: FieldWeights,
    /// The beam reflected from below, going up (its own zero-input field,
    /// mirrored), with its irradiance at the layer's bottom.
    up: Option<(FieldModes, FieldWeights, f64)>,
    /// Beam cosine in this layer and its irradiance at the top.
    beam: Option<(f64, f64)>,
    /// Scaled optical thickness per unit length.
    per_len: f64,
    sigma_a: f64,
    /// Scaled optical thickness.
    tau0: f64,
    z_top: f64,
    thickness: f64,
}

/// The multi-flux field of one channel (order 0), prepared once for every
/// layer: [`DepthField::profile`] then evaluates any number of depths.
pub struct DepthField {
    layers: Vec<Option<LayerField>>,
    total: f64,
}

impl DepthField {
    /// Solve the stack of `scene` and prepare every layer of positive
    /// thickness.
    ///
    /// # Errors
    /// Those of [`crate::internal_field`] and of the layers' eigen-solves.
    ///
    /// ```
    /// use km_multiflux::{MultifluxOptions, depth::DepthField};
    /// let s = km_core::Scene::from_toml_str(
    ///     "[[layer]]\nsigma_a = 1.0\nsigma_s = 0.0\nthickness = 2.0\n").unwrap();
    /// let f = DepthField::new(&s.channels()[0], &MultifluxOptions::default()).unwrap();
    /// let p = f.profile(&[0.5, 1.0]).unwrap();
    /// // No scattering, normal incidence: phi = F = exp(-z).
    /// assert!((p.fluence[1] - (-1.0f64).exp()).abs() < 1e-12);
    /// ```
    pub fn new(scene: &MonoScene, opts: &MultifluxOptions) -> Result<Self, MultifluxError> {
        let streams = resolve_streams(scene, opts)?;
        let scaled = scale_layers(scene, opts, streams);
        let faces = layer_faces(scene, opts, streams, &scaled)?;
        let mut layers = Vec::with_capacity(scaled.len());
        let mut z_top = 0.0;
        for ((l, sl), face) in scene.layers().iter().zip(&scaled).zip(faces) {
            let thickness = l.thickness();
            let Some(LayerFace { top, bottom, sol }) = face else {
                layers.push(None);
                z_top += thickness;
                continue;
            };
            let half = thickness.is_infinite();
            let mu_b = scene.beam_invariant().and_then(|s| mu_of_invariant(s, l.n()));
            let beam = mu_b.map(|m| (m, top.beam_down));
            let zero = vec![0.0; top.mu.len()];
            let up_in = bottom.as_ref().map_or(zero.clone(), |b| b.up.clone());
            let modes = sol.field_modes(&top.down, &up_in, beam);
            let fw = sol.field_weights(&modes);
            let up = match (mu_b, &bottom) {
                (Some(m), Some(b)) if b.beam_up != 0.0 => {
                    let um = sol.field_modes(&zero, &zero, Some((m, b.beam_up)));
                    let uw = sol.field_weights(&um);
                    Some((um, uw, b.beam_up))
                }
                _ => None,
            };
            let per_len = if half { l.sigma_t() * sl.factor } else { sl.tau / thickness };
            layers.push(Some(LayerField {
                sol,
                modes,
                fw,
                up,
                beam,
                per_len,
                sigma_a: l.sigma_a(),
                tau0: sl.tau,
                z_top,
                thickness,
            }));
            z_top += thickness;
        }
        Ok(Self { layers, total: z_top })
    }

    /// `(phi, A, F)` at depth `z` (inside the stack; at an interface, the
    /// values of the layer above it).
    fn at(&self, z: f64) -> Option<(f64, f64, f64)> {
        let l = self.layers.iter().flatten().find(|l| z <= l.z_top + l.thickness)?;
        let tau = ((z - l.z_top).max(0.0) * l.per_len).min(l.sol_tau());
        let (sum, diff) = match &l.up {
            None => l.sol.field_moments(&l.modes, &l.fw, tau),
            Some((um, uw, _)) => l.sol.field_moments_mirrored((&l.modes, &l.fw), (um, uw), tau),
        };
        let (mut coll, mut net) = (0.0, 0.0);
        if let Some((mu_b, f)) = l.beam {
            let e = f * (-tau / mu_b).exp();
            coll += e / mu_b;
            net += e;
        }
        if let Some((_, _, fu)) = &l.up {
            let mu_b = l.beam.map_or(1.0, |b| b.0);
            let t = l.sol_tau() - tau;
            let e = fu * (-t / mu_b).exp();
            coll += e / mu_b;
            net -= e;
        }
        let phi = 2.0 * PI * sum + coll;
        let a = if l.sigma_a == 0.0 { 0.0 } else { l.sigma_a * phi };
        Some((phi, a, 2.0 * PI * diff + net))
    }

    /// `phi`, `A` and `F` at `depths` (each finite, in `[0, D]` with `D` the
    /// stack's thickness; any depth in a half-space).
    ///
    /// # Errors
    /// A depth outside the stack ([`MultifluxError::Option`]).
    pub fn profile(&self, depths: &[f64]) -> Result<DepthProfile, MultifluxError> {
        let mut p = DepthProfile {
            depths: depths.to_vec(),
            fluence: Vec::with_capacity(depths.len()),
            absorbed: Vec::with_capacity(depths.len()),
            net_flux: Vec::with_capacity(depths.len()),
        };
        for &z in depths {
            let inside = z.is_finite() && z >= 0.0 && z <= self.total;
            let v = if inside { self.at(z) } else { None };
            let Some((f, a, n)) = v else {
                return Err(MultifluxError::Option {
                    name: "depths",
                    value: z,
                    reason: "every depth must be finite and lie in the stack",
                });
            };
            p.fluence.push(f);
            p.absorbed.push(a);
            p.net_flux.push(n);
        }
        Ok(p)
    }

    /// The power absorbed in each layer per unit incident power,
    /// `sigma_a integral phi dz` over the layer, integrated exactly term by
    /// term (eq. D5); 0 for a layer of zero thickness or no absorption.
    pub fn layer_absorptance(&self) -> Vec<f64> {
        self.layers
            .iter()
            .map(|l| {
                let Some(l) = l else { return 0.0 };
                if l.sigma_a == 0.0 {
                    return 0.0;
                }
                let t0 = l.sol_tau();
                let mut tot = 2.0 * PI * l.sol.field_moment_integral(&l.modes, &l.fw);
                if let Some((mu_b, f)) = l.beam {
                    tot += f * phi(1.0 / mu_b, t0) / mu_b;
                }
                if let (Some((um, uw, fu)), Some((mu_b, _))) = (&l.up, l.beam) {
                    tot += 2.0 * PI * l.sol.field_moment_integral(um, uw);
                    tot += fu * phi(1.0 / mu_b, t0) / mu_b;
                }
                l.sigma_a * tot / l.per_len
            })
            .collect()
    }

    /// The stack's thickness (infinite over a half-space).
    pub fn thickness(&self) -> f64 {
        self.total
    }
}

impl LayerField {
    fn sol_tau(&self) -> f64 {
        self.tau0
    }
}
