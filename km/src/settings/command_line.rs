//! The settings as command-line flags (feature `clap`): one [`clap::Arg`]
//! per setting of [`SETTINGS`], made from the table (`--name` with `_`
//! written `-`, its help line, default, value name and choices), the
//! settings given on a command line read back as text for
//! [`Settings::from_flags`], and [`SolveFlags`], the flags of a solve
//! (`km solve`, `km sweep`) from which its options are built.
//!
//! The parser checks each value's type (a whole number, a number, one of
//! the choices; a shard is text), and the range of a count every method
//! reads (`repeat`), which no method's options see; the other ranges are
//! checked by the options of the method that reads the setting, in its words.

use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use clap::parser::ValueSource;
use clap::{Arg, ArgAction, ArgMatches, Command, ValueEnum};

use super::{ALL, FlagError, Kind, SETTINGS, Setting, Settings, Value, option_flag};
use crate::{KmError, Method, Options};

/// The flags of a solve: every setting of [`SETTINGS`] and `--quiet` (no
/// progress bar, `crate::progress`); `clap::Args`, flattened into a command.
#[derive(Debug, Clone, Default)]
pub struct SolveFlags {
    /// The settings given, by name, as text.
    pub given: Vec<(&'static str, String)>,
    /// No progress bar on stderr.
    pub quiet: bool,
}

impl clap::FromArgMatches for SolveFlags {
    fn from_arg_matches(m: &ArgMatches) -> Result<Self, clap::Error> {
        Ok(SolveFlags { given: given(m), quiet: m.get_flag("quiet") })
    }

    fn update_from_arg_matches(&mut self, m: &ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(m)?;
        Ok(())
    }
}

impl clap::Args for SolveFlags {
    fn augment_args(cmd: Command) -> Command {
        let mut args = args();
        let quiet = Arg::new("quiet").long("quiet").action(ArgAction::SetTrue).help(
            "No progress bar on stderr (it is drawn only for a solve expected to last more \
             than 2 s, and never when stderr is not a terminal)",
        );
        // After the settings every method reads, before the dipole's.
        let at = args.iter().position(|a| a.get_id() == "fdr").unwrap_or(args.len());
        args.insert(at, quiet);
        cmd.args(args)
    }

    fn augment_args_for_update(cmd: Command) -> Command {
        Self::augment_args(cmd)
    }
}

impl SolveFlags {
    /// The settings given, for `method` ([`Settings::from_flags`]).
    ///
    /// # Errors
    /// A shard that is not `I/N` with `0 <= I < N`, in the words of `--shard`.
    pub fn settings(&self, method: Method) -> Result<Settings, Box<FlagError>> {
        Settings::from_flags(method, &self.given).map_err(|e| Box::new(option_flag(e)))
    }

    /// The library options of `settings` ([`Settings::options`]).
    ///
    /// # Errors
    /// No photon (`--samples 0`), and an invalid `--budget`, in the flags' words.
    pub fn options(&self, settings: &Settings) -> Result<Options, Box<FlagError>> {
        if settings.method() == Method::Mc && settings.get("samples") == Some(&Value::Count(0)) {
            return Err(Box::new(FlagError::Option("--samples must be at least 1".into())));
        }
        settings.options().map_err(|e| Box::new(option_flag(e)))
    }
}

#[cfg(feature = "progress")]
impl SolveFlags {
    /// Solve `scene` by `method` as these flags ask: their settings and
    /// options, `repeat` times ([`crate::solve_repeated`]), with a progress
    /// bar on stderr when it may be shown ([`crate::progress`]).
    ///
    /// # Errors
    /// The refusals of [`SolveFlags::settings`], [`SolveFlags::options`] and
    /// of the solve, in the flags' words ([`solve_error`]).
    pub fn solve(
        &self,
        scene: &crate::Scene,
        method: Method,
    ) -> Result<crate::Solution, Box<FlagError>> {
        let settings = self.settings(method)?;
        let mut opts = self.options(&settings)?;
        let _bar =
            crate::progress::wanted(self.quiet).then(|| crate::progress::attach(scene, &mut opts));
        crate::solve_repeated(scene, &opts, settings.repeat())
            .map_err(|e| Box::new(solve_error(e, &settings)))
    }

    /// Shard `i` of `n` of a Monte Carlo run of `scene` as these flags ask
    /// ([`crate::mc_shard`]), with a progress bar as [`SolveFlags::solve`].
    ///
    /// # Errors
    /// As [`SolveFlags::solve`].
    pub fn shard(
        &self,
        scene: &crate::Scene,
        settings: &Settings,
        (i, n): (u64, u64),
    ) -> Result<crate::Partial, Box<FlagError>> {
        let mut opts = self.options(settings)?;
        let _bar =
            crate::progress::wanted(self.quiet).then(|| crate::progress::attach(scene, &mut opts));
        crate::mc_shard(scene, &opts, i, n).map_err(|e| Box::new(FlagError::Km(e)))
    }
}

/// The flags given on the command line of `m` (not at their defaults), by
/// id: the `given` of [`super::refuse_flags`] and of `km fit`'s checks.
pub fn given_flag(m: &ArgMatches) -> impl Fn(&str) -> bool + '_ {
    |id| {
        matches!(m.try_get_raw(id), Ok(Some(_)))
            && m.value_source(id) == Some(ValueSource::CommandLine)
    }
}

/// Refuse a flag given to a subcommand of `matches` that does not apply to
/// the chosen method or mode (clap cannot know the method: checked after
/// parsing, by [`super::refuse_flags`]).
///
/// # Errors
/// The refusal's words, naming the flag and the method.
pub fn refuse_given_flags(matches: &ArgMatches) -> Result<(), String> {
    let Some((command, m)) = matches.subcommand() else { return Ok(()) };
    let method = m.try_get_one::<Method>("method").ok().flatten().copied();
    super::refuse_flags(command, method, given_flag(m))
}

/// `cmd` with its argument `id` shown in the help right after `after`.
pub fn place_after(cmd: Command, after: &str, id: &str) -> Command {
    let order = |c: &Command, id: &str| {
        c.get_arguments().find(|a| a.get_id() == id).map_or(0, Arg::get_display_order)
    };
    let at = order(&cmd, after);
    let ids: Vec<String> = cmd.get_arguments().map(|a| a.get_id().to_string()).collect();
    let mut cmd = cmd;
    for other in ids.iter().filter(|o| *o != id) {
        let o = order(&cmd, other);
        cmd = cmd.mut_arg(other, |a| a.display_order(if o > at { 2 * o + 2 } else { 2 * o }));
    }
    cmd.mut_arg(id, |a| a.display_order(2 * at + 1))
}

/// A refusal of a solve with `settings`, in the words of the flags that
/// caused it ([`super::solve_flag_error`]).
pub fn solve_error(e: KmError, settings: &Settings) -> FlagError {
    let tolerance = match settings.get("tolerance") {
        Some(Value::Real(t)) => Some(*t),
        _ => None,
    };
    super::solve_flag_error(e, settings.method(), tolerance)
}

/// The values of `--method`: the names of `methods`.
pub fn method_parser(methods: &[Method]) -> impl TypedValueParser<Value = Method> + use<> {
    PossibleValuesParser::new(methods.iter().map(|m| m.name())).try_map(|s| s.parse::<Method>())
}

/// The flag of every setting, in the table's order.
pub fn args() -> Vec<Arg> {
    SETTINGS.iter().map(arg).collect()
}

/// The flag of setting `s`.
fn arg(s: &Setting) -> Arg {
    let value_name = s.value_name.map_or_else(|| s.name.to_uppercase(), str::to_string);
    let a = Arg::new(s.name).long(s.name.replace('_', "-")).help(s.help);
    let a = match s.kind {
        Kind::Flag => return a.action(ArgAction::SetTrue),
        Kind::Count { min, max } if s.methods == ALL => {
            a.value_parser(clap::value_parser!(u64).range(min..=max))
        }
        Kind::Count { .. } => a.value_parser(clap::value_parser!(u64)),
        Kind::Real { .. } => a.value_parser(clap::value_parser!(f64)),
        Kind::Choice(_) => a.value_parser(PossibleValuesParser::new(choices(s.name))),
        Kind::Shard => a.value_parser(clap::value_parser!(String)),
    };
    let a = a.value_name(value_name);
    match s.default {
        Some(d) => a.default_value(d),
        None => a,
    }
}

/// The values of a choice with their help: those of the library's option
/// enum (whose names the table lists; km-cli's settings parity test checks
/// that they agree).
fn choices(name: &str) -> Vec<PossibleValue> {
    fn of<E: ValueEnum>() -> Vec<PossibleValue> {
        E::value_variants().iter().filter_map(ValueEnum::to_possible_value).collect()
    }
    match name {
        "km_mapping" => of::<crate::KmMapping>(),
        "km_model" => of::<crate::KmModel>(),
        "estimator" => of::<crate::Estimator>(),
        "fdr" => of::<crate::FdrModel>(),
        "dipole" => of::<crate::DipoleModel>(),
        _ => Vec::new(),
    }
}

/// The settings given on the command line of `m` (not their defaults), by
/// name, as text.
pub fn given(m: &ArgMatches) -> Vec<(&'static str, String)> {
    SETTINGS
        .iter()
        .filter(|s| m.value_source(s.name) == Some(ValueSource::CommandLine))
        .filter_map(|s| {
            let text = m.get_raw(s.name)?.next()?.to_string_lossy().into_owned();
            Some((s.name, text))
        })
        .collect()
}
