//! `km mc FILE.mci`: every run of an MCML input file, traced by km's Monte
//! Carlo, written as MCML's ASCII output (`.mco`) and as numpy arrays
//! (`.npz`, with standard errors, `km::mcml_files`) — docs/mcml.md.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use km::McOptions;
use km::mcml::{parse_mci, run_mci};
use km::mcml_files::{npz_bytes, out_paths};

/// Largest `.mci` file read, bytes.
const MAX_MCI_BYTES: u64 = 16 << 20;

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

/// Run `km mc`.
pub fn run(args: &McArgs) -> Result<()> {
    let shown = args.input.display().to_string();
    let text = km::read_scene_text(&args.input, MAX_MCI_BYTES).with_context(|| shown.clone())?;
    let file = parse_mci(&text).with_context(|| shown.clone())?;
    if args.samples == Some(0) {
        bail!("--samples 0: need at least one photon");
    }
    // Every output path is checked before any run starts.
    let outs: Vec<(PathBuf, PathBuf)> = file
        .runs
        .iter()
        .map(|r| out_paths(&args.input, &args.out_dir, r))
        .collect::<Result<_, _>>()?;
    for (k, (run, (mco, npz))) in file.runs.iter().zip(&outs).enumerate() {
        let opts = McOptions {
            seed: args.seed.wrapping_add(k as u64),
            threads: args.threads,
            ..Default::default()
        };
        let (out, sol, g) = run_mci(run, args.samples, &opts)
            .with_context(|| format!("{shown}: run {} (line {})", k + 1, run.line))?;
        let photons = args.samples.unwrap_or(run.photons);
        let body = out.text(run, photons, sol.seconds);
        km::atomic_file::write_atomic(mco, body.as_bytes())
            .with_context(|| format!("cannot write {}", mco.display()))?;
        if !args.no_npz {
            km::atomic_file::write_atomic(npz, &npz_bytes(run, &out, &g))
                .with_context(|| format!("cannot write {}", npz.display()))?;
        }
        crate::stdout::eprint(&format!(
            "run {}: {photons} photons in {:.1} s: Rsp {:.6} Rd {:.6} ± {:.1e} A {:.6} Tt {:.6} \
             ± {:.1e} -> {}\n",
            k + 1,
            sol.seconds,
            out.rsp,
            out.rd[0],
            out.rd[1],
            out.a[0],
            out.tt[0],
            out.tt[1],
            mco.display()
        ))?;
    }
    Ok(())
}
