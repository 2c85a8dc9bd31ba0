//! `km fit`: optical properties from measurements. Two inverses behind one
//! command: the slab inverse of Prahl's iad (`--m-r`, `--m-t`, `[--m-u]`, or
//! a spectrum file; `docs/inverse.md`), and, with `--km`, the Kubelka–Munk
//! inverse of paint drawdowns (`docs/inverse-km.md`). The flags become a
//! `km_inverse::request::FitRequest`, which checks, fits and writes the
//! answer; the hiding curves are drawn by `km_plot::fit`.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use km_inverse::drawdown::DrawdownInputs;
use km_inverse::request::{FIT_OPTIONS, FitRequest, Mode, check_options};
use km_inverse::spectrum::RowFixed;

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
    /// The request of the flags.
    fn request(&self) -> FitRequest {
        FitRequest {
            file: self.file.clone(),
            m_r: self.m_r,
            m_t: self.m_t,
            m_u: self.m_u,
            sigma_r: self.sigma_r,
            sigma_t: self.sigma_t,
            sigma_u: self.sigma_u,
            thickness: self.thickness,
            n_sample: self.n_sample,
            n_slide: self.n_slide,
            g: self.g,
            specular_in_m_r: self.specular_in_m_r,
            unscattered_in_m_t: self.unscattered_in_m_t,
            exclude_specular: self.exclude_specular,
            exclude_unscattered: self.exclude_unscattered,
            incidence: self.incidence,
            spheres: self.spheres,
            r_sphere: self.r_sphere.clone(),
            t_sphere: self.t_sphere.clone(),
            r_std: self.r_std,
            fix_mu_s: self.fix_mu_s,
            fix_mu_a: self.fix_mu_a,
            semi_infinite: self.semi_infinite,
            streams: self.streams,
            km: self.km,
            budget: self.budget,
            drawdown: DrawdownInputs {
                r_black: self.r_black,
                r_white: self.r_white,
                r_white_ground: self.r_white_ground,
                r_black_ground: self.r_black_ground,
                r_inf: self.r_inf,
                r_zero: self.r_zero,
                k2: self.k2,
                ..Default::default()
            },
        }
    }
}

/// `km fit`: the answer printed (and with `--km --plot`, the hiding curves drawn).
pub fn run(args: &FitArgs) -> Result<()> {
    if args.plot.is_some() && !args.km {
        anyhow::bail!("--plot applies to --km only");
    }
    let answer = args.request().run()?;
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
    let given = |id: &str| {
        matches!(m.try_get_raw(id), Ok(Some(_)))
            && m.value_source(id) == Some(clap::parser::ValueSource::CommandLine)
    };
    let file = m.try_get_one::<PathBuf>("file").ok().flatten();
    debug_assert!(FIT_OPTIONS.iter().all(|(id, _)| m.try_get_raw(id).is_ok()));
    Ok(check_options(Mode::of(given("km"), file.map(PathBuf::as_path)), given)?)
}
