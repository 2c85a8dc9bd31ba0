//! Every refusal of the library, in its own terms.

use thiserror::Error;

use crate::Method;

/// Why a method cannot treat a scene (the answer of [`crate::Solver::supports`]).
#[derive(Debug, Clone, PartialEq, Error)]
#[error("method {method} cannot treat this scene: {reason}")]
pub struct Unsupported {
    /// The method asked.
    pub method: Method,
    /// Why not.
    pub reason: Reason,
}

/// What in a scene is beyond a method.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum Reason {
    /// The method treats one homogeneous layer only.
    #[error(
        "it treats a single homogeneous half-space and the scene has {layers} layers (the \
         multi-flux and Monte Carlo methods treat stacks)"
    )]
    Stack {
        /// Number of layers of the scene.
        layers: usize,
    },
    /// The method treats semi-infinite layers only.
    #[error(
        "it treats a semi-infinite layer and the layer has a finite optical thickness \
         tau = sigma_t * thickness = {} (the multi-flux and Monte Carlo methods treat slabs)",
        short(*.tau)
    )]
    FiniteLayer {
        /// The layer's optical thickness `tau = (sigma_a + sigma_s) * thickness`.
        tau: f64,
    },
    /// The dipole's radial profile is that of a beam at normal incidence.
    #[error(
        "its Rd(r) is that of a pencil beam at normal incidence and channel {channel} has {light} \
         (Monte Carlo gives Rd(r) at any incidence: --method mc)"
    )]
    NormalIncidenceOnly {
        /// 0-based channel.
        channel: usize,
        /// The channel's light, in words.
        light: String,
    },
    /// The method gives no depth-resolved field.
    #[error(
        "it gives no depth-resolved field phi(z), A(z), F(z) (the multi-flux, two-flux and Monte \
         Carlo methods do: --method multiflux, km or mc)"
    )]
    NoDepthField,
    /// The method gives no radially resolved profile.
    #[error("it gives no radial profile Rd(r) (the dipole and Monte Carlo do)")]
    NoProfile,
    /// The method has values on its own direction nodes only.
    #[error(
        "it gives the totals only (its radiances are on its own direction nodes) and the scene \
         asks for {directions} output directions (the multi-flux and Monte Carlo methods give \
         BRDF/BTDF values there; without [output] directions_deg the totals are computed)"
    )]
    OutputDirections {
        /// Number of output directions asked for.
        directions: usize,
    },
    /// The method needs a medium with extinction for a half-space layer.
    #[error(
        "layer[{layer}] is a clear half-space (sigma_t = 0), which has no direction set of its \
         own: give it as a transparent substrate"
    )]
    ClearHalfSpace {
        /// 1-based layer.
        layer: usize,
    },
    /// The direction set of a denser medium is larger than the solver may hold.
    #[error(
        "channel {channel} needs a set of {directions} downward directions in its densest \
         medium (at most {limit}): use fewer directions"
    )]
    SetTooLarge {
        /// 0-based channel.
        channel: usize,
        /// Downward directions of the largest set.
        directions: usize,
        /// The most allowed.
        limit: usize,
    },
    /// The method needs scattering.
    #[error("diffusion needs scattering and channel {channel} has sigma_s = 0")]
    NoScattering {
        /// 0-based channel.
        channel: usize,
    },
}

/// Every error of [`crate::solve`] and [`crate::profile()`].
#[derive(Debug, Error)]
pub enum KmError {
    /// The scene is invalid.
    #[error(transparent)]
    Scene(#[from] km_core::CoreError),
    /// The multi-flux solver refused or failed.
    #[error(transparent)]
    Multiflux(#[from] km_multiflux::MultifluxError),
    /// The Monte Carlo tracer refused or failed.
    #[error(transparent)]
    MonteCarlo(#[from] km_montecarlo::McError),
    /// The dipole refused.
    #[error(transparent)]
    Dipole(#[from] km_dipole::DipoleError),
    /// The method cannot treat the scene.
    #[error(transparent)]
    Unsupported(#[from] Unsupported),
    /// An option is out of its domain.
    #[error("invalid {name} = {value}: {reason}")]
    Option {
        /// The option.
        name: &'static str,
        /// Its value, as text.
        value: String,
        /// The rule it breaks.
        reason: &'static str,
    },
    /// A setting of [`crate::settings::SETTINGS`] refused: an unknown name,
    /// a value outside its range, a setting the method does not read, or two
    /// that exclude each other.
    #[error("{}", setting_message(name, value, reason))]
    Setting {
        /// The setting's name.
        name: String,
        /// The value given, as text (empty when there is none).
        value: String,
        /// What is wrong.
        reason: String,
    },
    /// The method has no setting an accuracy target could choose.
    #[error(
        "accuracy target {target}: method {method} is a closed form with no accuracy setting; \
         its error against transport theory is not bounded by any setting"
    )]
    NoAccuracySetting {
        /// The method.
        method: Method,
        /// The target asked.
        target: f64,
    },
    /// The work was stopped by the cancel flag of its options
    /// ([`crate::Options::cancel`]) before it finished; nothing is returned.
    #[error("cancelled: the computation was stopped before it finished (no result)")]
    Cancelled,
    /// One point of a sweep failed; the point's edits name it.
    #[error("at sweep point {point}: {source}")]
    SweepPoint {
        /// The point's swept values, `KEY=VALUE` joined by spaces.
        point: String,
        /// Its error.
        source: Box<KmError>,
    },
    /// A request of many points (a sweep, a batch) whose points' work,
    /// summed before any is solved, exceeds the budget of one request.
    #[error(
        "{points} points x {per_point:.3e} {unit} each = {total:.3e} {unit}, over the budget \
         of {budget:.3e} for the whole request: use fewer points or a coarser grid, or raise \
         the budget (--budget FACTOR; docs/limits.md)"
    )]
    RequestTooLarge {
        /// Number of points.
        points: usize,
        /// Estimated work of one point.
        per_point: f64,
        /// Summed work.
        total: f64,
        /// The budget of the request (the method's budget of one solve).
        budget: f64,
        /// The unit of the work (`multi-flux work units`, `photon steps`).
        unit: &'static str,
    },
    /// The accuracy target cannot be met within the work the library allows.
    #[error(
        "accuracy target {target:e} not reached: {limited_by} has an estimated error of \
         {estimate:.2e} (allowed {allowed:.2e}) at {work}, the most this library runs"
    )]
    TargetUnreachable {
        /// The target `tol`.
        target: f64,
        /// The number that missed it (e.g. `reflectance`, `brdf[1]`).
        limited_by: String,
        /// Its error estimate at the largest work.
        estimate: f64,
        /// What it was allowed (`tol * max(1, |x|)`).
        allowed: f64,
        /// The largest work, in words (e.g. `256 streams`).
        work: String,
    },
    /// The accuracy target cannot be met within the work budget, known
    /// before the long solves (docs/planner.md, eq. E4–E6).
    #[error(
        "accuracy target {target:e} cannot be met within the work budget: {limited_by} would \
         need {needed}, the budget allows {reachable}, where the best accuracy reachable is \
         about {best:.1e}; {basis}"
    )]
    TargetOverBudget {
        /// The target `tol`.
        target: f64,
        /// The number that limits it (e.g. `brdf[3]`, `reflectance`).
        limited_by: String,
        /// The work it would need, in words (`about 512 streams`, `about 4.0e10 photons`).
        needed: String,
        /// The most the budget allows, in words (`64 streams`, `2.0e9 photons`).
        reachable: String,
        /// The best accuracy reachable within the budget (the target it would meet).
        best: f64,
        /// What the forecast rests on and the budget (its value, unit and how
        /// to raise it), in words.
        basis: String,
    },
}

impl KmError {
    /// Whether the work was stopped by its cancel flag ([`KmError::Cancelled`],
    /// the tracer's [`km_montecarlo::McError::Cancelled`], or either at a sweep point).
    pub fn is_cancelled(&self) -> bool {
        match self {
            KmError::Cancelled | KmError::MonteCarlo(km_montecarlo::McError::Cancelled) => true,
            KmError::SweepPoint { source, .. } => source.is_cancelled(),
            _ => false,
        }
    }
}

/// `name = value: reason`, or `name: reason` without a value.
fn setting_message(name: &str, value: &str, reason: &str) -> String {
    if value.is_empty() {
        format!("setting {name}: {reason}")
    } else {
        format!("setting {name} = {value}: {reason}")
    }
}

/// `x` with at most 6 significant digits and no trailing zeros (`64`, not `64.000000000001`).
fn short(x: f64) -> String {
    let t = format!("{x:.6e}");
    let v: f64 = t.parse().unwrap_or(x);
    format!("{v}")
}
