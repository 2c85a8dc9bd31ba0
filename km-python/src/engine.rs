//! The one solve call of the package: the keyword arguments of `km.solve`
//! ([`Options`]) turned into the library's options (`km::Options`) and
//! solved by `km::solve`, which applies the plan, the channel
//! de-duplication and the accuracy target exactly as `km solve` does, so that
//! `Solution::to_json` is the `km solve --json` object.

use km::settings::{Settings, Value};
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
    /// Further settings of [`km::settings::SETTINGS`] by name, as text
    /// (`("km_mapping", "seed")`, `("budget", "4")`, `("repeat", "3")`):
    /// checked and read exactly as the `km solve` flags of the same names.
    pub settings: Vec<(String, String)>,
    /// A flag that stops the solve under way ([`km::Options::cancel`]): the
    /// Monte Carlo tracer reads it between batches and within them, a batch
    /// or a sweep before each point; the solve then returns
    /// [`Error::Cancelled`]. Never changes a result that is returned.
    pub cancel: Option<km::Cancel>,
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
            settings: Vec::new(),
            cancel: None,
        }
    }
}

impl Options {
    /// These options with the cancel flag `cancel` ([`Options::cancel`]).
    pub fn with_cancel(&self, cancel: &km::Cancel) -> Options {
        Options { cancel: Some(cancel.clone()), ..self.clone() }
    }

    /// The settings of the solve, checked against [`km::settings::SETTINGS`]
    /// as the `km solve` flags are: a setting the method does not read (a
    /// silent no-op would mislead), a value outside its range or two settings
    /// that exclude each other are refused in the command's words.
    ///
    /// # Errors
    /// The first refused setting, as [`Error::Setting`] naming it.
    pub fn settings(&self) -> Result<Settings, Error> {
        let mut s = Settings::new(self.method);
        let counts = [
            ("streams", self.streams.map(|n| n as u64)),
            ("order", self.order.map(|n| n as u64)),
            ("samples", self.samples),
            ("seed", self.seed),
            ("threads", self.threads.map(|n| n as u64)),
        ];
        for (name, v) in counts {
            if let Some(n) = v {
                s.set(name, Value::Count(n))?;
            }
        }
        if let Some(t) = self.tolerance {
            s.set("tolerance", Value::Real(t))?;
        }
        if let Some(c) = self.cone {
            s.set("cone", Value::Real(c))?;
        }
        if self.analog {
            s.set("estimator", Value::Choice("analog"))?;
        }
        if self.all_effects {
            s.set("all_effects", Value::Flag(true))?;
        }
        if let Some(m) = self.km_model {
            let name = match m {
                km::KmModel::TwoFlux => "two-flux",
                km::KmModel::FourFlux => "four-flux",
            };
            s.set("km_model", Value::Choice(name))?;
        }
        for (name, text) in &self.settings {
            s.set_text(name, text)?;
        }
        Ok(s)
    }

    /// The library's options (`km::Options`), as `km solve` builds them from
    /// its flags ([`Options::settings`], then [`Settings::options`]).
    ///
    /// # Errors
    /// Those of [`Options::settings`] and of the budget.
    pub fn library(&self) -> Result<km::Options, Error> {
        let o = self.settings()?.options()?;
        Ok(match &self.cancel {
            Some(c) => o.with_cancel(c.clone()),
            None => o,
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
/// method cannot treat, an accuracy target it cannot reach); a raised
/// cancel flag ([`Error::Cancelled`]).
///
/// ```
/// let scene = km::Scene::from_toml_str("[[layer]]\ntau = 1.0\nalbedo = 0.9\n").unwrap();
/// let sol = _km::engine::solve(&scene, &_km::engine::Options::default()).unwrap();
/// let c = &sol.channels[0];
/// assert!((c.reflectance + c.transmittance + c.absorptance - 1.0).abs() < 1e-9);
/// ```
pub fn solve(scene: &Scene, opts: &Options) -> Result<Solution, Error> {
    let settings = opts.settings()?;
    Ok(km::solve_repeated(scene, &opts.library()?, settings.repeat())?)
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
        let e = solve(&scene, &opts).unwrap_err();
        assert_eq!(e.key(), Some("samples"));
        assert!(e.to_string().contains("1.."), "{e}");
        // A setting of the table given by name, in the table's words.
        let opts = Options {
            method: Method::Km,
            settings: vec![("km_mapping".into(), "nope".into())],
            ..Default::default()
        };
        let e = solve(&scene, &opts).unwrap_err();
        assert_eq!(e.key(), Some("km_mapping"));
        assert!(e.to_string().contains("gate1974"), "{e}");
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
