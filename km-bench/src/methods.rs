//! One entry point over every solver of the workspace, so that the recipes
//! can run "a method at a setting" on a scene and compare the answers.

use std::fmt;

use km_core::{Scene, Solution};

/// A method at one accuracy setting.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Method {
    /// Two-flux Kubelka–Munk (km-core, seed 000 §2), the seed's identity mapping.
    TwoFlux,
    /// The diffusion dipole (semi-infinite media only; km-dipole).
    Dipole,
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Method::TwoFlux => write!(f, "two-flux KM"),
            Method::Dipole => write!(f, "dipole"),
        }
    }
}

impl Method {
    /// The family name (one Pareto curve per family).
    pub fn family(&self) -> &'static str {
        match self {
            Method::TwoFlux => "km",
            Method::Dipole => "dipole",
        }
    }
}

/// Solve `scene` with `method`.
///
/// # Errors
/// The solver's refusal (e.g. the dipole on a finite slab), as text.
pub fn solve(method: Method, scene: &Scene) -> anyhow::Result<Solution> {
    match method {
        Method::TwoFlux => {
            Ok(km_core::two_flux::solve(scene, &km_core::two_flux::KmOptions::default())?)
        }
        Method::Dipole => Ok(km_dipole::solve(scene, &km_dipole::DipoleOptions::default())?),
    }
}

/// Time a solve: the best of `repeats` runs of the solver's own wall time
/// (`Solution::seconds`), at least one run; returns the last solution and
/// that time.
///
/// # Errors
/// Those of [`solve`].
pub fn timed(method: Method, scene: &Scene, repeats: usize) -> anyhow::Result<(Solution, f64)> {
    let mut sol = solve(method, scene)?;
    let mut best = sol.seconds;
    for _ in 1..repeats.max(1) {
        sol = solve(method, scene)?;
        best = best.min(sol.seconds);
    }
    Ok((sol, best))
}

/// The converged reference used for deviations, when a solver that can
/// serve as one is available in this build.
pub fn reference() -> Option<Method> {
    None
}

/// The methods mapped by the stability study at this size.
pub fn stability_methods(_size: crate::reproduce::Size) -> Vec<Method> {
    vec![Method::TwoFlux, Method::Dipole]
}
