//! A fit asked for with plain options (`km fit`'s flags): which inverse and
//! which input they call for ([`Mode`]), the options that do not apply to
//! it refused ([`check_options`]), the inputs built and checked ([`Setup`],
//! [`SphereSetup`], [`DrawdownInputs`], a measurement file read and parsed),
//! the fit run, and its answer as JSON and as text ([`FitAnswer`]).
//!
//! The options are named in the refusals as the command line spells them
//! (`--thickness`, `--r-sphere`): [`option_flag`] turns a name of
//! [`FIT_OPTIONS`] into its flag.

use std::path::{Path, PathBuf};

use serde_json::Value;

use crate::drawdown::{DrawdownFit, DrawdownInputs, Input, InputError};
use crate::forward::Sample;
use crate::reflectance::fit_reflectance;
use crate::rxt::{parse_csv_within, parse_rxt_within};
use crate::slab::{FitOptions, Measurement, Setup};
use crate::spectrum::{RowFit, RowFixed, RowOverrides, check_fixed, fit_rows, rows_json};
use crate::sphere::{Sphere, SphereSetup};
use crate::text::{drawdown_report, fits_table};

/// A refusal of a fit request: a message naming the options, or an error of
/// the fit itself (shown with its sources, as it was raised).
#[derive(Debug)]
pub enum RequestError {
    /// The request's own words.
    Message(String),
    /// `CONTEXT: ERROR`: the error, after what it concerns (a file's name).
    Context(String, Box<dyn std::error::Error + Send + Sync>),
    /// An error of the fit, unchanged.
    Other(Box<dyn std::error::Error + Send + Sync>),
}

impl std::fmt::Display for RequestError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RequestError::Message(m) | RequestError::Context(m, _) => f.write_str(m),
            RequestError::Other(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for RequestError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            RequestError::Message(_) => None,
            RequestError::Context(_, e) => Some(e.as_ref()),
            RequestError::Other(e) => e.source(),
        }
    }
}

/// The error `e` of the fit, unchanged.
fn other(e: impl std::error::Error + Send + Sync + 'static) -> RequestError {
    RequestError::Other(Box::new(e))
}

/// A refusal in the request's words.
fn refuse(message: impl Into<String>) -> RequestError {
    RequestError::Message(message.into())
}

/// The inverses and inputs of a fit, decided by `--km` and the measurement file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// `--km`: the Kubelka–Munk inverse of drawdowns.
    Km,
    /// `--m-r`/`--m-t`: the slab inverse of one measurement.
    Slab,
    /// An `.rxt` file: its header gives the sample and the spheres.
    Rxt,
    /// A `.csv` spectrum: the options give the sample.
    Csv,
}

impl Mode {
    /// The mode of a request: `km`, else the file's extension (`.rxt`, else
    /// `.csv`), else one measurement.
    pub fn of(km: bool, file: Option<&Path>) -> Mode {
        match file {
            _ if km => Mode::Km,
            Some(f) if FileKind::of(f) == Some(FileKind::Rxt) => Mode::Rxt,
            Some(_) => Mode::Csv,
            None => Mode::Slab,
        }
    }

    /// The mode in words (for refusals).
    pub fn words(self) -> &'static str {
        match self {
            Mode::Km => "--km (the Kubelka–Munk inverse of drawdowns: the readings are --r-*)",
            Mode::Slab => "the slab inverse of --m-r/--m-t",
            Mode::Rxt => "an .rxt file (its header gives the sample, the slides and the spheres)",
            Mode::Csv => "a .csv spectrum (its columns give the measurements)",
        }
    }
}

/// The kinds of measurement file, by extension (any case).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FileKind {
    /// iad's `.rxt`.
    Rxt,
    /// A `.csv` spectrum.
    Csv,
}

impl FileKind {
    /// The kind of `path` by its extension, `None` for another one.
    pub fn of(path: &Path) -> Option<FileKind> {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_lowercase();
        match ext.as_str() {
            "rxt" => Some(FileKind::Rxt),
            "csv" => Some(FileKind::Csv),
            _ => None,
        }
    }
}

use Mode::{Csv, Km, Rxt, Slab};

/// Every option of a fit request (its name, as `km fit`'s argument ids) and
/// the modes it applies to.
pub const FIT_OPTIONS: &[(&str, &[Mode])] = &[
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

/// The flag of option `name` of [`FIT_OPTIONS`] (`m_r` → `--m-r`; `file`
/// → "a measurement file").
pub fn option_flag(name: &str) -> String {
    if name == "file" {
        "a measurement file".into()
    } else {
        format!("--{}", name.replace('_', "-"))
    }
}

/// Refuse an option of [`FIT_OPTIONS`] that was `given` and does not apply
/// to `mode`, naming the mode: an option that would be silently ignored is
/// an error.
///
/// # Errors
/// The first such option, with the modes it applies to.
pub fn check_options(mode: Mode, given: impl Fn(&str) -> bool) -> Result<(), RequestError> {
    for (id, modes) in FIT_OPTIONS {
        if given(id) && !modes.contains(&mode) {
            let flag = option_flag(id);
            if *id == "file" {
                return Err(refuse(format!("{flag} does not apply to {}", mode.words())));
            }
            let applies: Vec<_> = modes.iter().map(|x| x.words()).collect();
            return Err(refuse(format!(
                "{flag} does not apply to {}; it applies to {}",
                mode.words(),
                applies.join(", to ")
            )));
        }
    }
    Ok(())
}

/// A fit asked for with plain options (`km fit`'s flags, one field each,
/// with their help: `clap::Args` with the feature `clap`;
/// [`FitRequest::default`] is every option absent or at its default).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct FitRequest {
    /// Spectrum file: iad's `.rxt` (sample and spheres from its header) or a
    /// `.csv` with columns wavelength_nm, m_r, m_t[, m_u, sigma_r, sigma_t, sigma_u, g].
    pub file: Option<PathBuf>,
    /// Measured total reflectance M_R (normal collimated light).
    #[cfg_attr(feature = "clap", arg(long = "m-r"))]
    pub m_r: Option<f64>,
    /// Measured total transmittance M_T.
    #[cfg_attr(feature = "clap", arg(long = "m-t"))]
    pub m_t: Option<f64>,
    /// Measured unscattered (collimated) transmittance M_U; g is then fitted unless --g is given.
    #[cfg_attr(feature = "clap", arg(long = "m-u"))]
    pub m_u: Option<f64>,
    /// Standard uncertainty of M_R (default 1e-4, iad's tolerance).
    #[cfg_attr(feature = "clap", arg(long = "sigma-r"))]
    pub sigma_r: Option<f64>,
    /// Standard uncertainty of M_T (default 1e-4).
    #[cfg_attr(feature = "clap", arg(long = "sigma-t"))]
    pub sigma_t: Option<f64>,
    /// Standard uncertainty of M_U (default 1e-4).
    #[cfg_attr(feature = "clap", arg(long = "sigma-u"))]
    pub sigma_u: Option<f64>,
    /// Sample thickness (mu_a, mu_s, mu_s' come out in its inverse unit).
    #[cfg_attr(feature = "clap", arg(long))]
    pub thickness: Option<f64>,
    /// Refractive index of the sample (default 1).
    #[cfg_attr(feature = "clap", arg(long = "n-sample"))]
    pub n_sample: Option<f64>,
    /// Refractive index of clear glass slides on both faces (default: none).
    #[cfg_attr(feature = "clap", arg(long = "n-slide"))]
    pub n_slide: Option<f64>,
    /// Fixed anisotropy g (default 0 without M_U; fitted with M_U).
    #[cfg_attr(feature = "clap", arg(long))]
    pub g: Option<f64>,
    /// Fraction of the specular reflection included in M_R (iad -c; default 1).
    #[cfg_attr(feature = "clap", arg(long = "specular-in-m-r", default_value_t = FitRequest::default().specular_in_m_r))]
    pub specular_in_m_r: f64,
    /// Fraction of the unscattered beam included in M_T (iad -C; default 1).
    #[cfg_attr(feature = "clap", arg(long = "unscattered-in-m-t", default_value_t = FitRequest::default().unscattered_in_m_t))]
    pub unscattered_in_m_t: f64,
    /// M_R excludes the specular reflection (same as --specular-in-m-r 0).
    #[cfg_attr(feature = "clap", arg(long = "exclude-specular"))]
    pub exclude_specular: bool,
    /// M_T excludes the unscattered beam (same as --unscattered-in-m-t 0).
    #[cfg_attr(feature = "clap", arg(long = "exclude-unscattered"))]
    pub exclude_unscattered: bool,
    /// Polar angle of the incident beam in degrees (default 0).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = FitRequest::default().incidence))]
    pub incidence: f64,
    /// Integrating spheres used at a time (iad -S): 0 (the totals themselves, the default),
    /// 1 (substitution) or 2 (double sphere); 1 and 2 need --r-sphere.
    #[cfg_attr(feature = "clap", arg(long, value_parser = clap::value_parser!(u8).range(0..=2)))]
    pub spheres: Option<u8>,
    /// The reflection sphere (iad -1): sphere, sample port, entrance port and detector port
    /// diameters (one length unit), and the wall reflectance.
    #[cfg_attr(feature = "clap", arg(long = "r-sphere", num_args = 5, allow_negative_numbers = true, value_names = ["D_SPHERE", "D_SAMPLE", "D_ENTRANCE", "D_DETECTOR", "R_WALL"]))]
    pub r_sphere: Option<Vec<f64>>,
    /// The transmission sphere (iad -2): sphere, sample port, exit port and detector port
    /// diameters, and the wall reflectance (default: the same as --r-sphere).
    #[cfg_attr(feature = "clap", arg(long = "t-sphere", num_args = 5, allow_negative_numbers = true, value_names = ["D_SPHERE", "D_SAMPLE", "D_EXIT", "D_DETECTOR", "R_WALL"]))]
    pub t_sphere: Option<Vec<f64>>,
    /// Reflectance of the reflection standard with spheres (the .rxt header's; default 1).
    #[cfg_attr(feature = "clap", arg(long = "r-std"))]
    pub r_std: Option<f64>,
    /// Reflectance only (--m-r without --m-t, or the rows of an .rxt file that give M_R
    /// alone): the scattering coefficient is fixed (1/length) and mu_a is fitted. A number,
    /// or as iad's -F a power law of the rows' wavelengths: 'P L0 MU_S0 EXP' for
    /// mu_s = MU_S0 (lambda/L0)^EXP, 'R L0 MU_SP0 EXP' for mu_s' = mu_s (1 - g) the same.
    #[cfg_attr(feature = "clap", arg(long = "fix-mu-s", value_name = "MU_S", value_parser = RowFixed::parse_mu_s, allow_hyphen_values = true))]
    pub fix_mu_s: Option<RowFixed>,
    /// Reflectance only (--m-r alone, or .rxt rows with M_R alone): the absorption
    /// coefficient is fixed at this value (1/length) and mu_s is fitted.
    #[cfg_attr(feature = "clap", arg(long = "fix-mu-a", value_name = "MU_A"))]
    pub fix_mu_a: Option<f64>,
    /// Reflectance only: the sample is semi-infinite (nothing returns from its far face) and
    /// the albedo is fitted.
    #[cfg_attr(feature = "clap", arg(long = "semi-infinite"))]
    pub semi_infinite: bool,
    /// Fixed stream count of the forward model (default: the rule of docs/inverse.md eq. I7).
    #[cfg_attr(feature = "clap", arg(long))]
    pub streams: Option<usize>,
    /// Kubelka–Munk inverse of paint drawdowns instead of the slab inverse.
    #[cfg_attr(feature = "clap", arg(long))]
    pub km: bool,
    /// A measurement file: multiply its row budget (10^4 rows, about 0.5 ms of fitting a row)
    /// by this factor; see docs/limits.md.
    #[cfg_attr(feature = "clap", arg(long, value_name = "FACTOR", default_value_t = FitRequest::default().budget))]
    pub budget: f64,
    /// The readings of the Kubelka–Munk inverse (`thickness`, `n` unused:
    /// those of this request serve).
    #[cfg_attr(feature = "clap", command(flatten))]
    pub drawdown: DrawdownInputs,
}

impl Default for FitRequest {
    fn default() -> Self {
        FitRequest {
            file: None,
            m_r: None,
            m_t: None,
            m_u: None,
            sigma_r: None,
            sigma_t: None,
            sigma_u: None,
            thickness: None,
            n_sample: None,
            n_slide: None,
            g: None,
            specular_in_m_r: 1.0,
            unscattered_in_m_t: 1.0,
            exclude_specular: false,
            exclude_unscattered: false,
            incidence: 0.0,
            spheres: None,
            r_sphere: None,
            t_sphere: None,
            r_std: None,
            fix_mu_s: None,
            fix_mu_a: None,
            semi_infinite: false,
            streams: None,
            km: false,
            budget: 1.0,
            drawdown: DrawdownInputs::default(),
        }
    }
}

/// The answer of a fit request.
#[derive(Debug)]
pub struct FitAnswer {
    /// The JSON answer (one object, or a list for a file).
    pub json: Value,
    /// The answer for people (a table, or the Kubelka–Munk report).
    pub text: String,
    /// The Kubelka–Munk fit (for its chart).
    pub drawdown: Option<DrawdownFit>,
    /// A file none of whose rows could be fitted: the refusal to report
    /// after the answer (whose rows say why each failed).
    pub failure: Option<RequestError>,
}

impl FitAnswer {
    /// The answer of one slab fit (the table of one row).
    fn one(r: crate::FitResult) -> FitAnswer {
        let json = r.to_json();
        let text = fits_table(&[RowFit { wavelength_nm: None, result: Ok(r) }]);
        FitAnswer { json, text, drawdown: None, failure: None }
    }
}

impl FitRequest {
    /// `M_R` and `M_T` fractions: the specular reflection, the unscattered beam.
    fn fractions(&self) -> (f64, f64) {
        let c = if self.exclude_specular { 0.0 } else { self.specular_in_m_r };
        let c_t = if self.exclude_unscattered { 0.0 } else { self.unscattered_in_m_t };
        (c, c_t)
    }

    /// The set-up of the options (thickness required).
    ///
    /// # Errors
    /// No thickness, or an invalid sample or sphere.
    pub fn setup(&self) -> Result<Setup, RequestError> {
        let Some(d) = self.thickness else {
            return Err(refuse(
                "--thickness is required (the sample's thickness, in the length unit of the answer)",
            ));
        };
        let sample = Sample::new(d, self.n_sample.unwrap_or(1.0), self.n_slide)
            .and_then(|s| s.with_incidence(self.incidence))
            .map_err(other)?;
        let (c, c_t) = self.fractions();
        let spheres = self.spheres()?;
        Ok(Setup { specular_in_m_r: c, unscattered_in_m_t: c_t, spheres, ..Setup::new(sample) })
    }

    /// The spheres of `spheres`, `r_sphere`, `t_sphere`, `r_std` (iad's -S, -1, -2).
    fn spheres(&self) -> Result<Option<SphereSetup>, RequestError> {
        let count = self.spheres.unwrap_or(0);
        if count == 0 {
            if self.r_sphere.is_some() || self.t_sphere.is_some() || self.r_std.is_some() {
                return Err(refuse(
                    "--r-sphere, --t-sphere and --r-std describe spheres: give --spheres 1 or 2",
                ));
            }
            return Ok(None);
        }
        let Some(r) = &self.r_sphere else {
            return Err(refuse(format!(
                "--spheres {count} needs --r-sphere D_SPHERE D_SAMPLE D_ENTRANCE D_DETECTOR R_WALL"
            )));
        };
        let sphere = |v: &[f64]| -> Result<Sphere, RequestError> {
            let [d_sphere, d_sample, d_third, d_detector, r_wall] = v[..] else {
                return Err(refuse("a sphere is five numbers"));
            };
            Ok(Sphere { d_sphere, d_sample, d_third, d_detector, r_wall, r_detector: 0.0 })
        };
        let r_sphere = sphere(r)?;
        let t_sphere = self.t_sphere.as_deref().map_or(Ok(r_sphere), sphere)?;
        let set = SphereSetup {
            count: count.into(),
            r_sphere,
            t_sphere,
            r_std: self.r_std.unwrap_or(1.0),
            t_std: 1.0,
            baffle: true,
        };
        set.validate().map_err(other)?;
        Ok(Some(set))
    }

    /// The Kubelka–Munk inputs (`n_sample` is the binder's index).
    fn drawdown(&self) -> DrawdownInputs {
        DrawdownInputs { thickness: self.thickness, n: self.n_sample, ..self.drawdown }
    }

    /// Run the fit the options ask for: the Kubelka–Munk inverse (`km`), a
    /// reflectance-only or full slab fit of one measurement, or every row of
    /// a measurement file.
    ///
    /// # Errors
    /// Options that do not go together or are missing, invalid values,
    /// an unreadable or malformed file, and a fit that fails.
    pub fn run(&self) -> Result<FitAnswer, RequestError> {
        if self.km {
            // The slab inverse's inputs mean nothing to the Kubelka–Munk one.
            let slab = [
                ("--m-r", self.m_r.is_some()),
                ("--m-t", self.m_t.is_some()),
                ("--m-u", self.m_u.is_some()),
                ("--sigma-r", self.sigma_r.is_some()),
                ("--sigma-t", self.sigma_t.is_some()),
                ("--sigma-u", self.sigma_u.is_some()),
                ("--g", self.g.is_some()),
                ("--streams", self.streams.is_some()),
                ("--n-slide", self.n_slide.is_some()),
                ("a measurement file", self.file.is_some()),
            ];
            if let Some((flag, _)) = slab.iter().find(|(_, given)| *given) {
                return Err(refuse(format!(
                    "{flag} applies to the slab inverse, not to --km (the readings are --r-*)"
                )));
            }
            return self.run_km();
        }
        // The Kubelka–Munk readings and k2 need --km (thickness and index serve both inverses).
        let km_only = DrawdownInputs { thickness: None, n: None, ..self.drawdown };
        if km_only != DrawdownInputs::default() {
            return Err(refuse(
                "--r-black, --r-white, --r-white-ground, --r-black-ground, --r-inf, --r-zero and \
                 --k2 need --km",
            ));
        }
        let fixed = self.reflectance_only_fixed()?;
        if let Some(path) = &self.file {
            return self.run_file(path, fixed);
        }
        if let (Some(m_r), None, Some(fixed)) = (self.m_r, self.m_t, fixed) {
            if self.m_u.is_some() {
                return Err(refuse("--m-u needs --m-t: a reflectance-only fit takes --m-r alone"));
            }
            let RowFixed::Same(fixed) = fixed else {
                return Err(refuse(
                    "--fix-mu-s: a power law needs wavelengths: give it with an .rxt file whose \
                     rows give a wavelength and M_R alone",
                ));
            };
            let g = self.g.unwrap_or(0.0);
            let r = fit_reflectance(&self.setup()?, m_r, self.sigma_r, fixed, g, self.streams)
                .map_err(other)?;
            return Ok(FitAnswer::one(r));
        }
        let (Some(m_r), Some(m_t)) = (self.m_r, self.m_t) else {
            return Err(refuse(
                "give --m-r and --m-t (or a measurement file), or --m-r alone with one fixed \
                 quantity: --fix-mu-s MU_S, --fix-mu-a MU_A or --semi-infinite",
            ));
        };
        let (sigma_r, sigma_t, sigma_u) = (self.sigma_r, self.sigma_t, self.sigma_u);
        let meas = Measurement { m_r, m_t, m_u: self.m_u, sigma_r, sigma_t, sigma_u };
        let opts = FitOptions { g: self.g, streams: self.streams };
        Ok(FitAnswer::one(crate::fit(&self.setup()?, &meas, &opts).map_err(other)?))
    }

    /// The fixed quantity of a reflectance-only fit (`fix_mu_s`, `fix_mu_a`,
    /// `semi_infinite`): at most one, and only with `M_R` alone.
    fn reflectance_only_fixed(&self) -> Result<Option<RowFixed>, RequestError> {
        let fixed = RowFixed::one_of(self.fix_mu_s, self.fix_mu_a, self.semi_infinite)
            .map_err(|e| refuse(format!("--fix-mu-s, --fix-mu-a, --semi-infinite: {e}")))?;
        if fixed.is_some() && self.m_t.is_some() {
            return Err(refuse(
                "--fix-mu-s, --fix-mu-a and --semi-infinite are for a reflectance-only fit (--m-r \
                 alone); with --m-t both mu_a and mu_s are fitted",
            ));
        }
        Ok(fixed)
    }

    /// A spectrum file (`.rxt`, or `.csv` with the set-up of the options),
    /// every row fitted with the options' overrides (`crate::spectrum`).
    fn run_file(&self, path: &Path, fixed: Option<RowFixed>) -> Result<FitAnswer, RequestError> {
        if self.m_r.is_some() || self.m_t.is_some() || self.m_u.is_some() {
            return Err(refuse("give either a measurement file or --m-r/--m-t/--m-u, not both"));
        }
        if !(self.budget.is_finite() && self.budget > 0.0) {
            return Err(refuse(format!(
                "--budget must be a finite factor > 0, not {}",
                self.budget
            )));
        }
        let text = crate::rxt::read_file(path).map_err(other)?;
        let max = crate::rxt::max_rows(self.budget);
        let raise = "raise it with --budget FACTOR (x FACTOR) or fit the file in parts";
        let Some(kind) = FileKind::of(path) else {
            return Err(refuse(format!("{}: expected a .rxt or .csv file", path.display())));
        };
        let rows = match kind {
            FileKind::Rxt => parse_rxt_within(&text, max, raise),
            FileKind::Csv => parse_csv_within(&text, &self.setup()?, max, raise),
        }
        .map_err(|e| RequestError::Context(path.display().to_string(), Box::new(e)))?;
        check_fixed(&rows, fixed).map_err(|e| {
            refuse(format!("--fix-mu-s, --fix-mu-a, --semi-infinite with {}: {e}", path.display()))
        })?;
        let (c, c_t) = self.fractions();
        let (sigma_r, sigma_t, sigma_u) = (self.sigma_r, self.sigma_t, self.sigma_u);
        let over = RowOverrides::from_options(c, c_t, [sigma_r, sigma_t, sigma_u], fixed);
        let fits = fit_rows(&rows, &over, &FitOptions { g: self.g, streams: self.streams });
        let failure = fits
            .iter()
            .all(|f| f.result.is_err())
            .then(|| refuse(format!("no row of {} could be fitted", path.display())));
        Ok(FitAnswer { json: rows_json(&fits), text: fits_table(&fits), drawdown: None, failure })
    }

    /// The Kubelka–Munk inverse of the drawdown readings.
    fn run_km(&self) -> Result<FitAnswer, RequestError> {
        let fit = self.drawdown().fit().map_err(flagged)?;
        let json = fit.to_json();
        let text = drawdown_report(&fit, "--r-zero and --thickness");
        Ok(FitAnswer { json, text, drawdown: Some(fit), failure: None })
    }
}

/// A refusal of the Kubelka–Munk inputs in the words of the options.
fn flagged(e: InputError) -> RequestError {
    let flag = |i: Input| match i {
        Input::N => "--n-sample".to_string(),
        i => format!("--{}", i.name().replace('_', "-")),
    };
    match &e {
        // The library's refusal names the value; the flag goes in front.
        InputError::Refused { input, .. } => {
            refuse(format!("{}: {}", input.map_or("--km".into(), flag), e.message(flag)))
        }
        _ => refuse(e.message(flag)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The request's slab fit is the fit of the set-up and measurement built
    /// by hand (the same numbers bit for bit: one code path, so no tolerance).
    #[test]
    fn slab_request_is_the_direct_fit() {
        let req = FitRequest {
            m_r: Some(0.2726),
            m_t: Some(0.2991),
            thickness: Some(1.0),
            n_sample: Some(1.4),
            ..FitRequest::default()
        };
        let answer = req.run().unwrap();
        let setup = Setup::new(Sample::new(1.0, 1.4, None).unwrap());
        let meas = Measurement {
            m_r: 0.2726,
            m_t: 0.2991,
            m_u: None,
            sigma_r: None,
            sigma_t: None,
            sigma_u: None,
        };
        let direct = crate::fit(&setup, &meas, &FitOptions::default()).unwrap();
        assert_eq!(answer.json, direct.to_json());
        assert!(answer.failure.is_none() && answer.drawdown.is_none());
        // The table's one row gives the fitted albedo (six decimals).
        let albedo = format!("{:.6}", direct.to_json()["albedo"].as_f64().unwrap());
        let row = answer.text.lines().nth(1).unwrap();
        assert!(row.split_whitespace().nth(1) == Some(albedo.as_str()), "{}", answer.text);
    }

    /// Options outside their mode are refused with the modes they apply to;
    /// those inside pass.
    #[test]
    fn options_outside_their_mode_are_refused() {
        let rxt = Mode::of(false, Some(Path::new("a.RXT")));
        assert_eq!(rxt, Mode::Rxt);
        assert_eq!(Mode::of(false, Some(Path::new("a.txt"))), Mode::Csv);
        assert_eq!(Mode::of(true, Some(Path::new("a.rxt"))), Mode::Km);
        let e = check_options(rxt, |id| id == "m_r").unwrap_err().to_string();
        assert!(e.starts_with("--m-r does not apply to an .rxt file"), "{e}");
        assert!(e.ends_with("it applies to the slab inverse of --m-r/--m-t"), "{e}");
        let e = check_options(Mode::Km, |id| id == "file").unwrap_err().to_string();
        assert!(e.starts_with("a measurement file does not apply to --km"), "{e}");
        assert!(check_options(Mode::Slab, |id| ["thickness", "m_r", "g"].contains(&id)).is_ok());
    }

    /// Readings of one inverse given to the other are refused, not ignored.
    #[test]
    fn readings_of_the_other_inverse_are_refused() {
        let mut req = FitRequest { m_r: Some(0.3), m_t: Some(0.4), ..FitRequest::default() };
        req.drawdown.r_inf = Some(0.5);
        let e = req.run().unwrap_err().to_string();
        assert!(e.ends_with("need --km"), "{e}");
        let req = FitRequest { km: true, m_r: Some(0.3), ..FitRequest::default() };
        let e = req.run().unwrap_err().to_string();
        assert!(e.starts_with("--m-r applies to the slab inverse"), "{e}");
    }
}
