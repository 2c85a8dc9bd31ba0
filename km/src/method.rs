//! The method registry: the methods of km, by name.

use std::fmt;
use std::str::FromStr;

use km_core::plan::{Simplification, relevant_to};

/// The methods of km.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    /// Two-flux Kubelka–Munk, closed form (km-core, seed §2).
    Km,
    /// Multi-flux eigenvalue solver, discrete ordinates (km-multiflux, seed eq. 18–21).
    Multiflux,
    /// The multi-flux solver on the seed's own direction set on the sphere
    /// (km-multiflux `direction_set`, seed §3 and §4.2; docs/multiflux-direction-set.md):
    /// totals and delta parts, no Fourier series, no delta-M.
    DirectionSet,
    /// Monte Carlo reference tracer (km-montecarlo).
    Mc,
    /// Diffusion dipole for a semi-infinite layer (km-dipole).
    Dipole,
}

impl Method {
    /// Every method, in the order of the documentation.
    pub const ALL: [Method; 5] =
        [Method::Km, Method::Multiflux, Method::DirectionSet, Method::Mc, Method::Dipole];

    /// The name used in JSON, scene tools and messages (`km`, `multiflux`,
    /// `direction-set`, `mc`, `dipole`).
    ///
    /// ```
    /// assert_eq!(km::Method::Mc.name(), "mc");
    /// assert_eq!("dipole".parse::<km::Method>().unwrap(), km::Method::Dipole);
    /// assert!("kubelka".parse::<km::Method>().is_err());
    /// ```
    pub fn name(self) -> &'static str {
        match self {
            Method::Km => "km",
            Method::Multiflux => "multiflux",
            Method::DirectionSet => "direction-set",
            Method::Mc => "mc",
            Method::Dipole => "dipole",
        }
    }

    /// One line on what the method is.
    pub fn summary(self) -> &'static str {
        match self {
            Method::Km => "two-flux Kubelka–Munk, closed form",
            Method::Multiflux => "multi-flux eigenvalue solver (discrete ordinates)",
            Method::DirectionSet => "multi-flux on the seed's direction set on the sphere",
            Method::Mc => "Monte Carlo reference tracer",
            Method::Dipole => "diffusion dipole for semi-infinite media",
        }
    }

    /// The planner's simplifications this method obeys (docs/planner.md).
    pub fn simplifications(self) -> &'static [Simplification] {
        match self {
            // Every node of the set carries every effect: only duplicate
            // channels can be skipped.
            Method::DirectionSet => &[Simplification::DuplicateChannels],
            _ => relevant_to(self.name()),
        }
    }

    /// Whether the method has an accuracy setting that an accuracy target can choose.
    pub fn has_accuracy_knob(self) -> bool {
        matches!(self, Method::Multiflux | Method::Mc)
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A method name that is none of km's.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown method `{0}` (known: km, multiflux, direction-set, mc, dipole)")]
pub struct UnknownMethod(pub String);

impl FromStr for Method {
    type Err = UnknownMethod;
    fn from_str(s: &str) -> Result<Method, UnknownMethod> {
        Method::ALL.into_iter().find(|m| m.name() == s).ok_or_else(|| UnknownMethod(s.to_string()))
    }
}
