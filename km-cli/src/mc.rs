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
    /// Photons per run, instead of each run's count.
    #[arg(long)]
    pub samples: Option<u64>,
    /// Seed of the runs (run k uses seed + k).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Worker threads (default: all cores); never changes the result.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Directory of the output files (default: the current directory, as MCML).
    #[arg(long, default_value = ".")]
    pub out_dir: PathBuf,
    /// Write only the `.mco` files, no `.npz`.
    #[arg(long)]
    pub no_npz: bool,
}

/// Run `km mc`: every run of the file (`km::mcml_files::McFile`), its summary on stderr.
pub fn run(args: &McArgs) -> Result<()> {
    let opts = McFileOptions {
        samples: args.samples,
        seed: args.seed,
        threads: args.threads,
        out_dir: args.out_dir.clone(),
        npz: !args.no_npz,
    };
    let file = McFile::open(&args.input, &opts)?;
    for k in 0..file.runs() {
        crate::stdout::eprint(&file.run(k)?)?;
    }
    Ok(())
}
