//! The one solve call of the package: a method and its options, applied with
//! the planner and channel de-duplication exactly as `km solve` does
//! (`docs/planner.md`), so that `Solution::to_json` is the `km solve --json`
//! object.

use std::str::FromStr;

use km_core::plan::{Plan, Request, expand_channels, plan_scene, reduce_channels};
use km_core::{Scene, Solution};

use crate::error::Error;

/// The four methods of km.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Method {
    /// Two-flux Kubelka–Munk (closed form).
    Km,
    /// Multi-flux eigenvalue solver (discrete ordinates); the default.
    #[default]
    Multiflux,
    /// Monte Carlo reference.
    Mc,
    /// Diffusion dipole (half-spaces).
    Dipole,
}

impl Method {
    /// The method's name, as in `km solve --method` and the JSON key `method`.
    pub fn name(self) -> &'static str {
        match self {
            Method::Km => "km",
            Method::Multiflux => "multiflux",
            Method::Mc => "mc",
            Method::Dipole => "dipole",
        }
    }
}

impl FromStr for Method {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self, Error> {
        match s {
            "km" | "two-flux" => Ok(Method::Km),
            "multiflux" => Ok(Method::Multiflux),
            "mc" | "montecarlo" => Ok(Method::Mc),
            "dipole" => Ok(Method::Dipole),
            other => Err(Error::option(
                "method",
                format!("unknown method \"{other}\" (expected km, multiflux, mc or dipole)"),
            )),
        }
    }
}

/// A method and its options: the keyword arguments of `km.solve`, with the
/// defaults of `km solve` (docs/cli.md) where `None`.
#[derive(Debug, Clone, PartialEq, Default)]
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
    /// Accuracy target (absolute, on reflectance and transmittance) [multiflux, mc].
    pub tolerance: Option<f64>,
    /// Worker threads [mc] (`None`: all cores). Never changes the result.
    pub threads: Option<usize>,
    /// Analog absorption instead of survival biasing [mc].
    pub analog: bool,
    /// Compute every effect (planner off), for comparison.
    pub all_effects: bool,
}

impl Options {
    /// The Monte Carlo options these stand for.
    ///
    /// # Errors
    /// Zero samples or threads.
    pub fn mc(&self) -> Result<km_montecarlo::McOptions, Error> {
        if self.samples == Some(0) {
            return Err(Error::option("samples", "must be at least 1"));
        }
        if self.threads == Some(0) {
            return Err(Error::option("threads", "must be at least 1"));
        }
        let d = km_montecarlo::McOptions::default();
        Ok(km_montecarlo::McOptions {
            samples: self.samples.unwrap_or(d.samples),
            seed: self.seed.unwrap_or(d.seed),
            threads: self.threads,
            estimator: if self.analog {
                km_montecarlo::Estimator::Analog
            } else {
                km_montecarlo::Estimator::SurvivalBiasing
            },
            all_effects: self.all_effects,
            ..d
        })
    }

    fn multiflux(&self) -> km_multiflux::MultifluxOptions {
        km_multiflux::MultifluxOptions {
            streams: self.streams,
            neumann_order: self.order,
            all_effects: self.all_effects,
            ..Default::default()
        }
    }

    /// Refuse options that the chosen method does not read (a silent no-op
    /// would mislead).
    fn check(&self) -> Result<(), Error> {
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
        if let Some(t) = self.tolerance {
            return Err(Error::option(
                "tolerance",
                format!("{t}: accuracy targets are not available in this build"),
            ));
        }
        Ok(())
    }
}

/// Solve `scene` by `opts.method`, as `km solve SCENE --method M --json` does:
/// the plan of the scene for the method (`docs/planner.md`) is obeyed (unless
/// `all_effects`), channels with identical coefficients are solved once, and
/// the plan is added to the solution under `"plan"`.
///
/// # Errors
/// Options outside their domain, and the method's own refusals (a scene it
/// cannot treat), with the solver's message.
///
/// ```
/// let scene = km_core::Scene::from_toml_str("[[layer]]\ntau = 1.0\nalbedo = 0.9\n").unwrap();
/// let sol = _km::engine::solve(&scene, &_km::engine::Options::default()).unwrap();
/// let c = &sol.channels[0];
/// assert!((c.reflectance + c.transmittance + c.absorptance - 1.0).abs() < 1e-9);
/// ```
pub fn solve(scene: &Scene, opts: &Options) -> Result<Solution, Error> {
    opts.check()?;
    let method = opts.method;
    let request = Request::from_scene(&scene.channels[0]);
    let plan = plan_scene(scene, request, opts.all_effects).for_method(method.name());
    // Channels with identical coefficients are solved once (`duplicate-channels`).
    let dedup = plan.skips("duplicate-channels");
    let reduced = if dedup { Some(reduce_channels(scene)) } else { None };
    let work = reduced.as_ref().map(|(s, _)| s).unwrap_or(scene);
    let mut sol = match method {
        Method::Km => km_core::two_flux::solve(work, &Default::default())?,
        Method::Multiflux => km_multiflux::solve(work, &opts.multiflux())?,
        Method::Mc => km_montecarlo::solve(work, &opts.mc()?)?,
        Method::Dipole => match as_half_space(work, opts.all_effects) {
            Some((half, bound)) => {
                let mut sol = km_dipole::solve(&half, &Default::default())?;
                let note = format!(
                    "{} < {:.1e} {}",
                    "the top layer is so thick that the light returning from below it is",
                    bound.max(f64::MIN_POSITIVE),
                    "of the incident (planner rule `transmission`): solved as a half-space"
                );
                let notes = sol.extra.entry("notes").or_insert_with(|| serde_json::json!([]));
                if let Some(a) = notes.as_array_mut() {
                    a.push(serde_json::json!(note));
                }
                sol
            }
            None => km_dipole::solve(work, &Default::default())?,
        },
    };
    if let Some((_, map)) = &reduced {
        sol = expand_channels(sol, map, &scene.labels);
    }
    sol.extra.insert("plan".into(), plan.to_json());
    Ok(sol)
}

/// The dipole treats half-spaces only; a finite top layer that the planner's
/// `transmission` rule makes a half-space in every channel is one (with the
/// largest bound of the neglected light).
fn as_half_space(scene: &Scene, all_effects: bool) -> Option<(Scene, f64)> {
    if all_effects {
        return None;
    }
    let mut half = scene.clone();
    let mut bound = 0.0f64;
    for c in &mut half.channels {
        let plan = Plan::new(c, Request::default(), false);
        let cut = plan.layers.first().and_then(|l| l.cutoff_bound)?;
        bound = bound.max(cut);
        c.layers.truncate(1);
        c.layers[0].thickness = f64::INFINITY;
    }
    Some((half, bound))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_method_and_foreign_options_are_refused() {
        let e = "multi".parse::<Method>().unwrap_err();
        assert!(e.to_string().contains("unknown method \"multi\""), "{e}");
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
        let plan = sol.extra["plan"].to_string();
        assert!(plan.contains("duplicate-channels"), "{plan}");
    }
}
