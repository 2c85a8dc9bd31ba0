//! `km bsdf`'s files: the BSDF of a scene's stack on angle grids, its checks
//! in a meta JSON, and the bytes of an npz, CSV or Fourier BSDF file
//! (`docs/bsdf.md`).

use std::path::Path;

use km_multiflux::MultifluxOptions;
use km_multiflux::bsdf::write::{FourierSettings, Table, fourier};
use km_multiflux::bsdf::{Bsdf, BsdfError, BsdfOptions, Side, check, gauss_angles};
use serde_json::{Value, json};

use crate::Scene;

/// File format of a BSDF file.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum BsdfFormat {
    /// numpy `.npz` (zip of `.npy` arrays; names in docs/bsdf.md).
    Npz,
    /// Long-format CSV, one row per (channel, theta_i, theta_o, phi), after
    /// the meta JSON as `# ` comment lines.
    #[cfg_attr(
        feature = "clap",
        value(help = "Long-format CSV, one row per (channel, theta_i, theta_o, phi)")
    )]
    Csv,
    /// The layerlab Fourier BSDF file read by Mitsuba 0.6 and pbrt-v3.
    #[cfg_attr(
        feature = "clap",
        value(
            help = "The layerlab Fourier BSDF file read by Mitsuba 0.6 and pbrt-v3 (`fourier` material)"
        )
    )]
    Fourier,
}

impl BsdfFormat {
    /// The format named by a file's extension: `.csv`, `.bsdf` (Fourier),
    /// anything else (or no file) npz.
    ///
    /// ```
    /// use km::bsdf_file::BsdfFormat;
    /// assert_eq!(BsdfFormat::from_path(Some("a.bsdf".as_ref())), BsdfFormat::Fourier);
    /// assert_eq!(BsdfFormat::from_path(None), BsdfFormat::Npz);
    /// ```
    pub fn from_path(path: Option<&Path>) -> BsdfFormat {
        match path.and_then(|p| p.extension()).and_then(|e| e.to_str()) {
            Some("csv") => BsdfFormat::Csv,
            Some("bsdf") => BsdfFormat::Fourier,
            _ => BsdfFormat::Npz,
        }
    }

    /// The default exit polar grid in degrees: 48 angles uniform in theta
    /// from 0 (step 1.875) for the Fourier file, which needs 0 and equal
    /// grids; else the arccosines of 32 Gauss nodes in mu (the energy
    /// check's quadrature).
    pub fn default_theta(self) -> Vec<f64> {
        match self {
            BsdfFormat::Fourier => (0..48).map(|k| 1.875 * k as f64).collect(),
            _ => gauss_angles(32).0,
        }
    }

    /// The default incidence polar grid in degrees: [`BsdfFormat::default_theta`]
    /// with normal incidence (0) first when it lacks it (npz, csv: 0 and the
    /// 32 Gauss angles).
    ///
    /// ```
    /// use km::bsdf_file::BsdfFormat;
    /// let t = BsdfFormat::Csv.default_theta_i();
    /// assert_eq!((t[0], t.len()), (0.0, 33));
    /// assert_eq!(BsdfFormat::Fourier.default_theta_i(), BsdfFormat::Fourier.default_theta());
    /// ```
    pub fn default_theta_i(self) -> Vec<f64> {
        let mut t = self.default_theta();
        if !t.contains(&0.0) {
            t.insert(0, 0.0);
        }
        t
    }
}

/// The default azimuths: every 5 degrees from 0 (72).
pub fn default_phi() -> Vec<f64> {
    (0..72).map(|k| 5.0 * k as f64).collect()
}

/// An angle list that [`parse_angles`] refuses: the list as given (trimmed)
/// for the errors about a `gauss:N` or a range, and what is wrong.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum AngleListError {
    /// A `gauss:N` or `START:STOP:STEP` that is not valid.
    #[error("{text}: {reason}")]
    Grid {
        /// The list as given.
        text: String,
        /// What is wrong.
        reason: String,
    },
    /// A comma-separated list with a value that is not valid.
    #[error("{reason}")]
    List {
        /// What is wrong.
        reason: String,
    },
}

/// The most values one angle list gives.
pub const MAX_ANGLES: usize = 100_000;

/// Angles in degrees from a list `a,b,c`, a range `START:STOP:STEP` (STOP
/// excluded: `START + k STEP < STOP`) or `gauss:N` (the arccosines of the
/// `N` Gauss–Legendre nodes in `mu` on (0, 1), `1 <= N <= 1024`).
///
/// # Errors
/// [`AngleListError`] for values that are not finite numbers, an empty or
/// reversed range, `N` outside `1..=1024`, more than [`MAX_ANGLES`] values.
///
/// ```
/// use km::bsdf_file::parse_angles;
/// assert_eq!(parse_angles("0:90:30").unwrap(), vec![0.0, 30.0, 60.0]);
/// assert_eq!(parse_angles("0, 45").unwrap(), vec![0.0, 45.0]);
/// assert_eq!(parse_angles("gauss:4").unwrap().len(), 4);
/// assert!(parse_angles("0:90").is_err());
/// ```
pub fn parse_angles(text: &str) -> Result<Vec<f64>, AngleListError> {
    let text = text.trim();
    let grid = |reason: String| AngleListError::Grid { text: text.into(), reason };
    if let Some(n) = text.strip_prefix("gauss:") {
        let n: usize = n.trim().parse().map_err(|e| grid(format!("N: {e}")))?;
        if n == 0 || n > 1024 {
            return Err(grid("N must lie in 1..=1024".into()));
        }
        return Ok(gauss_angles(n).0);
    }
    if text.contains(':') {
        let parts: Vec<&str> = text.split(':').collect();
        let [a, b, s] = parts[..] else {
            return Err(grid("a range is START:STOP:STEP".into()));
        };
        let num = |x: &str| -> Result<f64, AngleListError> {
            let v: f64 = x.trim().parse().map_err(|e| grid(format!("`{x}`: {e}")))?;
            if !v.is_finite() {
                return Err(grid(format!("`{x}` is not finite")));
            }
            Ok(v)
        };
        let (a, b, s) = (num(a)?, num(b)?, num(s)?);
        if s <= 0.0 || b <= a {
            return Err(grid("needs STOP > START and STEP > 0".into()));
        }
        // The count, less a relative 1e-9 so that STOP itself stays out.
        let count = ((b - a) / s - 1e-9).ceil();
        if count > MAX_ANGLES as f64 {
            return Err(grid(format!("{count} values (at most {MAX_ANGLES})")));
        }
        return Ok((0..count as usize).map(|k| a + s * k as f64).collect());
    }
    let list = |reason: String| AngleListError::List { reason };
    let v = text
        .split(',')
        .map(|x| {
            let v: f64 =
                x.trim().parse().map_err(|e| list(format!("`{x}` is not a number: {e}")))?;
            if !v.is_finite() {
                return Err(list(format!("`{x}` is not finite")));
            }
            Ok(v)
        })
        .collect::<Result<Vec<f64>, _>>()?;
    if v.len() > MAX_ANGLES {
        return Err(list(format!("{} values (at most {MAX_ANGLES})", v.len())));
    }
    Ok(v)
}

/// The most (channel, theta_i, theta_o) triples of one BSDF at budget 1:
/// each keeps its Fourier coefficients and correction weights (about 1 kB),
/// so `2^18` triples stay near 256 MB.
pub const MAX_PAIRS: usize = 1 << 18;

/// The most values of one table (channels x theta_i x theta_o x phi) at
/// budget 1: `2^22` values are 32 MB per array of the file.
pub const MAX_TABLE_VALUES: usize = 1 << 22;

/// The largest azimuth magnitude accepted, degrees (one turn either way:
/// beyond, `phi` in `f64` has lost its fraction of a degree).
pub const MAX_PHI_DEG: f64 = 360.0;

/// Refuse a grid over its budget, before any work: `pairs` (channels x
/// theta_i x theta_o) over [`MAX_PAIRS`] x `budget`, or table values (pairs
/// x phi, when `table`) over [`MAX_TABLE_VALUES`] x `budget`; and azimuths
/// beyond [`MAX_PHI_DEG`].
///
/// # Errors
/// [`BsdfError::Input`] naming the grid sizes and the budget.
pub fn check_grid(
    channels: usize,
    request: &BsdfRequest,
    table: bool,
    budget: f64,
) -> Result<(), BsdfError> {
    let (ni, no, np) = (request.theta_i.len(), request.theta_o.len(), request.phi.len());
    if let Some(p) = request.phi.iter().find(|p| p.abs() > MAX_PHI_DEG) {
        return Err(BsdfError::Input {
            name: "phi",
            reason: format!("{p:e} degrees is outside [-{MAX_PHI_DEG}, {MAX_PHI_DEG}]"),
        });
    }
    let pairs = channels as f64 * ni as f64 * no as f64;
    let max_pairs = MAX_PAIRS as f64 * budget;
    if pairs > max_pairs {
        return Err(BsdfError::Input {
            name: "theta_o",
            reason: format!(
                "{channels} channel(s) x {ni} theta_i x {no} theta_o = {pairs:.0} angle pairs, \
                 over the budget of {max_pairs:.0} (about 1 kB each): use coarser angle \
                 lists, fewer channels, or raise the budget (--budget FACTOR)"
            ),
        });
    }
    let values = pairs * np as f64;
    let max_values = MAX_TABLE_VALUES as f64 * budget;
    if table && values > max_values {
        return Err(BsdfError::Input {
            name: "phi",
            reason: format!(
                "{pairs:.0} angle pairs x {np} phi = {values:.0} table values, over the \
                 budget of {max_values:.0}: use fewer azimuths or angles, or raise the \
                 budget (--budget FACTOR)"
            ),
        });
    }
    Ok(())
}

/// A BSDF file asked for in words (with the feature `clap`, `km bsdf`'s
/// flags): the angle lists as text ([`parse_angles`]), the side, the
/// streams, the format and the budget; [`BsdfRequest::from_lists`] reads it.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct BsdfLists {
    /// File format (default: from the extension of --out: .npz, .csv, .bsdf → fourier; else npz).
    #[cfg_attr(feature = "clap", arg(long, value_enum))]
    pub format: Option<BsdfFormat>,
    /// Incidence polar angles, degrees in [0, 90): a list `0,30,60`, a range
    /// `START:STOP:STEP` (STOP excluded) or `gauss:N` (arccosines of N Gauss
    /// nodes in mu). Default 0 and gauss:32 (npz, csv); for fourier, 48 angles
    /// uniform in theta from 0 (`0:90:1.875`).
    #[cfg_attr(feature = "clap", arg(long, allow_hyphen_values = true))]
    pub theta_i: Option<String>,
    /// Exit polar angles, degrees in [0, 90), same syntax; default the --theta-i
    /// given, else gauss:32 (npz, csv) or as --theta-i (fourier).
    #[cfg_attr(feature = "clap", arg(long, allow_hyphen_values = true))]
    pub theta_o: Option<String>,
    /// Azimuths, degrees (180 = mirror side), same syntax; default `0:360:5` (72).
    #[cfg_attr(feature = "clap", arg(long, allow_hyphen_values = true))]
    pub phi: Option<String>,
    /// Light from below (through a transparent substrate) instead of above [npz, csv].
    #[cfg_attr(feature = "clap", arg(long))]
    pub from_below: bool,
    /// Gauss nodes per hemisphere and Snell segment (default: as `km solve`
    /// would choose for the most demanding incidence).
    #[cfg_attr(feature = "clap", arg(long))]
    pub streams: Option<usize>,
    /// Stop the azimuthal series after two Fourier orders whose multiply
    /// scattered part is at most TOL of the largest order-0 coefficient, in
    /// [0, 0.1] (default 1e-9; docs/multiflux.md eq. 5j, docs/bsdf.md §1).
    #[cfg_attr(feature = "clap", arg(long, value_name = "TOL"))]
    pub fourier_tol: Option<f64>,
    /// Factor on the grid budgets (angle pairs, table values) and on the work
    /// budget of the operators (docs/limits.md).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = BsdfLists::default().budget))]
    pub budget: f64,
}

impl Default for BsdfLists {
    fn default() -> Self {
        BsdfLists {
            format: None,
            theta_i: None,
            theta_o: None,
            phi: None,
            from_below: false,
            streams: None,
            fourier_tol: None,
            budget: 1.0,
        }
    }
}

/// What a BSDF file is asked for.
#[derive(Debug, Clone)]
pub struct BsdfRequest {
    /// Incidence polar angles, degrees in [0, 90).
    pub theta_i: Vec<f64>,
    /// Exit polar angles, degrees in [0, 90).
    pub theta_o: Vec<f64>,
    /// Azimuths, degrees (180 = mirror side).
    pub phi: Vec<f64>,
    /// Light from the substrate side (npz, csv only).
    pub from_below: bool,
    /// Gauss nodes per hemisphere and Snell segment (`None`: the solver's choice).
    pub streams: Option<usize>,
    /// Where the azimuthal series stops (`MultifluxOptions::fourier_tol`;
    /// `None`: its default).
    pub fourier_tol: Option<f64>,
    /// The file format.
    pub format: BsdfFormat,
    /// Factor on the grid budgets of [`check_grid`] and on the work budget
    /// of the operators (default 1).
    pub budget: f64,
    /// For the Fourier file of a scene with other than 1 or 3 channels (a
    /// spectrum): the linear RGB each channel adds per unit value
    /// ([`FourierSettings::channel_mix`]); `None` otherwise.
    pub channel_mix: Option<Vec<[f64; 3]>>,
}

/// The angle lists of a [`BsdfRequest`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AngleList {
    /// Incidence polar angles.
    ThetaI,
    /// Exit polar angles.
    ThetaO,
    /// Azimuths.
    Phi,
}

/// A request that [`BsdfRequest::from_lists`] refuses.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RequestError {
    /// An angle list that [`parse_angles`] refuses.
    #[error("{list:?}: {source}")]
    Angles {
        /// Which list.
        list: AngleList,
        /// Why.
        source: AngleListError,
    },
    /// Light from below asked of a Fourier file, which holds both sides.
    #[error("light from below does not apply to the Fourier file (the file holds both sides)")]
    FromBelowInFourier,
    /// A budget factor that is not a finite number > 0.
    #[error("budget {0}: must be a finite factor > 0")]
    Budget(f64),
}

impl RequestError {
    /// The refusal in the words of `km bsdf`'s flags (`--theta-i`,
    /// `--theta-o`, `--phi`, `--from-below`, `--budget`).
    pub fn flag_words(&self) -> String {
        let (list, source) = match self {
            RequestError::Angles { list, source } => (list, source),
            RequestError::Budget(b) => {
                return format!("--budget must be a finite number > 0, not {b}");
            }
            RequestError::FromBelowInFourier => {
                return "--from-below does not apply to --format fourier (the file holds both \
                        sides)"
                    .into();
            }
        };
        let flag = match list {
            AngleList::ThetaI => "--theta-i",
            AngleList::ThetaO => "--theta-o",
            AngleList::Phi => "--phi",
        };
        match source {
            e @ AngleListError::Grid { .. } => format!("{flag} {e}"),
            e @ AngleListError::List { .. } => format!("{flag}: {e}"),
        }
    }
}

impl BsdfRequest {
    /// A request from angle lists as text ([`parse_angles`]); a list not
    /// given takes its default: `theta_i` the format's
    /// ([`BsdfFormat::default_theta_i`]), `theta_o` the `theta_i` when
    /// given, else [`BsdfFormat::default_theta`], `phi` [`default_phi`]; the
    /// format not given is that of the name of the file `out`
    /// ([`BsdfFormat::from_path`]).
    ///
    /// # Errors
    /// A list [`parse_angles`] refuses, naming the list; light from below
    /// for a Fourier file; a budget that is not a finite number > 0.
    ///
    /// ```
    /// use km::bsdf_file::{BsdfLists, BsdfRequest};
    /// let lists = BsdfLists { theta_i: Some("0,30".into()), ..Default::default() };
    /// let r = BsdfRequest::from_lists(&lists, Some("b.csv".as_ref())).unwrap();
    /// assert_eq!((r.theta_o.len(), r.phi.len()), (2, 72));
    /// ```
    pub fn from_lists(lists: &BsdfLists, out: Option<&Path>) -> Result<BsdfRequest, RequestError> {
        let format = lists.format.unwrap_or_else(|| BsdfFormat::from_path(out));
        let parse = |list: AngleList, text: &str| {
            parse_angles(text).map_err(|source| RequestError::Angles { list, source })
        };
        let given_i = lists.theta_i.as_deref().map(|t| parse(AngleList::ThetaI, t)).transpose()?;
        let theta_o = match &lists.theta_o {
            Some(t) => parse(AngleList::ThetaO, t)?,
            None => given_i.clone().unwrap_or_else(|| format.default_theta()),
        };
        let theta_i = given_i.unwrap_or_else(|| format.default_theta_i());
        let phi = match &lists.phi {
            Some(t) => parse(AngleList::Phi, t)?,
            None => default_phi(),
        };
        if format == BsdfFormat::Fourier && lists.from_below {
            return Err(RequestError::FromBelowInFourier);
        }
        if !(lists.budget.is_finite() && lists.budget > 0.0) {
            return Err(RequestError::Budget(lists.budget));
        }
        Ok(BsdfRequest {
            theta_i,
            theta_o,
            phi,
            from_below: lists.from_below,
            streams: lists.streams,
            fourier_tol: lists.fourier_tol,
            format,
            budget: lists.budget,
            channel_mix: None,
        })
    }
}

/// A computed BSDF, its meta JSON and (when asked) the file's bytes.
pub struct BsdfFile {
    /// The BSDF (light from the chosen side).
    pub bsdf: Bsdf,
    /// The azimuths of the table, degrees.
    pub phi: Vec<f64>,
    /// The meta JSON of the file (scene, solver, conventions, checks, seconds).
    pub meta: Value,
    /// Seconds spent computing the operators and the table.
    pub seconds: f64,
    /// The options of the table.
    pub options: BsdfOptions,
    /// The bytes of the file in the requested format, when asked for.
    pub bytes: Option<Vec<u8>>,
    /// For the CSV: the bytes of its totals file ([`totals_path`]), when asked for.
    pub totals: Option<Vec<u8>>,
}

/// The totals file beside a CSV BSDF file: `NAME.csv` -> `NAME.totals.csv`
/// (totals and delta parts per channel and incidence, `Table::totals_csv`).
///
/// ```
/// use std::path::Path;
/// let p = km::bsdf_file::totals_path(Path::new("out/paint.csv"));
/// assert_eq!(p, Path::new("out/paint.totals.csv"));
/// ```
pub fn totals_path(out: &Path) -> std::path::PathBuf {
    let stem = out.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    out.with_file_name(format!("{stem}.totals.csv"))
}

/// The BSDF of `scene` on the grids of `request`, its checks (energy,
/// reflection reciprocity, negative values: `docs/bsdf.md`) in the meta
/// JSON, and, when `with_bytes`, the file's bytes (the Fourier file solves
/// the stack from below as well when it transmits). `scene_file` and
/// `scene_text` are recorded in the meta.
///
/// # Errors
/// The solver's refusals and failures, grids outside their domains or over
/// their budgets ([`check_grid`], and the work of the operators,
/// `km_multiflux::budget::check_bsdf`, at the default multi-flux budget
/// times `request.budget`), and a Fourier file asked for light from below.
pub fn bsdf_file(
    scene: &Scene,
    scene_file: &str,
    scene_text: &str,
    request: &BsdfRequest,
    with_bytes: bool,
) -> Result<BsdfFile, BsdfError> {
    check_grid(scene.channels().len(), request, true, request.budget)?;
    let (theta_i, theta_o, phi) = (&request.theta_i, &request.theta_o, &request.phi);
    // The work budget of the operators (eq. W1 with a beam per incidence
    // angle), scaled as the grid's.
    let max_work = crate::multiflux_budget::DEFAULT_MAX_WORK * request.budget;
    let solver = MultifluxOptions {
        streams: request.streams,
        max_work: Some(max_work),
        fourier_tol: request.fourier_tol.unwrap_or(km_multiflux::options::FOURIER_TOL),
        ..Default::default()
    };
    let side = if request.from_below { Side::Below } else { Side::Above };
    let start = std::time::Instant::now();
    let options = BsdfOptions { solver: solver.clone(), side };
    let bsdf = Bsdf::new(scene, theta_i, theta_o, &options)?;
    let table = Table::new(&bsdf, phi)?;
    let seconds = start.elapsed().as_secs_f64();
    let mut meta = meta(&bsdf, phi, &solver, request.from_below);
    meta["scene_file"] = json!(scene_file);
    meta["scene"] = json!(scene_text);
    meta["channels"] = json!(scene.labels());
    meta["seconds"] = json!(seconds);
    let totals = (with_bytes && request.format == BsdfFormat::Csv).then(|| table.totals_csv());
    let bytes = if !with_bytes {
        None
    } else {
        Some(match request.format {
            BsdfFormat::Npz => table.npz(&meta_text(&meta)?),
            BsdfFormat::Csv => {
                let mut head = String::new();
                for line in meta_text(&meta)?.lines() {
                    head.push_str(&format!("# {line}\n"));
                }
                let mut b = head.into_bytes();
                b.extend(table.csv());
                b
            }
            BsdfFormat::Fourier => {
                let below = if bsdf.transmits {
                    let o = BsdfOptions { solver, side: Side::Below };
                    Some(Bsdf::new(scene, theta_i, theta_o, &o)?)
                } else {
                    None
                };
                let settings = FourierSettings {
                    channel_mix: request.channel_mix.clone(),
                    ..FourierSettings::default()
                };
                fourier(&bsdf, below.as_ref(), &settings)?
            }
        })
    };
    Ok(BsdfFile { bsdf, phi: phi.clone(), meta, seconds, options, bytes, totals })
}

impl BsdfFile {
    /// What was computed, in two or three lines for people: the file
    /// written to `out` (grid sizes, seconds), then the checks (energy,
    /// reflection reciprocity, negative values).
    pub fn summary(&self, out: Option<&Path>) -> String {
        let b = &self.bsdf;
        let mut s = String::new();
        if let Some(out) = out {
            s += &format!(
                "wrote {} ({} channel(s) x {} incidence x {} exit polar angles x {} azimuths) in \
                 {:.3} s\n",
                out.display(),
                b.channels.len(),
                b.theta_i.len(),
                b.theta_o.len(),
                self.phi.len(),
                self.seconds
            );
        }
        let checks = &self.meta["checks"];
        s + &format!(
            "checks: energy {:.1e}, reflection reciprocity {}, negative values {} of {}\n",
            checks["energy_max_error"].as_f64().unwrap_or(f64::NAN),
            checks["reflection_reciprocity_max_relative"]
                .as_f64()
                .map_or("n/a (grids differ)".into(), |v| format!("{v:.1e}")),
            checks["negative_values"],
            checks["values"]
        )
    }
}

/// The meta JSON as one line.
fn meta_text(meta: &Value) -> Result<String, BsdfError> {
    serde_json::to_string(meta)
        .map_err(|e| BsdfError::Input { name: "meta", reason: e.to_string() })
}

/// The meta JSON of a BSDF file: the solver, the conventions and the checks
/// (the scene and the seconds are filled in by [`bsdf_file`]).
fn meta(bsdf: &Bsdf, phi: &[f64], solver: &MultifluxOptions, from_below: bool) -> Value {
    let energy = check::energy(bsdf, phi.len().max(72));
    let recip = check::reciprocity(bsdf, &[0.0, 90.0, 180.0], 1e-6);
    let neg = check::negatives(bsdf, phi);
    json!({
        "km_version": env!("CARGO_PKG_VERSION"),
        "scene_file": null,
        "scene": null,
        "channels": null,
        "solver": {
            "method": "multiflux",
            "streams": bsdf.channels.iter().map(|c| c.streams).max(),
            "fourier_orders": (0..bsdf.channels.len()).map(|c| bsdf.orders(c)).max(),
            "delta_m": solver.delta_m,
            "single_scattering_correction": solver.delta_m,
        },
        "side": if from_below { "below" } else { "above" },
        "units": {"angles": "degrees", "brdf": "1/sr", "btdf": "1/sr"},
        "conventions": "light arrives from phi = 0; phi = 180 is the mirror side; theta from \
            the normal on each side; brdf/btdf are the smooth parts per unit irradiance on the \
            surface (divided by cos theta_i), delta parts in reflectance_specular and \
            transmittance_direct",
        "checks": {
            "energy_max_error": energy.max_error,
            "energy_rule": "hemispherical integral of the table (Gauss rule when theta_o is \
                gauss:N, else trapezoid in mu) plus delta parts, against the solver's totals",
            "reflection_reciprocity_max_relative": recip,
            "negative_values": neg.count,
            "values": neg.total,
            "most_negative": neg.worst.map(|w| json!({
                "value": w.0, "channel": w.1, "theta_i": w.2, "theta_o": w.3, "phi": w.4,
                "transmitted": w.5,
            })),
        },
        "seconds": null,
    })
}

/// A refusal or failure of [`BsdfFile::write`].
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    /// The totals file of a CSV would be the table itself (`--out NAME.totals.csv`).
    #[error("--out {}: the totals file would be the table itself", .0.display())]
    TotalsIsTable(std::path::PathBuf),
    /// A file could not be written.
    #[error("cannot write {}", path.display())]
    Io {
        /// The file.
        path: std::path::PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
}

impl BsdfFile {
    /// Write the file's bytes to `out` and, for a CSV, its totals beside it
    /// ([`totals_path`], written first), each atomically and never over one
    /// of `inputs`. Returns the totals file when one was written; nothing is
    /// written when the bytes were not asked for.
    ///
    /// # Errors
    /// [`WriteError`]: a totals file that would be `out`, or a failed write.
    pub fn write(
        &self,
        out: &Path,
        inputs: &[std::path::PathBuf],
    ) -> Result<Option<std::path::PathBuf>, WriteError> {
        use km_core::atomic_file::{WriteOptions, write_atomic_with};
        let Some(bytes) = &self.bytes else { return Ok(None) };
        let opts = WriteOptions { inputs: inputs.to_vec(), ..Default::default() };
        let write = |path: &Path, b: &[u8]| {
            write_atomic_with(path, b, &opts)
                .map_err(|source| WriteError::Io { path: path.to_path_buf(), source })
        };
        let totals = totals_path(out);
        if let Some(t) = &self.totals {
            if totals == out {
                return Err(WriteError::TotalsIsTable(out.to_path_buf()));
            }
            write(&totals, t)?;
        }
        write(out, bytes)?;
        Ok(self.totals.is_some().then_some(totals))
    }
}
