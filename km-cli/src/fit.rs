//! `km fit`: optical properties from measurements (`docs/inverse.md`).
//!
//! Two inverses behind one command: the slab inverse of Prahl's iad
//! (`--m-r`, `--m-t`, `[--m-u]`, or a spectrum file), and, with `--km`, the
//! Kubelka–Munk inverse of paint drawdowns (`docs/inverse-km.md`).

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::Args;
use km_inverse::forward::Sample;
use km_inverse::rxt::{Row, parse_csv, parse_rxt};
use km_inverse::slab::{FitOptions, FitResult, Measurement, Setup};
use km_inverse::spectrum::{RowOverrides, fit_rows, rows_json};

/// Arguments of `km fit`.
#[derive(Args, Debug, Clone)]
#[command(after_help = "Examples:\n  \
km fit --m-r 0.2726 --m-t 0.2991 --thickness 1 --n-sample 1.4 --n-slide 1.5 --json\n  \
km fit --m-r 0.2726 --m-t 0.2991 --m-u 0.1244 --thickness 1 --n-sample 1.4 --n-slide 1.5\n  \
km fit examples/fit-phantom.rxt --json\n  \
km fit examples/fit-spectrum.csv --thickness 1 --n-sample 1.4 --json\n  \
km fit --km --r-black 0.3 --r-white 0.5 --r-white-ground 0.8 --thickness 0.05 --json")]
pub struct FitArgs {
    /// Spectrum file: iad's `.rxt` (sample and spheres from its header) or a
    /// `.csv` with columns wavelength_nm, m_r, m_t[, m_u, sigma_r, sigma_t, sigma_u, g].
    pub file: Option<PathBuf>,
    /// Measured total reflectance M_R (normal collimated light).
    #[arg(long = "m-r")]
    pub m_r: Option<f64>,
    /// Measured total transmittance M_T.
    #[arg(long = "m-t")]
    pub m_t: Option<f64>,
    /// Measured unscattered (collimated) transmittance M_U; g is then fitted unless --g is given.
    #[arg(long = "m-u")]
    pub m_u: Option<f64>,
    /// Standard uncertainty of M_R (default 1e-4, iad's tolerance).
    #[arg(long = "sigma-r")]
    pub sigma_r: Option<f64>,
    /// Standard uncertainty of M_T (default 1e-4).
    #[arg(long = "sigma-t")]
    pub sigma_t: Option<f64>,
    /// Standard uncertainty of M_U (default 1e-4).
    #[arg(long = "sigma-u")]
    pub sigma_u: Option<f64>,
    /// Sample thickness (mu_a, mu_s, mu_s' come out in its inverse unit).
    #[arg(long)]
    pub thickness: Option<f64>,
    /// Refractive index of the sample (default 1).
    #[arg(long = "n-sample")]
    pub n_sample: Option<f64>,
    /// Refractive index of clear glass slides on both faces (default: none).
    #[arg(long = "n-slide")]
    pub n_slide: Option<f64>,
    /// Fixed anisotropy g (default 0 without M_U; fitted with M_U).
    #[arg(long)]
    pub g: Option<f64>,
    /// Fraction of the specular reflection included in M_R (iad -c; default 1).
    #[arg(long = "specular-in-m-r", default_value_t = 1.0)]
    pub specular_in_m_r: f64,
    /// Fraction of the unscattered beam included in M_T (iad -C; default 1).
    #[arg(long = "unscattered-in-m-t", default_value_t = 1.0)]
    pub unscattered_in_m_t: f64,
    /// M_R excludes the specular reflection (same as --specular-in-m-r 0).
    #[arg(long = "exclude-specular")]
    pub exclude_specular: bool,
    /// M_T excludes the unscattered beam (same as --unscattered-in-m-t 0).
    #[arg(long = "exclude-unscattered")]
    pub exclude_unscattered: bool,
    /// Polar angle of the incident beam in degrees (default 0).
    #[arg(long, default_value_t = 0.0)]
    pub incidence: f64,
    /// Fixed stream count of the forward model (default: the rule of docs/inverse.md eq. I7).
    #[arg(long)]
    pub streams: Option<usize>,
    /// Print JSON (one object, or a list for a spectrum file).
    #[arg(long)]
    pub json: bool,
    /// Kubelka–Munk inverse of paint drawdowns instead of the slab inverse.
    #[arg(long)]
    pub km: bool,
    /// --km: reflectance of the film over the black ground.
    #[arg(long = "r-black")]
    pub r_black: Option<f64>,
    /// --km: reflectance of the film over the white ground.
    #[arg(long = "r-white")]
    pub r_white: Option<f64>,
    /// --km: reflectance of the white ground itself.
    #[arg(long = "r-white-ground")]
    pub r_white_ground: Option<f64>,
    /// --km: reflectance of the black ground itself (default 0: ideal black).
    #[arg(long = "r-black-ground")]
    pub r_black_ground: Option<f64>,
    /// --km: also draw the fitted film's hiding curves into this directory (SVG and PNG).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// --km: reflectance of an opaque (infinitely thick) film.
    #[arg(long = "r-inf")]
    pub r_inf: Option<f64>,
    /// --km: reflectance of the film over a black ground (R_0).
    #[arg(long = "r-zero")]
    pub r_zero: Option<f64>,
    /// --km: Saunderson k2 (internal diffuse reflectance of the surface).
    #[arg(long)]
    pub k2: Option<f64>,
}

impl FitArgs {
    /// The Kubelka–Munk inputs of `--km`.
    pub fn km_inputs(&self) -> crate::fit_km::KmFitInputs {
        crate::fit_km::KmFitInputs {
            r_black: self.r_black,
            r_white: self.r_white,
            r_white_ground: self.r_white_ground,
            r_black_ground: self.r_black_ground,
            r_inf: self.r_inf,
            r_zero: self.r_zero,
            thickness: self.thickness,
            k2: self.k2,
            n: self.n_sample,
        }
    }

    fn fractions(&self) -> (f64, f64) {
        let c = if self.exclude_specular { 0.0 } else { self.specular_in_m_r };
        let c_t = if self.exclude_unscattered { 0.0 } else { self.unscattered_in_m_t };
        (c, c_t)
    }

    /// The set-up from the flags (thickness required).
    fn setup(&self) -> anyhow::Result<Setup> {
        let Some(d) = self.thickness else {
            bail!(
                "--thickness is required (the sample's thickness, in the length unit of the answer)"
            );
        };
        let sample = Sample::new(d, self.n_sample.unwrap_or(1.0), self.n_slide)?
            .with_incidence(self.incidence)?;
        let (c, c_t) = self.fractions();
        Ok(Setup { specular_in_m_r: c, unscattered_in_m_t: c_t, ..Setup::new(sample) })
    }
}

/// Run `km fit`.
pub fn run(args: &FitArgs) -> anyhow::Result<()> {
    if args.km {
        return run_km(args);
    }
    let km_only = [
        args.r_black,
        args.r_white,
        args.r_white_ground,
        args.r_black_ground,
        args.r_inf,
        args.r_zero,
        args.k2,
    ];
    if km_only.iter().any(Option::is_some) {
        bail!(
            "--r-black, --r-white, --r-white-ground, --r-black-ground, --r-inf, --r-zero and \
             --k2 need --km"
        );
    }
    if args.plot.is_some() {
        bail!("--plot applies to --km only");
    }
    let opts = FitOptions { g: args.g, streams: args.streams };
    match &args.file {
        None => run_one(args, &opts),
        Some(path) => run_file(args, &opts, path),
    }
}

/// One measurement from `--m-r`, `--m-t` [`--m-u`].
fn run_one(args: &FitArgs, opts: &FitOptions) -> anyhow::Result<()> {
    let (Some(m_r), Some(m_t)) = (args.m_r, args.m_t) else {
        bail!("give --m-r and --m-t (or a measurement file)");
    };
    let meas = Measurement {
        m_r,
        m_t,
        m_u: args.m_u,
        sigma_r: args.sigma_r,
        sigma_t: args.sigma_t,
        sigma_u: args.sigma_u,
    };
    let r = km_inverse::fit(&args.setup()?, &meas, opts)?;
    if args.json {
        crate::stdout::print(&format!("{}\n", serde_json::to_string_pretty(&r.to_json())?))
    } else {
        crate::stdout::print(&table(&[(None, r)]))
    }
}

/// A spectrum file: every row fitted (`km_inverse::spectrum`), bad rows reported in place.
fn run_file(args: &FitArgs, opts: &FitOptions, path: &Path) -> anyhow::Result<()> {
    if args.m_r.is_some() || args.m_t.is_some() || args.m_u.is_some() {
        bail!("give either a measurement file or --m-r/--m-t/--m-u, not both");
    }
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_lowercase();
    let rows: Vec<Row> = match ext.as_str() {
        "rxt" => parse_rxt(&text),
        "csv" => parse_csv(&text, &args.setup()?),
        _ => bail!("{}: expected a .rxt or .csv file", path.display()),
    }
    .with_context(|| format!("{}", path.display()))?;
    // Flags that differ from the defaults override an .rxt file.
    let (c, c_t) = args.fractions();
    let over = RowOverrides {
        specular_in_m_r: (c != 1.0).then_some(c),
        unscattered_in_m_t: (c_t != 1.0).then_some(c_t),
        sigma_r: args.sigma_r,
        sigma_t: args.sigma_t,
        sigma_u: args.sigma_u,
    };
    let fits = fit_rows(&rows, &over, opts);
    if args.json {
        crate::stdout::print(&format!("{}\n", serde_json::to_string_pretty(&rows_json(&fits))?))?;
    } else {
        let ok: Vec<(Option<f64>, FitResult)> = fits
            .iter()
            .filter_map(|f| f.result.as_ref().ok().map(|r| (f.wavelength_nm, r.clone())))
            .collect();
        let mut out = table(&ok);
        for f in &fits {
            if let Err(e) = &f.result {
                let w = f.wavelength_nm.map_or("-".to_string(), |w| format!("{w:.1}"));
                out += &format!("{w:>9} invalid: {e}\n");
            }
        }
        crate::stdout::print(&out)?;
    }
    if fits.iter().all(|f| f.result.is_err()) {
        bail!("no row of {} could be fitted", path.display());
    }
    Ok(())
}

/// A plain-text table of results.
fn table(results: &[(Option<f64>, FitResult)]) -> String {
    let mut s = format!(
        "{:>9} {:>10} {:>11} {:>7} {:>11} {:>11} {:>11} {:>9} {:>9} {}\n",
        "lambda", "albedo", "tau", "g", "mu_a", "mu_s'", "u(mu_a)", "M_R fit", "M_T fit", "status"
    );
    for (w, r) in results {
        let w = w.map_or("-".to_string(), |w| format!("{w:.1}"));
        let flag = if r.uncertainty.ill_conditioned { " (ill-conditioned)" } else { "" };
        s += &format!(
            "{w:>9} {:>10.6} {:>11.5e} {:>7.4} {:>11.5e} {:>11.5e} {:>11.3e} {:>9.5} {:>9.5} {:?}{flag}\n",
            r.albedo,
            r.tau,
            r.g,
            r.mu_a,
            r.mu_s_prime,
            r.uncertainty.mu_a,
            r.fitted[0],
            r.fitted[1],
            r.status
        );
        for n in &r.notes {
            s += &format!("          note: {n}\n");
        }
    }
    s
}

/// `--km`: the Kubelka–Munk inverse (`docs/inverse-km.md`).
fn run_km(args: &FitArgs) -> anyhow::Result<()> {
    let inputs = args.km_inputs();
    if let Some(dir) = &args.plot {
        crate::fit_km::write_plot(&inputs, dir)?;
    }
    crate::fit_km::run(&inputs, args.json)
}
