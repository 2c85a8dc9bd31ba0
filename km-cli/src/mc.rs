//! `km mc FILE.mci`: every run of an MCML input file, traced by km's Monte
//! Carlo, written as MCML's ASCII output (`.mco`) and as numpy arrays
//! (`.npz`, with standard errors, `km::mcml_files`) — docs/mcml.md.

use std::path::PathBuf;

use anyhow::Result;
use km::mcml_files::{McFile, McFileOptions};

/// The flags of `km mc`.
#[derive(clap::Args)]
pub struct McArgs {
    /// MCML input file (`.mci`).
    pub input: PathBuf,
    #[command(flatten)]
    pub options: McFileOptions,
}

/// Run `km mc`: every run of the file (`km::mcml_files::McFile`), its summary on stderr.
pub fn run(args: &McArgs) -> Result<()> {
    let file = McFile::open(&args.input, &args.options)?;
    for k in 0..file.runs() {
        crate::stdout::eprint(&file.run(k)?)?;
    }
    Ok(())
}
