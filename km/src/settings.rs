//! The settings of a solve, written once: their names, the methods they
//! apply to, their kinds, ranges and defaults, the settings they exclude and
//! one line of help ([`SETTINGS`]). Every front end builds its request from
//! this table: the `km` command's flags (`--name`, `_` written `-`) and the
//! Python package's keyword arguments are checked against it, and
//! [`Settings`] turns the values given into [`Options`], refusing a setting
//! the method does not read, a value outside its range, or two settings that
//! exclude each other, in the same words for both. [`refuse_flags`] checks
//! the flags given to a command against the method and the command.
//!
//! ```
//! use km::settings::Settings;
//! let mut s = Settings::new(km::Method::Mc);
//! s.set_text("samples", "20000").unwrap();
//! s.set_text("seed", "7").unwrap();
//! assert!(s.set_text("streams", "8").is_err(), "streams is multi-flux's");
//! assert!(s.set_text("tolerance", "1e-3").is_err(), "samples and tolerance exclude each other");
//! let km::MethodOptions::Mc(o) = s.options().unwrap().method else { unreachable!() };
//! assert_eq!((o.samples, o.seed), (20_000, 7));
//! ```

use crate::{DirectionSetOptions, KmError, Method, MethodOptions, Options};

#[cfg(feature = "clap")]
pub mod command_line;
mod flags;
pub use flags::{FlagError, method_flag_error, option_flag, refuse_flags, solve_flag_error};

/// What values a setting takes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Kind {
    /// On or off (a flag without a value on the command line).
    Flag,
    /// A whole number in `min..=max`.
    Count {
        /// Smallest value.
        min: u64,
        /// Largest value.
        max: u64,
    },
    /// A finite real number `> min` (`min` excluded) and `<= max`.
    Real {
        /// Lower bound (excluded).
        min: f64,
        /// Upper bound (included).
        max: f64,
    },
    /// One of these names.
    Choice(&'static [&'static str]),
    /// A shard `I/N` of a Monte Carlo run, `0 <= I < N`.
    Shard,
}

/// One setting of a solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Setting {
    /// Its name (`_` between words; the command line writes `-`).
    pub name: &'static str,
    /// The methods that read it.
    pub methods: &'static [Method],
    /// Its values.
    pub kind: Kind,
    /// Its default as text (`None`: the method chooses, see `help`).
    pub default: Option<&'static str>,
    /// The settings it excludes.
    pub conflicts: &'static [&'static str],
    /// One line of help (the `km solve --help` line: the methods that read
    /// the setting in brackets, unless every method does).
    pub help: &'static str,
    /// The name of its value in the help (`None`: the setting's name in capitals).
    pub value_name: Option<&'static str>,
    /// What it sets, in the words of a refusal: "`--NAME` does not apply to
    /// method M: it sets SETS".
    pub sets: &'static str,
}

use Method::{Dipole, DirectionSet as Ds, Km, Mc, Multiflux as Mf};

const ALL: &[Method] = &[Km, Mf, Ds, Mc, Dipole];

/// The km-mapping names (`km_core::two_flux::KmMapping`).
const MAPPINGS: &[&str] = &["seed", "star1988", "gate1974"];
/// The two-flux models (`km_core::two_flux::KmModel`).
const KM_MODELS: &[&str] = &["four-flux", "two-flux"];
/// The absorption estimators of Monte Carlo.
const ESTIMATORS: &[&str] = &["survival", "analog"];
/// How the dipole computes `F_dr`.
const FDR: &[&str] = &["exact", "egan-hilgeman"];
/// The dipoles.
const DIPOLES: &[&str] = &["jensen2001", "better"];

/// Every setting of a solve, in the order of the documentation.
pub const SETTINGS: &[Setting] = &[
    Setting {
        name: "tolerance",
        methods: &[Mf, Mc],
        kind: Kind::Real { min: 0.0, max: 1.0 },
        default: None,
        conflicts: &["streams", "samples", "shard"],
        help: "Accuracy target: every number asked for (R, T, their delta parts, each BRDF/BTDF \
              value) within TOL * max(1, |x|); chooses streams or samples, reports \
              `error_estimate` and `tolerance.limited_by`, fails when unreachable [multiflux, mc]",
        value_name: None,
        sets: "an accuracy target, met by choosing streams or photons; km and dipole are \
               closed forms with no accuracy setting",
    },
    Setting {
        name: "all_effects",
        methods: ALL,
        kind: Kind::Flag,
        default: Some("false"),
        conflicts: &[],
        help: "Compute every effect (planner off), for comparison",
        value_name: None,
        sets: "the planner off",
    },
    Setting {
        name: "km_mapping",
        methods: &[Km],
        kind: Kind::Choice(MAPPINGS),
        default: Some("gate1974"),
        conflicts: &[],
        help: "Two-flux coefficients K, S from the scene [km] (default gate1974, the least error \
              against multi-flux on the grid of docs/two-flux.md §13; seed: the paper's K = \
              sigma_a, S = sigma_s)",
        value_name: None,
        sets: "how two-flux K, S come from the scene",
    },
    Setting {
        name: "km_model",
        methods: &[Km],
        kind: Kind::Choice(KM_MODELS),
        default: Some("four-flux"),
        conflicts: &[],
        help: "Two-flux model [km]: four-flux carries a collimated beam as a beam (refracted, \
              Beer–Lambert on its path, Fresnel at its own angle); two-flux is the seed's diffuse \
              model (default four-flux; the same for diffuse light)",
        value_name: None,
        sets: "the four-flux or the two-flux model",
    },
    Setting {
        name: "streams",
        methods: &[Mf],
        kind: Kind::Count { min: 1, max: 512 },
        default: None,
        conflicts: &["tolerance"],
        help: "Gauss nodes per hemisphere [multiflux] (default 16)",
        value_name: None,
        sets: "the Gauss nodes per hemisphere of multi-flux",
    },
    Setting {
        name: "order",
        methods: &[Mf],
        kind: Kind::Count { min: 0, max: 100_000 },
        default: None,
        conflicts: &[],
        help: "Truncate adding after this Neumann order (seed eq. 21) [multiflux]; default exact",
        value_name: None,
        sets: "the Neumann order of multi-flux adding",
    },
    Setting {
        name: "fourier_tol",
        methods: &[Mf],
        kind: Kind::Real { min: 0.0, max: km_multiflux::options::MAX_FOURIER_TOL },
        default: Some("1e-9"),
        conflicts: &[],
        help: "Stop the azimuthal series of BRDF/BTDF values after two Fourier orders whose \
              multiply scattered part is at most TOL of the largest value (DISORT's ACCUR; \
              docs/multiflux.md eq. 5j) [multiflux]",
        value_name: Some("TOL"),
        sets: "where the azimuthal series of multi-flux BRDF/BTDF values stops",
    },
    Setting {
        name: "directions",
        methods: &[Ds],
        kind: Kind::Count { min: 4, max: 2000 },
        default: Some("303"),
        conflicts: &[],
        help: "Directions on the sphere, both hemispheres, in the medium of lowest index \
              (4..=2000) [direction-set] (the default is the seed's 303)",
        value_name: Some("N"),
        sets: "the size of the direction set on the sphere",
    },
    Setting {
        name: "cone",
        methods: &[Mf, Mc],
        kind: Kind::Real { min: 0.0, max: crate::cone::MAX_CONE_DEG },
        default: None,
        conflicts: &[],
        help: "BRDF/BTDF values as means over cones of this half-angle, degrees, in (0, 45]: the \
              Monte Carlo bins (default 5), or the multi-flux values averaged over the same cones \
              for comparison with them [mc, multiflux]",
        value_name: Some("DEG"),
        sets: "the cones the BRDF/BTDF values are means over (Monte Carlo bins; multi-flux \
               averaged alike)",
    },
    Setting {
        name: "samples",
        methods: &[Mc],
        kind: Kind::Count { min: 1, max: u64::MAX },
        default: Some("1000000"),
        conflicts: &["tolerance"],
        help: "Photons per channel [mc]",
        value_name: None,
        sets: "the photon count of Monte Carlo",
    },
    Setting {
        name: "seed",
        methods: &[Mc],
        kind: Kind::Count { min: 0, max: u64::MAX },
        default: Some("1"),
        conflicts: &[],
        help: "Seed [mc]; the same seed gives bit-identical results for any thread count",
        value_name: None,
        sets: "the random seed of Monte Carlo",
    },
    Setting {
        name: "threads",
        methods: &[Mc],
        kind: Kind::Count { min: 1, max: 4096 },
        default: None,
        conflicts: &[],
        help: "Worker threads [mc] (default: all cores)",
        value_name: None,
        sets: "the worker threads of Monte Carlo",
    },
    Setting {
        name: "estimator",
        methods: &[Mc],
        kind: Kind::Choice(ESTIMATORS),
        default: Some("survival"),
        conflicts: &[],
        help: "Absorption estimator [mc]",
        value_name: None,
        sets: "the absorption estimator of Monte Carlo",
    },
    Setting {
        name: "shard",
        methods: &[Mc],
        kind: Kind::Shard,
        default: None,
        conflicts: &["tolerance", "repeat"],
        help: "Run shard I of N (0-based) and write its partial tally to --out [mc]",
        value_name: Some("I/N"),
        sets: "a share of a Monte Carlo run",
    },
    Setting {
        name: "budget",
        methods: ALL,
        kind: Kind::Real { min: 0.0, max: 1e12 },
        default: Some("1"),
        conflicts: &[],
        help: "Multiply every default work and memory budget by this factor: one solve's (Monte \
              Carlo photon steps and tally memory, multi-flux work) and a request of many points' \
              (every method); see docs/limits.md",
        value_name: Some("FACTOR"),
        sets: "the work and memory budgets",
    },
    Setting {
        name: "repeat",
        methods: ALL,
        kind: Kind::Count { min: 1, max: 10_000 },
        default: Some("1"),
        conflicts: &["shard"],
        help: "Solve K times in this process: `seconds` stays the first (cold) call's, \
              `seconds_best` and `seconds_median` are over all K calls (1..=10000)",
        value_name: Some("K"),
        sets: "how many times the solve is timed",
    },
    Setting {
        name: "fdr",
        methods: &[Dipole],
        kind: Kind::Choice(FDR),
        default: Some("exact"),
        conflicts: &[],
        help: "How F_dr is computed [dipole]",
        value_name: None,
        sets: "how the dipole computes F_dr",
    },
    Setting {
        name: "dipole",
        methods: &[Dipole],
        kind: Kind::Choice(DIPOLES),
        default: Some("jensen2001"),
        conflicts: &[],
        help: "Which dipole [dipole]",
        value_name: None,
        sets: "which dipole",
    },
];

/// The setting named `name` (`-` and `_` alike).
pub fn setting(name: &str) -> Option<&'static Setting> {
    let name = name.replace('-', "_");
    SETTINGS.iter().find(|s| s.name == name)
}

/// A setting's value.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// A flag.
    Flag(bool),
    /// A whole number.
    Count(u64),
    /// A real number.
    Real(f64),
    /// A name of a [`Kind::Choice`].
    Choice(&'static str),
    /// Shard `I` of `N`.
    Shard(u64, u64),
}

impl std::fmt::Display for Value {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Value::Flag(b) => write!(f, "{b}"),
            Value::Count(n) => write!(f, "{n}"),
            Value::Real(x) => write!(f, "{x}"),
            Value::Choice(c) => f.write_str(c),
            Value::Shard(i, n) => write!(f, "{i}/{n}"),
        }
    }
}

/// A refusal in the settings' words.
fn refuse(name: &str, value: impl ToString, reason: impl Into<String>) -> KmError {
    KmError::Setting { name: name.to_string(), value: value.to_string(), reason: reason.into() }
}

impl Setting {
    /// Parse `text` as this setting's value (`1e6` is a whole number; a shard is `I/N`).
    ///
    /// # Errors
    /// [`KmError::Setting`] naming the setting, the text and the rule.
    pub fn parse(&self, text: &str) -> Result<Value, KmError> {
        let value = self.read(text)?;
        self.check(&value)?;
        Ok(value)
    }

    /// `text` read as this setting's value, its range not checked (a shard
    /// is checked: `0 <= I < N`).
    fn read(&self, text: &str) -> Result<Value, KmError> {
        let t = text.trim();
        let bad = |why: &str| refuse(self.name, text, why);
        let value = match self.kind {
            Kind::Flag => match t {
                "true" | "1" | "yes" | "on" => Value::Flag(true),
                "false" | "0" | "no" | "off" => Value::Flag(false),
                _ => return Err(bad("expected true or false")),
            },
            Kind::Count { .. } => {
                let n = match t.parse::<u64>() {
                    Ok(n) => n,
                    // `1e6` and `1000000.0` name whole numbers too.
                    Err(_) => match t.parse::<f64>() {
                        Ok(x) if x.fract() == 0.0 && (0.0..1.8e19).contains(&x) => x as u64,
                        _ => return Err(bad("expected a whole number")),
                    },
                };
                Value::Count(n)
            }
            Kind::Real { .. } => Value::Real(t.parse().map_err(|_| bad("expected a number"))?),
            Kind::Choice(names) => match names.iter().find(|n| **n == t) {
                Some(n) => Value::Choice(n),
                None => return Err(bad(&format!("expected one of {}", names.join(", ")))),
            },
            Kind::Shard => {
                let (i, n) = t.split_once('/').ok_or_else(|| bad("expected I/N, e.g. 0/4"))?;
                let num = |x: &str, what: &str| {
                    x.trim()
                        .parse::<u64>()
                        .map_err(|e| bad(&format!("{what} is not a number: {e}")))
                };
                let shard = Value::Shard(num(i, "I")?, num(n, "N")?);
                self.check(&shard)?;
                shard
            }
        };
        Ok(value)
    }

    /// Check `value` against this setting's kind and range.
    ///
    /// # Errors
    /// [`KmError::Setting`] naming the setting, the value and the rule.
    pub fn check(&self, value: &Value) -> Result<(), KmError> {
        let bad = |why: String| Err(refuse(self.name, value, why));
        match (self.kind, value) {
            (Kind::Flag, Value::Flag(_)) => Ok(()),
            (Kind::Count { min, max }, Value::Count(n)) if *n < min || *n > max => {
                bad(format!("must lie in {min}..={max}"))
            }
            (Kind::Count { .. }, Value::Count(_)) => Ok(()),
            (Kind::Real { min, max }, Value::Real(x))
                if !(x.is_finite() && *x > min && *x <= max) =>
            {
                bad(format!("must be a finite number > {min} and <= {max}"))
            }
            (Kind::Real { .. }, Value::Real(_)) => Ok(()),
            (Kind::Choice(names), Value::Choice(c)) if !names.contains(c) => {
                bad(format!("expected one of {}", names.join(", ")))
            }
            (Kind::Choice(_), Value::Choice(_)) => Ok(()),
            (Kind::Shard, Value::Shard(i, n)) if *n == 0 || i >= n => bad("need 0 <= I < N".into()),
            (Kind::Shard, Value::Shard(..)) => Ok(()),
            _ => bad(format!("not a value of this setting ({:?})", self.kind)),
        }
    }

    /// Whether `method` reads this setting.
    pub fn applies_to(&self, method: Method) -> bool {
        self.methods.contains(&method)
    }
}

/// The settings given for one solve by one method, each checked once.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    method: Method,
    given: Vec<(&'static Setting, Value)>,
}

impl Settings {
    /// No setting given yet for `method`.
    pub fn new(method: Method) -> Settings {
        Settings { method, given: Vec::new() }
    }

    /// The settings given on a command line for `method`, as text by name,
    /// once [`refuse_flags`] has accepted the flags (the method reads each,
    /// none excludes another) and the parser their types: each is read as
    /// its setting's value, its range left to the method's options (their
    /// words); a shard `I/N` is checked here.
    ///
    /// # Errors
    /// An unknown name, or a text that is not a value of its setting.
    pub fn from_flags(method: Method, given: &[(&str, String)]) -> Result<Settings, KmError> {
        let mut s = Settings::new(method);
        for (name, text) in given {
            let setting = s.known(name)?;
            s.given.push((setting, setting.read(text)?));
        }
        Ok(s)
    }

    /// The method.
    pub fn method(&self) -> Method {
        self.method
    }

    /// Give setting `name` the value `text` ([`Setting::parse`]).
    ///
    /// # Errors
    /// As [`Settings::set`], and a text that is not a value of the setting.
    pub fn set_text(&mut self, name: &str, text: &str) -> Result<(), KmError> {
        let s = self.known(name)?;
        let v = s.parse(text)?;
        self.set(name, v)
    }

    /// Give setting `name` the value `value`.
    ///
    /// # Errors
    /// [`KmError::Setting`]: an unknown name, a setting the method does not
    /// read (naming the methods that do), a value outside its range, a
    /// setting given twice, or one that excludes a setting already given.
    pub fn set(&mut self, name: &str, value: Value) -> Result<(), KmError> {
        let s = self.known(name)?;
        s.check(&value)?;
        if !s.applies_to(self.method) {
            let names: Vec<&str> = s.methods.iter().map(|m| m.name()).collect();
            return Err(refuse(
                s.name,
                &value,
                format!(
                    "does not apply to method {}: it sets {} (method {})",
                    self.method.name(),
                    s.sets,
                    names.join(" or ")
                ),
            ));
        }
        if self.given.iter().any(|(g, _)| g.name == s.name) {
            return Err(refuse(s.name, &value, "given twice"));
        }
        if let Some((other, _)) = self.given.iter().find(|(g, _)| s.conflicts.contains(&g.name)) {
            return Err(refuse(
                s.name,
                &value,
                format!("give either {} or {}, not both", other.name, s.name),
            ));
        }
        self.given.push((s, value));
        Ok(())
    }

    fn known(&self, name: &str) -> Result<&'static Setting, KmError> {
        setting(name).ok_or_else(|| {
            let names: Vec<&str> = SETTINGS.iter().map(|s| s.name).collect();
            refuse(name, "", format!("unknown setting (known: {})", names.join(", ")))
        })
    }

    /// The value given for `name`, if any.
    pub fn get(&self, name: &str) -> Option<&Value> {
        self.given.iter().find(|(s, _)| s.name == name).map(|(_, v)| v)
    }

    /// The value of `name`: the one given, else its default.
    fn value(&self, name: &str) -> Option<Value> {
        self.get(name).cloned().or_else(|| {
            let s = setting(name)?;
            s.default.and_then(|d| s.parse(d).ok())
        })
    }

    fn count(&self, name: &str) -> Option<u64> {
        match self.value(name) {
            Some(Value::Count(n)) => Some(n),
            _ => None,
        }
    }

    fn real(&self, name: &str) -> Option<f64> {
        match self.value(name) {
            Some(Value::Real(x)) => Some(x),
            _ => None,
        }
    }

    fn choice(&self, name: &str) -> &'static str {
        match self.value(name) {
            Some(Value::Choice(c)) => c,
            _ => "",
        }
    }

    /// How many times to solve (`repeat`, default 1).
    pub fn repeat(&self) -> u32 {
        self.count("repeat").map_or(1, |n| n.min(u32::MAX as u64) as u32)
    }

    /// The shard `(I, N)` asked for, if any.
    pub fn shard(&self) -> Option<(u64, u64)> {
        match self.get("shard") {
            Some(Value::Shard(i, n)) => Some((*i, *n)),
            _ => None,
        }
    }

    /// Whether the planner is off.
    pub fn all_effects(&self) -> bool {
        matches!(self.value("all_effects"), Some(Value::Flag(true)))
    }

    /// The library options these settings stand for (defaults where not given).
    ///
    /// # Errors
    /// Those of [`Options::with_budget`].
    pub fn options(&self) -> Result<Options, KmError> {
        let all_effects = self.all_effects();
        let usize_of = |name: &str| self.count(name).map(|n| n.min(usize::MAX as u64) as usize);
        let method = match self.method {
            Km => MethodOptions::Km(km_core::two_flux::KmOptions {
                mapping: match self.choice("km_mapping") {
                    "star1988" => km_core::two_flux::KmMapping::StarEtAl1988,
                    "gate1974" => km_core::two_flux::KmMapping::Gate1974,
                    _ => km_core::two_flux::KmMapping::Seed,
                },
                model: match self.choice("km_model") {
                    "two-flux" => km_core::two_flux::KmModel::TwoFlux,
                    _ => km_core::two_flux::KmModel::FourFlux,
                },
            }),
            Mf => MethodOptions::Multiflux(km_multiflux::MultifluxOptions {
                streams: usize_of("streams"),
                neumann_order: usize_of("order"),
                fourier_tol: self.real("fourier_tol").unwrap_or(km_multiflux::options::FOURIER_TOL),
                all_effects,
                ..Default::default()
            }),
            Ds => MethodOptions::DirectionSet(DirectionSetOptions {
                directions: usize_of("directions")
                    .unwrap_or(crate::direction_set::DEFAULT_DIRECTIONS),
            }),
            Mc => {
                let d = km_montecarlo::McOptions::default();
                MethodOptions::Mc(km_montecarlo::McOptions {
                    samples: self.count("samples").unwrap_or(d.samples),
                    seed: self.count("seed").unwrap_or(d.seed),
                    threads: usize_of("threads"),
                    estimator: match self.choice("estimator") {
                        "analog" => km_montecarlo::Estimator::Analog,
                        _ => km_montecarlo::Estimator::SurvivalBiasing,
                    },
                    all_effects,
                    ..d
                })
            }
            Dipole => MethodOptions::Dipole(km_dipole::DipoleOptions {
                fdr: match self.choice("fdr") {
                    "egan-hilgeman" => km_dipole::FdrModel::EganHilgeman,
                    _ => km_dipole::FdrModel::Exact,
                },
                model: match self.choice("dipole") {
                    "better" => km_dipole::DipoleModel::Better,
                    _ => km_dipole::DipoleModel::Jensen2001,
                },
            }),
        };
        let options = Options {
            method,
            tolerance: self.real("tolerance"),
            all_effects,
            cone_deg: self.real("cone"),
            budget: 1.0,
            cancel: None,
        };
        match self.get("budget") {
            Some(Value::Real(f)) => options.with_budget(*f),
            _ => Ok(options),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every default parses as its own setting's value, every conflict names
    /// a setting of the table (both ways), every setting applies to a method.
    #[test]
    fn the_table_is_consistent() {
        for s in SETTINGS {
            if let Some(d) = s.default {
                s.parse(d).unwrap_or_else(|e| panic!("{}: default {d}: {e}", s.name));
            }
            assert!(!s.methods.is_empty(), "{}", s.name);
            for c in s.conflicts {
                let other = setting(c).unwrap_or_else(|| panic!("{} conflicts with {c}", s.name));
                assert!(other.conflicts.contains(&s.name), "{c} must exclude {} too", s.name);
            }
        }
    }

    /// The options of the defaults are the libraries' own defaults.
    #[test]
    fn defaults_are_the_libraries_defaults() {
        let mc = Settings::new(Mc).options().unwrap();
        let MethodOptions::Mc(o) = mc.method else { panic!() };
        let d = km_montecarlo::McOptions::default();
        assert_eq!(
            (o.samples, o.seed, o.threads, o.estimator),
            (d.samples, d.seed, None, d.estimator)
        );
        let MethodOptions::Multiflux(o) = Settings::new(Mf).options().unwrap().method else {
            panic!()
        };
        assert_eq!(o, km_multiflux::MultifluxOptions::default());
        let MethodOptions::DirectionSet(o) = Settings::new(Ds).options().unwrap().method else {
            panic!()
        };
        assert_eq!(o.directions, crate::direction_set::DEFAULT_DIRECTIONS);
        let MethodOptions::Km(o) = Settings::new(Km).options().unwrap().method else { panic!() };
        assert_eq!(o, km_core::two_flux::KmOptions::default());
    }

    /// Each refusal names the setting and says why.
    #[test]
    fn refusals_name_the_setting() {
        type Case = (Method, &'static [(&'static str, &'static str)], &'static str);
        let cases: &[Case] = &[
            (Km, &[("streams", "8")], "does not apply to method km"),
            (Mf, &[("streams", "0")], "1..=512"),
            (Mf, &[("streams", "8"), ("tolerance", "1e-4")], "not both"),
            (Mc, &[("samples", "x")], "whole number"),
            (Mc, &[("shard", "4/4")], "0 <= I < N"),
            (Mc, &[("estimator", "implicit")], "survival, analog"),
            (Mf, &[("budget", "-1")], "> 0"),
            (Mf, &[("bogus", "1")], "unknown setting"),
            (Mf, &[("order", "2"), ("order", "3")], "given twice"),
            (Km, &[("km_model", "six-flux")], "four-flux, two-flux"),
            (Km, &[("cone", "5")], "does not apply to method km"),
            (Mc, &[("cone", "50")], "<= 45"),
        ];
        for (method, sets, words) in cases {
            let mut s = Settings::new(*method);
            let e = sets.iter().try_for_each(|(n, v)| s.set_text(n, v)).unwrap_err().to_string();
            assert!(e.contains(words), "{sets:?}: {e}");
            assert!(e.contains(sets.last().unwrap().0), "{sets:?}: {e}");
        }
    }

    /// A help line names the methods that read its setting in brackets
    /// (`[multiflux, mc]`), exactly those, in any order; a setting every
    /// method reads names none.
    #[test]
    fn help_lines_name_the_methods() {
        let names: Vec<&str> = ALL.iter().map(|m| m.name()).collect();
        for s in SETTINGS {
            let tags: Vec<Vec<&str>> = s
                .help
                .split('[')
                .skip(1)
                .filter_map(|t| t.split_once(']'))
                .map(|(t, _)| t.split(", ").collect::<Vec<_>>())
                .filter(|t| t.iter().all(|n| names.contains(n)))
                .collect();
            if s.methods == ALL {
                assert!(tags.is_empty(), "{}: {tags:?}", s.name);
                continue;
            }
            assert_eq!(tags.len(), 1, "{}: {}", s.name, s.help);
            let mut got = tags[0].clone();
            let mut want: Vec<&str> = s.methods.iter().map(|m| m.name()).collect();
            got.sort();
            want.sort();
            assert_eq!(got, want, "{}", s.name);
        }
    }

    /// The settings of a command line are read as the same values as
    /// [`Settings::set_text`] reads them, with the range left to the
    /// method's options; a shard is checked where it is read.
    #[test]
    fn command_line_settings_read_as_set_text() {
        let given = [("samples", "2000".to_string()), ("estimator", "analog".into())];
        let flags = Settings::from_flags(Mc, &given).unwrap();
        let mut text = Settings::new(Mc);
        given.iter().for_each(|(n, v)| text.set_text(n, v).unwrap());
        let debug = |s: &Settings| format!("{:?}", s.options().unwrap());
        assert_eq!(debug(&flags), debug(&text));
        // Out of range: refused by set_text, left to the options by from_flags.
        let zero = [("samples", "0".to_string())];
        assert!(Settings::new(Mc).set_text("samples", "0").is_err());
        assert_eq!(Settings::from_flags(Mc, &zero).unwrap().get("samples"), Some(&Value::Count(0)));
        for (shard, words) in
            [("3/2", "need 0 <= I < N"), ("1/2x", "N is not a number"), ("1", "I/N")]
        {
            let e = Settings::from_flags(Mc, &[("shard", shard.into())]).unwrap_err().to_string();
            assert!(e.contains(words), "{shard}: {e}");
        }
        assert!(Settings::from_flags(Mc, &[("bogus", "1".into())]).is_err());
    }
}
