//! The files of an MCML run (`km mc`, docs/mcml.md): an input file run by
//! run ([`McFile`]), where a run's `.mco` and `.npz` go ([`out_paths`], refusing to write outside the output
//! directory, over the input or over another kind of file) and the `.npz`
//! of its arrays with their standard errors ([`npz_bytes`]).

use std::path::{Path, PathBuf};

use km_montecarlo::mcml::{MciFile, MciRun, Mco, parse_mci, run_mci};
use km_montecarlo::{GridResult, McOptions};
use km_multiflux::bsdf::write::{npy, zip_stored};

/// Largest `.mci` file read, bytes.
const MAX_MCI_BYTES: u64 = 16 << 20;

/// A failure of [`McFile`]: what it concerns (the file, the run, the
/// output), and why.
#[derive(Debug, thiserror::Error)]
#[error("{context}")]
pub struct McFileError {
    context: String,
    #[source]
    source: Option<Box<dyn std::error::Error + Send + Sync>>,
}

impl McFileError {
    fn new(context: String, source: impl std::error::Error + Send + Sync + 'static) -> Self {
        McFileError { context, source: Some(Box::new(source)) }
    }
}

/// How to run an MCML input file (with the feature `clap`, `km mc`'s flags).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct McFileOptions {
    /// Photons per run instead of each run's count (at least 1).
    #[cfg_attr(feature = "clap", arg(long, help = "Photons per run, instead of each run's count"))]
    pub samples: Option<u64>,
    /// Seed of the runs (run k uses seed + k).
    #[cfg_attr(
        feature = "clap",
        arg(long, default_value_t = 1, help = "Seed of the runs (run k uses seed + k)")
    )]
    pub seed: u64,
    /// Worker threads (`None`: all cores); never changes the result.
    #[cfg_attr(
        feature = "clap",
        arg(long, help = "Worker threads (default: all cores); never changes the result")
    )]
    pub threads: Option<usize>,
    /// Directory of the output files.
    #[cfg_attr(
        feature = "clap",
        arg(
            long,
            default_value = ".",
            help = "Directory of the output files (default: the current directory, as MCML)"
        )
    )]
    pub out_dir: PathBuf,
    /// Write the `.npz` beside each `.mco`.
    #[cfg_attr(feature = "clap", arg(long = "no-npz", action = clap::ArgAction::SetFalse, help = "Write only the `.mco` files, no `.npz`"))]
    pub npz: bool,
}

/// An MCML input file read and checked, its output paths checked, ready to run.
#[derive(Debug)]
pub struct McFile {
    input: PathBuf,
    file: MciFile,
    outs: Vec<(PathBuf, PathBuf)>,
    opts: McFileOptions,
}

impl McFile {
    /// Read and parse `input` (at most 16 MiB) and check every output path
    /// ([`out_paths`]) before any run starts.
    ///
    /// # Errors
    /// An unreadable or malformed file (after its name), `samples` 0, and
    /// the refusals of [`out_paths`].
    pub fn open(input: &Path, opts: &McFileOptions) -> Result<McFile, McFileError> {
        let shown = input.display().to_string();
        let text = crate::read_scene_text(input, MAX_MCI_BYTES)
            .map_err(|e| McFileError::new(shown.clone(), e))?;
        let file = parse_mci(&text).map_err(|e| McFileError::new(shown.clone(), e))?;
        if opts.samples == Some(0) {
            let context = "--samples 0: need at least one photon".into();
            return Err(McFileError { context, source: None });
        }
        let outs = file
            .runs
            .iter()
            .map(|r| out_paths(input, &opts.out_dir, r))
            .collect::<Result<_, _>>()
            .map_err(|e| McFileError { context: e.to_string(), source: None })?;
        Ok(McFile { input: input.to_path_buf(), file, outs, opts: opts.clone() })
    }

    /// The number of runs.
    pub fn runs(&self) -> usize {
        self.file.runs.len()
    }

    /// Run `k` (0-based), write its files, and return its summary line.
    ///
    /// # Errors
    /// A run that fails (naming the file, the run and its line) and a file
    /// that cannot be written.
    pub fn run(&self, k: usize) -> Result<String, McFileError> {
        let (run, (mco, npz)) = (&self.file.runs[k], &self.outs[k]);
        let o = &self.opts;
        let mc = McOptions {
            seed: o.seed.wrapping_add(k as u64),
            threads: o.threads,
            ..Default::default()
        };
        let (out, sol, g) = run_mci(run, o.samples, &mc).map_err(|e| {
            let shown = self.input.display();
            McFileError::new(format!("{shown}: run {} (line {})", k + 1, run.line), e)
        })?;
        let photons = o.samples.unwrap_or(run.photons);
        let write = |p: &Path, bytes: &[u8]| {
            km_core::atomic_file::write_atomic(p, bytes)
                .map_err(|e| McFileError::new(format!("cannot write {}", p.display()), e))
        };
        write(mco, out.text(run, photons, sol.seconds).as_bytes())?;
        if o.npz {
            write(npz, &npz_bytes(run, &out, &g))?;
        }
        Ok(format!(
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
        ))
    }
}

/// The `.mco` and `.npz` paths of a run: its output name under `--out-dir`;
/// refused when absolute or climbing out (`..`), when it is the input file,
/// or when an existing file there is not an `.mco` (or `.npz`) one.
///
/// # Errors
/// Those refusals, as `std::io::Error`s of kind `Other`.
pub fn out_paths(
    input: &Path,
    out_dir: &Path,
    run: &MciRun,
) -> std::io::Result<(PathBuf, PathBuf)> {
    let bail = |m: String| Err(std::io::Error::other(m));
    let name = Path::new(&run.out_name);
    let climbs = name.components().any(|c| !matches!(c, std::path::Component::Normal(_)));
    if climbs {
        return bail(format!(
            "{}: line {}: output file name {:?} must be a relative path below --out-dir",
            input.display(),
            run.line,
            run.out_name
        ));
    }
    let mco = out_dir.join(name);
    let npz = mco.with_extension("npz");
    let input = std::fs::canonicalize(input).ok();
    for (p, magic) in [(&mco, &b"A1"[..]), (&npz, &b"PK"[..])] {
        if std::fs::canonicalize(p).ok().is_some_and(|c| Some(c) == input) {
            let p = p.display();
            return bail(format!("{p}: the output of line {} is the input file itself", run.line));
        }
        if p.exists() && !starts_with(p, magic) {
            return bail(format!(
                "{}: exists and is not an {} file: not overwritten",
                p.display(),
                if magic == b"A1" { "MCML output (.mco)" } else { "npz" }
            ));
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
pub fn npz_bytes(run: &MciRun, m: &Mco, g: &GridResult) -> Vec<u8> {
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
