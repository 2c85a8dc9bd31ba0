//! The settings as command-line flags (feature `clap`): one [`clap::Arg`]
//! per setting of [`SETTINGS`], made from the table (`--name` with `_`
//! written `-`, its help line, default, value name and choices), and the
//! settings given on a command line read back as text for
//! [`Settings::from_flags`](super::Settings::from_flags).
//!
//! The parser checks each value's type (a whole number, a number, one of
//! the choices; a shard is text), and the range of a count every method
//! reads (`repeat`), which no method's options see; the other ranges are
//! checked by the options of the method that reads the setting, in its words.

use clap::builder::{PossibleValue, PossibleValuesParser};
use clap::parser::ValueSource;
use clap::{Arg, ArgAction, ArgMatches, ValueEnum};

use super::{ALL, Kind, SETTINGS, Setting};

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
