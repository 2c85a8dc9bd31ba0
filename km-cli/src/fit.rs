//! `km fit`: optical properties from measurements. Two inverses behind one
//! command: the slab inverse of Prahl's iad (`--m-r`, `--m-t`, `[--m-u]`, or
//! a spectrum file; `docs/inverse.md`), and, with `--km`, the Kubelka–Munk
//! inverse of paint drawdowns (`docs/inverse-km.md`). The flags become a
//! `km_inverse::request::FitRequest`, which checks, fits and writes the
//! answer; the hiding curves are drawn by `km_plot::fit`.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use km_inverse::request::{FIT_OPTIONS, FitRequest, Mode, check_options};

use crate::stdout;

// The flags of `km fit`: the request's (`km_inverse::request::FitRequest`)
// and how the answer is shown (no doc comment: it would become the command's about).
#[derive(Args, Debug, Clone)]
#[command(after_help = help!("fit"))]
pub struct FitArgs {
    #[command(flatten)]
    pub request: FitRequest,
    /// Print JSON (one object, or a list for a spectrum file).
    #[arg(long)]
    pub json: bool,
    /// --km: also draw the fitted film's hiding curves into this directory (SVG and PNG).
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// The `km fit` command with its flags in the order of the help: the
/// output flags among the request's, `--budget` after `--plot`.
pub fn help_order(fit: clap::Command) -> clap::Command {
    let fit = km::settings::command_line::place_after(fit, "streams", "json");
    let fit = km::settings::command_line::place_after(fit, "r_black_ground", "plot");
    km::settings::command_line::place_after(fit, "plot", "budget")
}

/// `km fit`: the answer printed (and with `--km --plot`, the hiding curves drawn).
pub fn run(args: &FitArgs) -> Result<()> {
    if args.plot.is_some() && !args.request.km {
        anyhow::bail!("--plot applies to --km only");
    }
    let answer = args.request.run()?;
    if let (Some(dir), Some(fit)) = (&args.plot, &answer.drawdown) {
        km_plot::fit::write_hiding_curves(fit, dir)?;
    }
    if args.json {
        stdout::print_json(&answer.json)?;
    } else {
        stdout::print(&answer.text)?;
    }
    answer.failure.map_or(Ok(()), |e| Err(e.into()))
}

/// Refuse a flag of `km fit` that does not apply to its mode (`--km`, the
/// slab inverse of `--m-r`/`--m-t`, an `.rxt` or a `.csv` file), naming
/// the mode (`km_inverse::request::check_options`).
pub fn check_flags(matches: &clap::ArgMatches) -> Result<()> {
    let Some(("fit", m)) = matches.subcommand() else { return Ok(()) };
    let given = km::settings::command_line::given_flag(m);
    let file = m.try_get_one::<PathBuf>("file").ok().flatten();
    debug_assert!(FIT_OPTIONS.iter().all(|(id, _)| m.try_get_raw(id).is_ok()));
    Ok(check_options(Mode::of(given("km"), file.map(PathBuf::as_path)), given)?)
}
