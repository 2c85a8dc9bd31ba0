//! The one solve call of the package: the keyword arguments of `km.solve`
//! ([`Options`]) turned into the library's options (`km::Options`) and
//! solved by `km::solve`, which applies the plan, the channel
//! de-duplication and the accuracy target exactly as `km solve` does, so that
//! `Solution::to_json` is the `km solve --json` object.

use km::{Method, Scene, Solution};

use crate::error::Error;

/// Parse a method name (`km`, `multiflux`, `mc`, `dipole`).
///
/// # Errors
/// An unknown name, as an option error on `method`.
pub fn method(name: &str) -> Result<Method, Error> {
    name.parse::<Method>().map_err(|e| Error::option("method", e.to_string()))
}

/// A method and its options: the keyword arguments of `km.solve`, with the
/// defaults of `km solve` (docs/cli.md) where `None`.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// The method.
    pub method: Method,
    /// Gauss nodes per hemisphere [multiflux] (`None`: the solver's default).
    pub streams: Option<usize>,
    /// Truncate the adding after this Neumann order [multiflux] (`None`: exact).
    pub order: Option<usize>,
    /// Photons per channel [mc] (`None`: 10^6).
    pub samples: Option<u64>,
    /// Seed [mc] (`None`: 1).
    pub seed: Option<u64>,
    /// Accuracy target `tol` (docs/planner.md, eq. E1–E2) [multiflux, mc].
    pub tolerance: Option<f64>,
    /// Worker threads [mc] (`None`: all cores). Never changes the result.
    pub threads: Option<usize>,
    /// Analog absorption instead of survival biasing [mc].
    pub analog: bool,
    /// Compute every effect (planner off), for comparison.
    pub all_effects: bool,
    /// The two-flux model [km] (`None`: four-flux).
    pub km_model: Option<km::KmModel>,
    /// Cone half-angle of the BRDF/BTDF values, degrees [mc, multiflux].
    pub cone: Option<f64>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            method: Method::Multiflux,
            streams: None,
            order: None,
            samples: None,
            seed: None,
            tolerance: None,
            threads: None,
            analog: false,
            all_effects: false,
            km_model: None,
            cone: None,
        }
    }
}

impl Options {
    /// The Monte Carlo options these stand for.
    ///
    /// # Errors
    /// Zero samples or threads.
    pub fn mc(&self) -> Result<km::McOptions, Error> {
        if self.samples == Some(0) {
            return Err(Error::option("samples", "must be at least 1"));
        }
        if self.threads == Some(0) {
            return Err(Error::option("threads", "must be at least 1"));
        }
        let d = km::McOptions::default();
        Ok(km::McOptions {
            samples: self.samples.unwrap_or(d.samples),
            seed: self.seed.unwrap_or(d.seed),
            threads: self.threads,
            estimator: if self.analog {
                km::Estimator::Analog
            } else {
                km::Estimator::SurvivalBiasing
            },
            all_effects: self.all_effects,
            ..d
        })
    }

    /// The library's options (`km::Options`), as `km solve` builds them from its flags.
    ///
    /// # Errors
    /// An option that the method does not read (a silent no-op would
    /// mislead), both `streams` and `tolerance`, zero samples or threads.
    pub fn library(&self) -> Result<km::Options, Error> {
        let m = self.method;
        let unused = |name: &str, given: bool, ok: bool| -> Result<(), Error> {
            if given && !ok {
                Err(Error::option(name, format!("method {} has no such option", m.name())))
            } else {
                Ok(())
            }
        };
        unused("streams", self.streams.is_some(), m == Method::Multiflux)?;
        unused("order", self.order.is_some(), m == Method::Multiflux)?;
        unused("samples", self.samples.is_some(), m == Method::Mc)?;
        unused("seed", self.seed.is_some(), m == Method::Mc)?;
        unused("threads", self.threads.is_some(), m == Method::Mc)?;
        unused("analog", self.analog, m == Method::Mc)?;
        unused("km_model", self.km_model.is_some(), m == Method::Km)?;
        unused("cone", self.cone.is_some(), matches!(m, Method::Mc | Method::Multiflux))?;
        if self.tolerance.is_some() && self.streams.is_some() {
            return Err(Error::option("tolerance", "give either streams or tolerance, not both"));
        }
        let method = match m {
            Method::Km => km::MethodOptions::Km(km::KmOptions {
                model: self.km_model.unwrap_or_default(),
                ..Default::default()
            }),
            Method::Multiflux => km::MethodOptions::Multiflux(km::MultifluxOptions {
                streams: self.streams,
                neumann_order: self.order,
                all_effects: self.all_effects,
                ..Default::default()
            }),
            Method::Mc => km::MethodOptions::Mc(self.mc()?),
            Method::DirectionSet => km::MethodOptions::new(Method::DirectionSet),
            Method::Dipole => km::MethodOptions::Dipole(km::DipoleOptions::default()),
        };
        Ok(km::Options {
            method,
            tolerance: self.tolerance,
            all_effects: self.all_effects,
            cone_deg: self.cone,
            budget: 1.0,
        })
    }
}

/// Solve `scene` by `opts.method` through `km::solve` (the plan, channel
/// de-duplication, the dipole's half-space rule, the capability check, the
/// accuracy target; docs/planner.md), as `km solve SCENE --method M --json`
/// does.
///
/// # Errors
/// Options outside their domain, and the library's refusals (a scene the
/// method cannot treat, an accuracy target it cannot reach).
///
/// ```
/// let scene = km::Scene::from_toml_str("[[layer]]\ntau = 1.0\nalbedo = 0.9\n").unwrap();
/// let sol = _km::engine::solve(&scene, &_km::engine::Options::default()).unwrap();
/// let c = &sol.channels[0];
/// assert!((c.reflectance + c.transmittance + c.absorptance - 1.0).abs() < 1e-9);
/// ```
pub fn solve(scene: &Scene, opts: &Options) -> Result<Solution, Error> {
    Ok(km::solve(scene, &opts.library()?)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_method_and_foreign_options_are_refused() {
        let e = method("multi").unwrap_err();
        assert_eq!(e.key(), Some("method"));
        assert!(e.to_string().contains("multi"), "{e}");
        let scene = Scene::from_toml_str("[[layer]]\ntau = 1.0\nalbedo = 0.9\n").unwrap();
        let opts = Options { method: Method::Km, streams: Some(8), ..Default::default() };
        let e = solve(&scene, &opts).unwrap_err();
        assert_eq!(e.key(), Some("streams"));
        let opts = Options { method: Method::Mc, samples: Some(0), ..Default::default() };
        assert!(solve(&scene, &opts).unwrap_err().to_string().contains("at least 1"));
    }

    #[test]
    fn duplicate_channels_are_solved_once_and_expanded() {
        // Three channels, two distinct: the answer of channel 2 must be that of
        // channel 0 bit for bit, and the plan must say what was skipped.
        let scene =
            Scene::from_toml_str("[[layer]]\ntau = [1.0, 2.0, 1.0]\nalbedo = 0.9\n").unwrap();
        let sol = solve(&scene, &Options::default()).unwrap();
        assert_eq!(sol.channels.len(), 3);
        assert_eq!(sol.channels[0], sol.channels[2]);
        assert_ne!(sol.channels[0], sol.channels[1]);
        let plan = sol.to_json()["plan"].to_string();
        assert!(plan.contains("duplicate-channels"), "{plan}");
    }
}
