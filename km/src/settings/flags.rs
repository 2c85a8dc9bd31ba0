//! The settings given on a command line, checked against the command and the
//! method before anything runs (`km solve`, `km sweep`, `km profile`), and
//! the library's refusals in the words of the flags that caused them.

use crate::{KmError, Method};

use super::SETTINGS;

/// The flag of setting or option `id` (`_` written `-`).
fn flag(id: &str) -> String {
    format!("--{}", id.replace('_', "-"))
}

/// Refuse a flag of `command` that was `given` (by its id: the setting's
/// name, or `json`, `format`) and does not apply to `method` (which a
/// command-line parser cannot know before parsing) or to the command, or
/// that excludes another one given, saying why. `method` is the one given
/// (`None`: the command's default).
///
/// # Errors
/// The refusal, naming the flags (`--name`).
pub fn refuse_flags(
    command: &str,
    method: Option<Method>,
    given: impl Fn(&str) -> bool,
) -> Result<(), String> {
    match command {
        "solve" | "sweep" => {
            refuse_solve_flags(command, method.unwrap_or(Method::Multiflux), given)
        }
        "profile" => {
            let method = method.unwrap_or(Method::Dipole);
            let mc_only = ["samples", "seed"].into_iter().find(|id| given(id));
            match mc_only.filter(|_| method != Method::Mc) {
                Some(id) => Err(format!(
                    "{} does not apply to --method {}: it sets the Monte Carlo run (--method mc)",
                    flag(id),
                    method.name()
                )),
                None => Ok(()),
            }
        }
        _ => Ok(()),
    }
}

/// [`refuse_flags`] of `km solve` and `km sweep`.
fn refuse_solve_flags(
    command: &str,
    method: Method,
    given: impl Fn(&str) -> bool,
) -> Result<(), String> {
    for s in SETTINGS {
        if given(s.name) && !s.applies_to(method) {
            let names: Vec<_> = s.methods.iter().map(|x| x.name()).collect();
            return Err(format!(
                "{} does not apply to --method {}: it sets {} (--method {})",
                flag(s.name),
                method.name(),
                s.sets,
                names.join(" or ")
            ));
        }
    }
    // A sweep prints its rows: no shard, no timing of repeated solves.
    let once = ["shard", "repeat"].into_iter().find(|id| given(id));
    if let Some(id) = once.filter(|_| command == "sweep") {
        return Err(format!("{} applies to km solve, not to km sweep", flag(id)));
    }
    if given("shard") && (given("json") || given("format")) {
        return Err("--shard writes its partial tally to --out and prints no result: --json and \
                    --format apply to `km merge` and to whole runs"
            .into());
    }
    if given("tolerance") && given("samples") {
        return Err(
            "give either --samples or --tolerance: the target chooses the photon count".into()
        );
    }
    if given("tolerance") && given("streams") {
        return Err("give either --streams or --tolerance, not both".into());
    }
    if given("repeat") && given("shard") {
        return Err("--repeat does not combine with --shard (a shard is written once)".into());
    }
    if given("tolerance") && given("shard") {
        return Err("--tolerance does not combine with --shard (every shard would choose its own \
                    photon count): run a pilot `km solve SCENE --method mc --tolerance T --json`, \
                    read the sample count it chose (`tolerance.samples` of the JSON), then shard \
                    with `--samples N --shard I/K --out FILE` and `km merge`"
            .into());
    }
    Ok(())
}

/// A library refusal in the words of the flags that caused it.
#[derive(Debug, thiserror::Error)]
pub enum FlagError {
    /// `FLAG: REFUSAL`: the refusal after the flag it concerns.
    #[error("{flag}")]
    After {
        /// The flag and its value (`--tolerance 0.001`, `--method mc`).
        flag: String,
        /// The refusal.
        #[source]
        source: KmError,
    },
    /// `--NAME VALUE: REASON`: an invalid option in the words of its flag.
    #[error("{0}")]
    Option(String),
    /// A refusal no flag caused, unchanged.
    #[error(transparent)]
    Km(#[from] KmError),
}

impl FlagError {
    /// `e` after the flag `flag`.
    pub fn after(flag: String, e: KmError) -> FlagError {
        FlagError::After { flag, source: e }
    }
}

/// An invalid option or setting ([`KmError::Option`], [`KmError::Setting`])
/// in the words of its flag:
/// `--NAME VALUE: REASON`; any other refusal unchanged.
pub fn option_flag(e: KmError) -> FlagError {
    match e {
        KmError::Option { name, value, reason } => {
            FlagError::Option(format!("--{} {value}: {reason}", name.replace('_', "-")))
        }
        KmError::Setting { name, value, reason } => {
            FlagError::Option(format!("--{} {value}: {reason}", name.replace('_', "-")))
        }
        e => FlagError::Km(e),
    }
}

/// A refusal by `method` in the words of the flags: an invalid option as
/// [`option_flag`] words it, any other refusal after `--method M` (`km
/// profile`, `km plan`).
pub fn method_flag_error(e: KmError, method: Method) -> FlagError {
    match e {
        e @ (KmError::Option { .. } | KmError::Setting { .. }) => option_flag(e),
        e => FlagError::after(format!("--method {}", method.name()), e),
    }
}

/// A refusal of a solve in the words of the flags that caused it
/// (`--tolerance` when `tolerance` was given, `--directions`, `--cone`,
/// `--method`).
pub fn solve_flag_error(e: KmError, method: Method, tolerance: Option<f64>) -> FlagError {
    match (&e, tolerance) {
        (
            KmError::NoAccuracySetting { .. }
            | KmError::TargetUnreachable { .. }
            | KmError::TargetOverBudget { .. }
            | KmError::Option { name: "accuracy target", .. },
            Some(t),
        ) => FlagError::after(format!("--tolerance {t}"), e),
        (KmError::Option { name: "directions" | "cone", .. }, _) => option_flag(e),
        (KmError::Unsupported(_), _) => FlagError::after(format!("--method {}", method.name()), e),
        _ => FlagError::Km(e),
    }
}
