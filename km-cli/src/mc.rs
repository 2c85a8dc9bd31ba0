//! `km mc FILE.mci`: every run of an MCML input file, traced by km's Monte
//! Carlo, written as MCML's ASCII output (`.mco`) and as numpy arrays
//! (`.npz`, with standard errors) — docs/mcml.md.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use km::McOptions;
use km::mcml::{MciRun, Mco, parse_mci, run_mci};

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
    let outs: Vec<(PathBuf, PathBuf)> =
        file.runs.iter().map(|r| out_paths(args, r)).collect::<Result<_>>()?;
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

/// The `.mco` and `.npz` paths of a run: its output name under `--out-dir`;
/// refused when absolute or climbing out (`..`), when it is the input file,
/// or when an existing file there is not an `.mco` (or `.npz`) one.
fn out_paths(args: &McArgs, run: &MciRun) -> Result<(PathBuf, PathBuf)> {
    let name = Path::new(&run.out_name);
    let climbs = name.components().any(|c| !matches!(c, std::path::Component::Normal(_)));
    if climbs {
        bail!(
            "{}: line {}: output file name {:?} must be a relative path below --out-dir",
            args.input.display(),
            run.line,
            run.out_name
        );
    }
    let mco = args.out_dir.join(name);
    let npz = mco.with_extension("npz");
    let input = std::fs::canonicalize(&args.input).ok();
    for (p, magic) in [(&mco, &b"A1"[..]), (&npz, &b"PK"[..])] {
        if std::fs::canonicalize(p).ok().is_some_and(|c| Some(c) == input) {
            bail!("{}: the output of line {} is the input file itself", p.display(), run.line);
        }
        if p.exists() && !starts_with(p, magic) {
            bail!(
                "{}: exists and is not an {} file: not overwritten",
                p.display(),
                if magic == b"A1" { "MCML output (.mco)" } else { "npz" }
            );
        }
    }
    Ok((mco, npz))
}

fn starts_with(p: &Path, magic: &[u8]) -> bool {
    use std::io::Read;
    let mut head = vec![0u8; magic.len()];
    std::fs::File::open(p).and_then(|mut f| f.read_exact(&mut head)).is_ok() && head == magic
}

/// An array and its standard errors.
type Pair = [Vec<f64>; 2];

/// The `.npz` of a run: MCML's arrays and their standard errors (`_se`),
/// the bin centres, `phi_z` and `flux_z` (docs/mcml.md).
fn npz_bytes(run: &MciRun, m: &Mco, g: &km::GridResult) -> Vec<u8> {
    use km::bsdf::write::{npy, zip_stored};
    let f64s = |v: &[f64]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let (nz, nr, na) = (run.nz, run.nr, run.na);
    let da = g.grid.da();
    let mut e: Vec<(String, Vec<u8>)> = Vec::new();
    let mut put = |name: &str, shape: &[usize], v: &[f64]| {
        e.push((format!("{name}.npy"), npy("<f8", shape, &f64s(v))));
    };
    put("z", &[nz], &(0..nz).map(|i| (i as f64 + 0.5) * run.dz).collect::<Vec<_>>());
    put("r", &[nr], &(0..nr).map(|i| (i as f64 + 0.5) * run.dr).collect::<Vec<_>>());
    put("alpha", &[na], &(0..na).map(|i| (i as f64 + 0.5) * da).collect::<Vec<_>>());
    put("rat", &[4], &[m.rsp, m.rd[0], m.a[0], m.tt[0]]);
    put("rat_se", &[4], &[0.0, m.rd[1], m.a[1], m.tt[1]]);
    let arrays: [(&str, &Pair, Vec<usize>); 9] = [
        ("a_l", &m.a_l, vec![run.layers.len()]),
        ("a_z", &m.a_z, vec![nz]),
        ("rd_r", &m.rd_r, vec![nr]),
        ("rd_a", &m.rd_a, vec![na]),
        ("tt_r", &m.tt_r, vec![nr]),
        ("tt_a", &m.tt_a, vec![na]),
        ("a_rz", &m.a_rz, vec![nr, nz]),
        ("rd_ra", &m.rd_ra, vec![nr, na]),
        ("tt_ra", &m.tt_ra, vec![nr, na]),
    ];
    for (name, [v, se], shape) in arrays {
        put(name, &shape, v);
        put(&format!("{name}_se"), &shape, se);
    }
    put("phi_z", &[nz + 1], &g.phi_z);
    put("phi_z_se", &[nz + 1], &g.phi_z_se);
    put("flux_z", &[nz + 1], &g.flux_z);
    put("flux_z_se", &[nz + 1], &g.flux_z_se);
    zip_stored(&e)
}
