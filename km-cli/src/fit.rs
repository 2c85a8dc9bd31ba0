//! `km fit`: optical properties from measurements. Two inverses behind one
//! command: the slab inverse of Prahl's iad (`--m-r`, `--m-t`, `[--m-u]`, or
//! a spectrum file; `docs/inverse.md`), and, with `--km`, the Kubelka–Munk
//! inverse of paint drawdowns (`docs/inverse-km.md`), whose inputs
//! `km_inverse::drawdown::DrawdownInputs` checks.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow, bail};
use clap::Args;
use km_inverse::drawdown::{DrawdownFit, DrawdownInputs, Input, InputError, hiding_curves};
use km_inverse::forward::Sample;
use km_inverse::reflectance::fit_reflectance;
use km_inverse::rxt::{parse_csv_within, parse_rxt_within};
use km_inverse::slab::{FitOptions, Measurement, Setup};
use km_inverse::spectrum::{RowFit, RowFixed, RowOverrides, check_fixed, fit_rows, rows_json};
use km_inverse::sphere::{Sphere, SphereSetup};
use km_inverse::text::{drawdown_report, fits_table};
use km_plot::chart::{LineChart, Mark, Series, write_chart};

use crate::stdout;

// The flags of `km fit` (no doc comment: it would become the command's about).
#[derive(Args, Debug, Clone)]
#[command(after_help = help!("fit"))]
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
    /// Integrating spheres used at a time (iad -S): 0 (the totals themselves, the default),
    /// 1 (substitution) or 2 (double sphere); 1 and 2 need --r-sphere.
    #[arg(long, value_parser = clap::value_parser!(u8).range(0..=2))]
    pub spheres: Option<u8>,
    /// The reflection sphere (iad -1): sphere, sample port, entrance port and detector port
    /// diameters (one length unit), and the wall reflectance.
    #[arg(long = "r-sphere", num_args = 5, allow_negative_numbers = true,
          value_names = ["D_SPHERE", "D_SAMPLE", "D_ENTRANCE", "D_DETECTOR", "R_WALL"])]
    pub r_sphere: Option<Vec<f64>>,
    /// The transmission sphere (iad -2): sphere, sample port, exit port and detector port
    /// diameters, and the wall reflectance (default: the same as --r-sphere).
    #[arg(long = "t-sphere", num_args = 5, allow_negative_numbers = true,
          value_names = ["D_SPHERE", "D_SAMPLE", "D_EXIT", "D_DETECTOR", "R_WALL"])]
    pub t_sphere: Option<Vec<f64>>,
    /// Reflectance of the reflection standard with spheres (the .rxt header's; default 1).
    #[arg(long = "r-std")]
    pub r_std: Option<f64>,
    /// Reflectance only (--m-r without --m-t, or the rows of an .rxt file that give M_R
    /// alone): the scattering coefficient is fixed (1/length) and mu_a is fitted. A number,
    /// or as iad's -F a power law of the rows' wavelengths: 'P L0 MU_S0 EXP' for
    /// mu_s = MU_S0 (lambda/L0)^EXP, 'R L0 MU_SP0 EXP' for mu_s' = mu_s (1 - g) the same.
    #[arg(long = "fix-mu-s", value_name = "MU_S", value_parser = RowFixed::parse_mu_s,
          allow_hyphen_values = true)]
    pub fix_mu_s: Option<RowFixed>,
    /// Reflectance only (--m-r alone, or .rxt rows with M_R alone): the absorption
    /// coefficient is fixed at this value (1/length) and mu_s is fitted.
    #[arg(long = "fix-mu-a", value_name = "MU_A")]
    pub fix_mu_a: Option<f64>,
    /// Reflectance only: the sample is semi-infinite (nothing returns from its far face) and
    /// the albedo is fitted.
    #[arg(long = "semi-infinite")]
    pub semi_infinite: bool,
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
    /// A measurement file: multiply its row budget (10^4 rows, about 0.5 ms of fitting a row)
    /// by this factor; see docs/limits.md.
    #[arg(long, value_name = "FACTOR", default_value_t = 1.0)]
    pub budget: f64,
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
    /// `M_R` and `M_T` fractions: the specular reflection, the unscattered beam.
    fn fractions(&self) -> (f64, f64) {
        let c = if self.exclude_specular { 0.0 } else { self.specular_in_m_r };
        let c_t = if self.exclude_unscattered { 0.0 } else { self.unscattered_in_m_t };
        (c, c_t)
    }

    /// The set-up from the flags (thickness required).
    fn setup(&self) -> Result<Setup> {
        let Some(d) = self.thickness else {
            bail!(
                "--thickness is required (the sample's thickness, in the length unit of the answer)"
            );
        };
        let sample = Sample::new(d, self.n_sample.unwrap_or(1.0), self.n_slide)?
            .with_incidence(self.incidence)?;
        let (c, c_t) = self.fractions();
        let spheres = self.spheres()?;
        Ok(Setup { specular_in_m_r: c, unscattered_in_m_t: c_t, spheres, ..Setup::new(sample) })
    }

    /// The spheres of `--spheres`, `--r-sphere`, `--t-sphere`, `--r-std` (iad's -S, -1, -2).
    fn spheres(&self) -> Result<Option<SphereSetup>> {
        let count = self.spheres.unwrap_or(0);
        if count == 0 {
            if self.r_sphere.is_some() || self.t_sphere.is_some() || self.r_std.is_some() {
                bail!("--r-sphere, --t-sphere and --r-std describe spheres: give --spheres 1 or 2");
            }
            return Ok(None);
        }
        let Some(r) = &self.r_sphere else {
            bail!(
                "--spheres {count} needs --r-sphere D_SPHERE D_SAMPLE D_ENTRANCE D_DETECTOR R_WALL"
            );
        };
        let sphere = |v: &[f64]| Sphere {
            d_sphere: v[0],
            d_sample: v[1],
            d_third: v[2],
            d_detector: v[3],
            r_wall: v[4],
            r_detector: 0.0,
        };
        let r_sphere = sphere(r);
        let t_sphere = self.t_sphere.as_deref().map_or(r_sphere, sphere);
        let set = SphereSetup {
            count: count.into(),
            r_sphere,
            t_sphere,
            r_std: self.r_std.unwrap_or(1.0),
            t_std: 1.0,
            baffle: true,
        };
        set.validate()?;
        Ok(Some(set))
    }

    /// The Kubelka–Munk inputs of `--km` (`--n-sample` is the binder's index).
    fn drawdown(&self) -> DrawdownInputs {
        DrawdownInputs {
            r_black: self.r_black,
            r_white: self.r_white,
            r_white_ground: self.r_white_ground,
            r_black_ground: self.r_black_ground,
            r_inf: self.r_inf,
            r_zero: self.r_zero,
            thickness: self.thickness,
            n: self.n_sample,
            k2: self.k2,
        }
    }
}

/// `km fit`.
pub fn run(args: &FitArgs) -> Result<()> {
    if args.km {
        // The slab inverse's inputs mean nothing to the Kubelka–Munk one.
        let slab = [
            ("--m-r", args.m_r.is_some()),
            ("--m-t", args.m_t.is_some()),
            ("--m-u", args.m_u.is_some()),
            ("--sigma-r", args.sigma_r.is_some()),
            ("--sigma-t", args.sigma_t.is_some()),
            ("--sigma-u", args.sigma_u.is_some()),
            ("--g", args.g.is_some()),
            ("--streams", args.streams.is_some()),
            ("--n-slide", args.n_slide.is_some()),
            ("a measurement file", args.file.is_some()),
        ];
        if let Some((flag, _)) = slab.iter().find(|(_, given)| *given) {
            bail!("{flag} applies to the slab inverse, not to --km (the readings are --r-*)");
        }
        return run_km(args);
    }
    // The Kubelka–Munk readings and k2 need --km (thickness and index serve both inverses).
    let km_only = DrawdownInputs { thickness: None, n: None, ..args.drawdown() };
    if km_only != DrawdownInputs::default() {
        bail!(
            "--r-black, --r-white, --r-white-ground, --r-black-ground, --r-inf, --r-zero and \
             --k2 need --km"
        );
    }
    if args.plot.is_some() {
        bail!("--plot applies to --km only");
    }
    let opts = FitOptions { g: args.g, streams: args.streams };
    let fixed = reflectance_only_fixed(args)?;
    let Some(path) = &args.file else {
        if let (Some(m_r), None, Some(fixed)) = (args.m_r, args.m_t, fixed) {
            if args.m_u.is_some() {
                bail!("--m-u needs --m-t: a reflectance-only fit takes --m-r alone");
            }
            let g = args.g.unwrap_or(0.0);
            let RowFixed::Same(fixed) = fixed else {
                bail!(
                    "--fix-mu-s: a power law needs wavelengths: give it with an .rxt file whose \
                     rows give a wavelength and M_R alone"
                );
            };
            let r = fit_reflectance(&args.setup()?, m_r, args.sigma_r, fixed, g, args.streams)?;
            if args.json {
                return stdout::print_json(&r.to_json());
            }
            return stdout::print(&fits_table(&[RowFit { wavelength_nm: None, result: Ok(r) }]));
        }
        let (Some(m_r), Some(m_t)) = (args.m_r, args.m_t) else {
            bail!(
                "give --m-r and --m-t (or a measurement file), or --m-r alone with one fixed \
                 quantity: --fix-mu-s MU_S, --fix-mu-a MU_A or --semi-infinite"
            );
        };
        let (sigma_r, sigma_t, sigma_u) = (args.sigma_r, args.sigma_t, args.sigma_u);
        let meas = Measurement { m_r, m_t, m_u: args.m_u, sigma_r, sigma_t, sigma_u };
        let r = km_inverse::fit(&args.setup()?, &meas, &opts)?;
        if args.json {
            return stdout::print_json(&r.to_json());
        }
        return stdout::print(&fits_table(&[RowFit { wavelength_nm: None, result: Ok(r) }]));
    };
    let fits = fit_file(args, &opts, path, fixed)?;
    if args.json {
        stdout::print_json(&rows_json(&fits))?;
    } else {
        stdout::print(&fits_table(&fits))?;
    }
    if fits.iter().all(|f| f.result.is_err()) {
        bail!("no row of {} could be fitted", path.display());
    }
    Ok(())
}

/// The fixed quantity of a reflectance-only fit (`--fix-mu-s`, `--fix-mu-a`,
/// `--semi-infinite`): at most one, and only with `--m-r` alone.
fn reflectance_only_fixed(args: &FitArgs) -> Result<Option<RowFixed>> {
    let fixed = RowFixed::one_of(args.fix_mu_s, args.fix_mu_a, args.semi_infinite)
        .map_err(|e| anyhow!("--fix-mu-s, --fix-mu-a, --semi-infinite: {e}"))?;
    if fixed.is_some() && args.m_t.is_some() {
        bail!(
            "--fix-mu-s, --fix-mu-a and --semi-infinite are for a reflectance-only fit (--m-r \
             alone); with --m-t both mu_a and mu_s are fitted"
        );
    }
    Ok(fixed)
}

/// A spectrum file (`.rxt`, or `.csv` with the set-up of the flags), every
/// row fitted with the flags' overrides (`km_inverse::spectrum`).
fn fit_file(
    args: &FitArgs,
    opts: &FitOptions,
    path: &Path,
    fixed: Option<RowFixed>,
) -> Result<Vec<RowFit>> {
    if args.m_r.is_some() || args.m_t.is_some() || args.m_u.is_some() {
        bail!("give either a measurement file or --m-r/--m-t/--m-u, not both");
    }
    if !(args.budget.is_finite() && args.budget > 0.0) {
        bail!("--budget must be a finite factor > 0, not {}", args.budget);
    }
    let text = km_inverse::rxt::read_file(path)?;
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_lowercase();
    let max = km_inverse::rxt::max_rows(args.budget);
    let raise = "raise it with --budget FACTOR (x FACTOR) or fit the file in parts";
    let rows = match ext.as_str() {
        "rxt" => parse_rxt_within(&text, max, raise),
        "csv" => parse_csv_within(&text, &args.setup()?, max, raise),
        _ => bail!("{}: expected a .rxt or .csv file", path.display()),
    }
    .with_context(|| format!("{}", path.display()))?;
    check_fixed(&rows, fixed).map_err(|e| {
        anyhow!("--fix-mu-s, --fix-mu-a, --semi-infinite with {}: {e}", path.display())
    })?;
    // Flags that differ from the defaults override an .rxt file.
    let (c, c_t) = args.fractions();
    let over = RowOverrides {
        specular_in_m_r: (c != 1.0).then_some(c),
        unscattered_in_m_t: (c_t != 1.0).then_some(c_t),
        sigma_r: args.sigma_r,
        sigma_t: args.sigma_t,
        sigma_u: args.sigma_u,
        fixed,
    };
    Ok(fit_rows(&rows, &over, opts))
}

/// `--km`: the Kubelka–Munk inverse, and its hiding curves with `--plot`.
fn run_km(args: &FitArgs) -> Result<()> {
    let fit = args.drawdown().fit().map_err(flagged)?;
    if let Some(dir) = &args.plot {
        write_plot(&fit, dir)?;
    }
    if args.json {
        return stdout::print_json(&fit.to_json());
    }
    stdout::print(&drawdown_report(&fit, "--r-zero and --thickness"))
}

/// A refusal of the Kubelka–Munk inputs in the words of the flags.
fn flagged(e: InputError) -> anyhow::Error {
    let flag = |i: Input| match i {
        Input::N => "--n-sample".to_string(),
        i => format!("--{}", i.name().replace('_', "-")),
    };
    match &e {
        // The library's refusal names the value; the flag goes in front.
        InputError::Refused { input, .. } => {
            anyhow!("{}: {}", input.map_or("--km".into(), flag), e.message(flag))
        }
        _ => anyhow!(e.message(flag)),
    }
}

/// Points of the hiding curves (thicknesses from 0 to this many, at most).
const PLOT_POINTS: usize = 200;

/// Draw the fitted film's hiding curves ([`hiding_curves`]: its internal
/// reflectance over the grounds against thickness, the readings at the
/// measured thickness, and `R_inf`) into `dir/km-fit-km.svg` and `.png`.
fn write_plot(fit: &DrawdownFit, dir: &Path) -> Result<[PathBuf; 2]> {
    let Some((curves, x)) = hiding_curves(fit, PLOT_POINTS)? else {
        bail!("--plot needs K and S: give --r-zero and --thickness, or --r-black and --r-white");
    };
    let mut series = Vec::new();
    for (i, c) in curves.into_iter().enumerate() {
        if let Some(r) = c.reading {
            let label = format!("reading, {}", c.label);
            series.push(Series::new(label, vec![(x, r)], Mark::Points, i));
        }
        series.push(Series::new(format!("{} ({})", c.label, c.ground), c.points, Mark::Line, i));
    }
    let (k, s, r_inf) = fit.film.map_or((f64::NAN, f64::NAN, fit.r_inf), |f| (f.k, f.s, f.r_inf));
    let chart = LineChart {
        title: format!("Kubelka–Munk fit: K = {k:.4}, S = {s:.4} (internal reflectance)"),
        x_label: "film thickness".into(),
        y_label: "reflectance".into(),
        y_range: Some((0.0, 1.0)),
        series,
        h_lines: vec![(r_inf, format!("R_inf = {r_inf:.4}"))],
        ..Default::default()
    };
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    write_chart(dir, "km-fit-km", &chart)
}

/// The modes of `km fit`, decided by `--km` and the measurement file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    /// `--km`: the Kubelka–Munk inverse of drawdowns.
    Km,
    /// `--m-r`/`--m-t` on the command line: the slab inverse.
    Slab,
    /// An `.rxt` file: its header gives the sample and the spheres.
    Rxt,
    /// A `.csv` spectrum: the flags give the sample.
    Csv,
}

impl Mode {
    fn words(self) -> &'static str {
        match self {
            Mode::Km => "--km (the Kubelka–Munk inverse of drawdowns: the readings are --r-*)",
            Mode::Slab => "the slab inverse of --m-r/--m-t",
            Mode::Rxt => "an .rxt file (its header gives the sample, the slides and the spheres)",
            Mode::Csv => "a .csv spectrum (its columns give the measurements)",
        }
    }
}

use Mode::{Csv, Km, Rxt, Slab};

/// Every flag of `km fit` (clap id) and the modes it applies to.
const FIT_FLAGS: &[(&str, &[Mode])] = &[
    ("file", &[Rxt, Csv]),
    ("m_r", &[Slab]),
    ("m_t", &[Slab]),
    ("m_u", &[Slab]),
    ("sigma_r", &[Slab, Rxt, Csv]),
    ("sigma_t", &[Slab, Rxt, Csv]),
    ("sigma_u", &[Slab, Rxt, Csv]),
    ("thickness", &[Km, Slab, Csv]),
    ("n_sample", &[Km, Slab, Csv]),
    ("n_slide", &[Slab, Csv]),
    ("g", &[Slab, Rxt, Csv]),
    ("specular_in_m_r", &[Slab, Rxt, Csv]),
    ("unscattered_in_m_t", &[Slab, Rxt, Csv]),
    ("exclude_specular", &[Slab, Rxt, Csv]),
    ("exclude_unscattered", &[Slab, Rxt, Csv]),
    ("incidence", &[Slab, Csv]),
    ("streams", &[Slab, Rxt, Csv]),
    ("fix_mu_s", &[Slab, Rxt]),
    ("fix_mu_a", &[Slab, Rxt]),
    ("semi_infinite", &[Slab, Rxt]),
    ("spheres", &[Slab, Csv]),
    ("r_sphere", &[Slab, Csv]),
    ("t_sphere", &[Slab, Csv]),
    ("r_std", &[Slab, Csv]),
    ("r_black", &[Km]),
    ("r_white", &[Km]),
    ("r_white_ground", &[Km]),
    ("r_black_ground", &[Km]),
    ("plot", &[Km]),
    ("budget", &[Rxt, Csv]),
    ("r_inf", &[Km]),
    ("r_zero", &[Km]),
    ("k2", &[Km]),
];

/// Refuse a flag of `km fit` that does not apply to its mode (`--km`, the
/// slab inverse of `--m-r`/`--m-t`, an `.rxt` or a `.csv` file), naming
/// the mode: a flag that would be silently ignored is an error.
pub fn check_flags(matches: &clap::ArgMatches) -> Result<()> {
    let Some(("fit", m)) = matches.subcommand() else { return Ok(()) };
    let given = |id: &str| {
        matches!(m.try_get_raw(id), Ok(Some(_)))
            && m.value_source(id) == Some(clap::parser::ValueSource::CommandLine)
    };
    let file = m.try_get_one::<PathBuf>("file").ok().flatten();
    let mode = if given("km") {
        Km
    } else if let Some(f) = file {
        let ext = f.extension().and_then(|e| e.to_str()).unwrap_or("").to_lowercase();
        if ext == "rxt" { Rxt } else { Csv }
    } else {
        Slab
    };
    for (id, modes) in FIT_FLAGS {
        if given(id) && !modes.contains(&mode) {
            let flag = if *id == "file" {
                "a measurement file".to_string()
            } else {
                format!("--{}", id.replace('_', "-"))
            };
            if *id == "file" {
                bail!("{flag} does not apply to {}", mode.words());
            }
            let applies: Vec<_> = modes.iter().map(|x| x.words()).collect();
            bail!(
                "{flag} does not apply to {}; it applies to {}",
                mode.words(),
                applies.join(", to ")
            );
        }
    }
    Ok(())
}
