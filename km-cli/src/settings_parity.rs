//! The flags of `km solve` against the one table of settings
//! ([`km::settings::SETTINGS`]): every setting is a flag of the same name,
//! default and choices, and every flag of `km solve` that is a setting of
//! the solve is in the table. Fails when a setting is added to one and not
//! the other, or when a default or a choice differs.

use clap::{Args, Command};
use km::settings::{Kind, SETTINGS};

use crate::solve::SolveArgs;

/// Flags of `km solve` that are not settings of the solve: the scene and its
/// edits, the method, and where and how the answer is written (the colour
/// of a spectrum and its swatch included).
const NOT_SETTINGS: &[&str] =
    &["scene", "set", "method", "json", "format", "out", "quiet", "help", "colour", "swatch"];

#[test]
fn every_setting_is_a_flag_with_its_default_and_choices() {
    let cmd = SolveArgs::augment_args(Command::new("solve"));
    for s in SETTINGS {
        let arg = cmd
            .get_arguments()
            .find(|a| a.get_id().as_str() == s.name)
            .unwrap_or_else(|| panic!("setting {} has no flag in km solve", s.name));
        assert_eq!(arg.get_long(), Some(s.name.replace('_', "-").as_str()), "{}", s.name);
        let defaults: Vec<String> =
            arg.get_default_values().iter().map(|v| v.to_string_lossy().into_owned()).collect();
        if s.kind == Kind::Flag {
            // A flag is off unless given.
            assert!(matches!(arg.get_action(), clap::ArgAction::SetTrue), "--{}", s.name);
            assert_eq!(s.default, Some("false"), "default of --{}", s.name);
            continue;
        }
        let want: Vec<String> = s.default.iter().map(|d| d.to_string()).collect();
        assert_eq!(defaults, want, "default of --{}", s.name);
        if let Kind::Choice(names) = s.kind {
            let mut got: Vec<String> =
                arg.get_possible_values().iter().map(|v| v.get_name().to_string()).collect();
            let mut want: Vec<String> = names.iter().map(|n| n.to_string()).collect();
            got.sort();
            want.sort();
            assert_eq!(got, want, "choices of --{}", s.name);
        }
    }
    for arg in cmd.get_arguments() {
        let id = arg.get_id().as_str();
        assert!(
            NOT_SETTINGS.contains(&id) || SETTINGS.iter().any(|s| s.name == id),
            "km solve --{id} is not in km::settings::SETTINGS"
        );
    }
}

/// The options of a `km solve` command line are those the same settings
/// give through `Settings::set_text` (the path of Python's keyword
/// arguments): the flags and the keyword arguments reach the library alike.
#[test]
fn flags_give_the_options_of_the_same_settings() {
    use clap::FromArgMatches;
    use km::settings::Settings;
    let cases: &[(&str, &[(&str, &str)])] = &[
        ("mc", &[("samples", "5000"), ("seed", "7"), ("threads", "2"), ("estimator", "analog")]),
        ("mc", &[("cone", "10"), ("all_effects", "true"), ("budget", "2")]),
        ("multiflux", &[("streams", "8"), ("order", "3")]),
        ("multiflux", &[("tolerance", "0.001"), ("cone", "5")]),
        ("km", &[("km_mapping", "seed"), ("km_model", "two-flux")]),
        ("direction-set", &[("directions", "50")]),
        ("dipole", &[("fdr", "egan-hilgeman"), ("dipole", "better")]),
    ];
    for (method, sets) in cases {
        let mut argv = vec!["solve".to_string(), "-".into(), "--method".into(), method.to_string()];
        for (name, value) in *sets {
            argv.push(format!("--{}", name.replace('_', "-")));
            if *name != "all_effects" {
                argv.push(value.to_string());
            }
        }
        let m = SolveArgs::augment_args(Command::new("solve")).get_matches_from(&argv);
        let args = SolveArgs::from_arg_matches(&m).unwrap();
        let flags = args.settings.options(&args.settings.settings(args.method).unwrap()).unwrap();
        let mut text = Settings::new(args.method);
        sets.iter().for_each(|(n, v)| text.set_text(n, v).unwrap());
        let text = text.options().unwrap();
        assert_eq!(format!("{flags:?}"), format!("{text:?}"), "{argv:?}");
    }
}

/// `km reproduce --only`'s help names every recipe of the bench, and no
/// other: fails when a recipe is added to (or removed from) the bench and
/// not the help.
#[test]
fn reproduce_only_names_every_recipe() {
    let cmd = km_bench::ReproduceRequest::augment_args(Command::new("reproduce"));
    let only = cmd.get_arguments().find(|a| a.get_id() == "only").expect("--only");
    let help = only.get_help().expect("help of --only").to_string();
    let listed = help.split_once('(').and_then(|(_, r)| r.split_once(')')).expect("a list").0;
    let mut listed: Vec<&str> = listed.split(',').map(str::trim).collect();
    let mut names = km_bench::recipe_names();
    listed.sort_unstable();
    names.sort_unstable();
    assert_eq!(listed, names);
}
