//! Errors of the dipole method: every refusal names the problem and the
//! offending value.

use thiserror::Error;

/// Why the dipole method refuses an input.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum DipoleError {
    /// The dipole is a solution for a half-space; this layer ends.
    #[error(
        "the dipole treats only a semi-infinite layer (a half-space): layer {layer} has finite \
         thickness {thickness}; the multi-flux and Monte Carlo methods treat slabs"
    )]
    FiniteThickness {
        /// 1-based layer index.
        layer: usize,
        /// Its thickness.
        thickness: f64,
    },
    /// The dipole treats one homogeneous half-space, not a stack.
    #[error(
        "the dipole treats a single homogeneous half-space: the scene has {count} layers; \
         the multi-flux and Monte Carlo methods treat stacks"
    )]
    LayerCount {
        /// Number of layers in the scene.
        count: usize,
    },
    /// The dipole's boundary condition is that of a smooth Fresnel face.
    #[error(
        "the dipole takes a smooth top face: layer 1 has roughness {alpha} (its boundary \
         condition and Fresnel transmission are those of a smooth face; docs/rough.md §6); \
         the multi-flux and Monte Carlo methods treat rough faces"
    )]
    RoughFace {
        /// The roughness of the top face.
        alpha: f64,
    },
    /// Without scattering there is no diffusion (reduced albedo 0).
    #[error(
        "the diffusion approximation needs scattering: sigma_s = {sigma_s} (layer {layer}, \
         channel {channel}); a clear absorbing half-space reflects only its Fresnel part"
    )]
    NoScattering {
        /// 1-based layer index.
        layer: usize,
        /// 0-based spectral channel.
        channel: usize,
        /// The scattering coefficient found.
        sigma_s: f64,
    },
    /// A parameter outside its domain.
    #[error("invalid {name} = {value}: {reason}")]
    Invalid {
        /// Parameter name.
        name: &'static str,
        /// The offending value.
        value: f64,
        /// The domain.
        reason: &'static str,
    },
    /// The Egan–Hilgeman fit is used outside the range it was fitted on.
    #[error(
        "the Egan-Hilgeman fit of F_dr is defined for eta = n_inside / n_outside >= 1, got eta = \
         {eta}; use the exact F_dr (FdrModel::Exact)"
    )]
    FitOutOfRange {
        /// The relative index.
        eta: f64,
    },
    /// A preset name that is not in the table.
    #[error("unknown preset \"{name}\" (known: {known})")]
    UnknownPreset {
        /// The name asked for.
        name: String,
        /// The known names, comma separated.
        known: String,
    },
    /// The scene itself is invalid (from `km-core` validation).
    #[error(transparent)]
    Scene(#[from] km_core::CoreError),
}

impl DipoleError {
    pub(crate) fn invalid(name: &'static str, value: f64, reason: &'static str) -> Self {
        DipoleError::Invalid { name, value, reason }
    }
}
