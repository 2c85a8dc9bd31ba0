//! `Rd(r)`: the radially resolved diffuse reflectance of a pencil beam, by
//! the dipole (normal incidence only; closed form, docs/diffusion.md eq.
//! D15) or by Monte Carlo (any incidence; annuli around the point of entry,
//! docs/montecarlo.md eq. R1); with depths, the dipole's fluence `phi(r, z)`
//! inside as well (eq. D14).

use std::fmt::Write;

use km_core::Scene;
use serde_json::{Value, json};

use crate::{KmError, Method, Reason, Unsupported};

/// The most values of `phi(r, z)` one profile gives per channel
/// (depths x radii).
pub const MAX_FLUENCE_VALUES: usize = 10_000_000;

/// Settings of [`profile()`] (with the feature `clap`, `km profile`'s flags).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct ProfileOptions {
    /// `Dipole` or `Mc`.
    #[cfg_attr(feature = "clap", arg(long, short, value_parser = crate::settings::command_line::method_parser(&[Method::Dipole, Method::Mc]), default_value = ProfileOptions::default().method.name(), help = "`dipole` (closed form) or `mc` (Monte Carlo annuli)"))]
    pub method: Method,
    /// Largest radius, in the scene's length unit; `None`: 10 transport mean
    /// free paths `1 / (sigma_a + sigma_s (1 - g))` of the first channel's layer.
    #[cfg_attr(
        feature = "clap",
        arg(
            long,
            help = "Largest radius, in the scene's length unit (default: 10 transport lengths)"
        )
    )]
    pub r_max: Option<f64>,
    /// Number of radii (dipole) or annuli (Monte Carlo), at least 1.
    #[cfg_attr(
        feature = "clap",
        arg(long, default_value_t = ProfileOptions::default().points, help = "Number of radii (dipole) or annuli (mc)")
    )]
    pub points: usize,
    /// Monte Carlo photons.
    #[cfg_attr(
        feature = "clap",
        arg(long, default_value_t = ProfileOptions::default().samples, help = "Monte Carlo photons [mc]")
    )]
    pub samples: u64,
    /// Monte Carlo seed.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = ProfileOptions::default().seed, help = "Monte Carlo seed [mc]"))]
    pub seed: u64,
    /// Depths at which the dipole also gives the fluence `phi(r, z)` at the
    /// same radii (empty: none; the dipole only).
    #[cfg_attr(feature = "clap", arg(long, value_delimiter = ',', num_args = 1.., help = "Depths at which to give the dipole's fluence phi(r, z) as well [dipole] (comma-separated, the layer's length unit)"))]
    pub depths: Vec<f64>,
}

impl Default for ProfileOptions {
    fn default() -> Self {
        ProfileOptions {
            method: Method::Dipole,
            r_max: None,
            points: 20,
            samples: 1_000_000,
            seed: 1,
            depths: Vec::new(),
        }
    }
}

/// `Rd(r)` per channel.
#[derive(Debug, Clone, PartialEq)]
pub struct Profile {
    /// The method used.
    pub method: Method,
    /// Radii (mid-points of the annuli), length unit of the scene.
    pub r: Vec<f64>,
    /// Per channel, `Rd(r_i)` in 1/length^2.
    pub rd: Vec<Vec<f64>>,
    /// Per channel, the standard errors (Monte Carlo).
    pub stderr: Option<Vec<Vec<f64>>>,
    /// Channel labels.
    pub labels: Vec<String>,
    /// The depths of [`Profile::fluence`] (empty: none asked for).
    pub depths: Vec<f64>,
    /// Per channel and depth, the dipole's fluence `phi(r_i, z)` of the
    /// pencil beam (eq. D14), 1/length^2 per unit power entering, diffuse
    /// light only; `None` without depths.
    pub fluence: Option<Vec<Vec<Vec<f64>>>>,
}

impl Profile {
    /// The JSON of `km profile --json` (docs/cli.md): one list per key for
    /// one channel, a list of lists for several.
    pub fn to_json(&self) -> Value {
        let pick = |v: &Vec<Vec<f64>>| if v.len() == 1 { json!(v[0]) } else { json!(v) };
        json!({
            "method": self.method.name(),
            "r": self.r,
            "rd": pick(&self.rd),
            "stderr": self.stderr.as_ref().map(pick),
            "channels": self.labels,
            "depths": self.depths,
            "fluence": self.fluence.as_ref().map(|f| if f.len() == 1 { json!(f[0]) } else { json!(f) }),
        })
    }

    /// The CSV of `km profile --format csv`: a header, then one row per
    /// radius: `r`, then `Rd` (and its standard error) per channel.
    pub fn csv(&self) -> String {
        let one = self.labels.len() == 1;
        let name = |base: &str, l: &str| if one { base.to_string() } else { format!("{base}_{l}") };
        let mut cols = vec!["r".to_string()];
        for l in &self.labels {
            cols.push(name("rd", l));
            if self.stderr.is_some() {
                cols.push(name("stderr_rd", l));
            }
            if self.fluence.is_some() {
                for z in &self.depths {
                    cols.push(name(&format!("phi_z{z}"), l));
                }
            }
        }
        let mut t = cols.join(",") + "\n";
        for (i, ri) in self.r.iter().enumerate() {
            let _ = write!(t, "{ri:e}");
            for (c, rd) in self.rd.iter().enumerate() {
                let _ = write!(t, ",{:e}", rd[i]);
                if let Some(se) = &self.stderr {
                    let _ = write!(t, ",{:e}", se[c][i]);
                }
                if let Some(f) = &self.fluence {
                    for row in &f[c] {
                        let _ = write!(t, ",{:e}", row[i]);
                    }
                }
            }
            t.push('\n');
        }
        t
    }

    /// The text table of `km profile`: `r` in the scene's length unit,
    /// `Rd(r)` per unit area (1/length^2), one column per channel.
    pub fn table(&self) -> String {
        let mut t = format!("{:>12}", "r [L]");
        for l in &self.labels {
            let name = if self.labels.len() == 1 { "Rd".to_string() } else { format!("Rd {l}") };
            let _ = write!(t, "{:>16}", format!("{name} [1/L^2]"));
            if self.fluence.is_some() {
                for z in &self.depths {
                    let _ = write!(t, "{:>16}", format!("phi z={z}"));
                }
            }
        }
        t.push('\n');
        for (i, ri) in self.r.iter().enumerate() {
            let _ = write!(t, "{ri:>12.5}");
            for (k, c) in self.rd.iter().enumerate() {
                let _ = write!(t, "{:>16.6e}", c[i]);
                if let Some(f) = &self.fluence {
                    for row in &f[k] {
                        let _ = write!(t, "{:>16.6e}", row[i]);
                    }
                }
            }
            t.push('\n');
        }
        t.push_str("L: the scene's length unit (that of 1/sigma_t)\n");
        if self.fluence.is_some() {
            t.push_str(
                "phi: the dipole's fluence of the pencil beam at depth z [1/L^2], diffuse light \
                 only (eq. D14)\n",
            );
        }
        t
    }
}

/// Refuse a light other than a collimated beam at normal incidence (the
/// dipole's profile is that of a normally incident pencil beam).
fn normal_incidence(scene: &Scene) -> Result<(), KmError> {
    for (channel, c) in scene.channels().iter().enumerate() {
        let light = match c.light() {
            km_core::Light::Collimated { theta_deg: 0.0 } => continue,
            km_core::Light::Collimated { theta_deg } => format!("a beam at {theta_deg} degrees"),
            km_core::Light::Diffuse => "diffuse light".to_string(),
        };
        let reason = Reason::NormalIncidenceOnly { channel, light };
        return Err(Unsupported { method: Method::Dipole, reason }.into());
    }
    Ok(())
}

/// `Rd(r)` of `scene` at `points` radii up to `r_max`.
///
/// Dipole: `Rd(r)` at `r_i = r_max (i + 1/2) / points` (docs/diffusion.md
/// eq. D11). Monte Carlo: the mean over annuli of width `r_max / points`
/// (docs/montecarlo.md eq. R1) around the point of entry, at the scene's
/// incidence. Domain: a single half-space layer at normal incidence for the
/// dipole (other light is refused with the reason); any scene for Monte Carlo.
/// With `depths` (dipole only), the fluence `phi(r_i, z)` of the pencil beam
/// at each depth as well (docs/diffusion.md eq. D14).
///
/// # Errors
/// A method other than the two, `points = 0`, a non-positive `r_max`, a
/// layer that neither scatters nor absorbs without `r_max`, depths with
/// Monte Carlo, a negative or non-finite depth, and the solvers' errors.
///
/// ```
/// let s = km_core::Scene::from_toml_str("[[layer]]\npreset = \"marble\"\n").unwrap();
/// let p = km::profile(&s, &km::ProfileOptions::default()).unwrap();
/// assert_eq!(p.rd[0].len(), 20);
/// assert!(p.rd[0].windows(2).all(|w| w[1] < w[0]), "Rd decreases with r");
/// ```
pub fn profile(scene: &Scene, opts: &ProfileOptions) -> Result<Profile, KmError> {
    let bad = |name, value: String, reason| Err(KmError::Option { name, value, reason });
    if opts.points == 0 {
        return bad("points", "0".into(), "at least 1 radius is needed");
    }
    if opts.points > km_montecarlo::options::MAX_RADIAL_BINS {
        return bad("points", opts.points.to_string(), "at most 1000000 radii (docs/limits.md)");
    }
    let Some(l) = scene.channels().first().and_then(|c| c.layers().first()) else {
        return bad("scene", "no layer".into(), "a profile needs a layer");
    };
    let sigma_t_prime = l.sigma_a() + l.sigma_s_reduced();
    let r_max = match opts.r_max {
        Some(r) if r.is_finite() && r > 0.0 => r,
        Some(r) => return bad("r_max", r.to_string(), "must be finite and > 0"),
        None if sigma_t_prime > 0.0 => 10.0 / sigma_t_prime,
        None => {
            return bad("r_max", "unset".into(), "the layer neither scatters nor absorbs: give it");
        }
    };
    let points = opts.points;
    if !opts.depths.is_empty() && opts.method != Method::Dipole {
        let value = format!("{} depths with --method {}", opts.depths.len(), opts.method.name());
        return bad("depths", value, "the fluence phi(r, z) comes from the dipole only");
    }
    // phi(r, z) holds points x depths values per channel: bounded.
    if opts.depths.len().saturating_mul(points) > MAX_FLUENCE_VALUES {
        let value = format!("{} depths x {points} radii", opts.depths.len());
        return bad("depths", value, "at most 10^7 values of phi(r, z) (depths x points)");
    }
    let mut fluence = None;
    let (r, rd, stderr) = match opts.method {
        Method::Dipole => {
            let d = km_dipole::DipoleOptions::default();
            crate::Solver::supports(&d, scene)?;
            normal_incidence(scene)?;
            // The width first: `r_max (i + 1/2)` overflows for r_max near 1e308.
            let dr = r_max / points as f64;
            let r: Vec<f64> = (0..points).map(|i| dr * (i as f64 + 0.5)).collect();
            let rd = km_dipole::profile(scene, &r, &d)?;
            if !opts.depths.is_empty() {
                fluence = Some(km_dipole::fluence_profile(scene, &r, &opts.depths, &d)?);
            }
            (r, rd, None)
        }
        Method::Mc => {
            let o = km_montecarlo::McOptions {
                samples: opts.samples,
                seed: opts.seed,
                ..Default::default()
            };
            let bins = km_montecarlo::RadialBins { dr: r_max / points as f64, count: points };
            let p = km_montecarlo::radial_profile(scene, &o, bins)?;
            (p.r, p.rd, Some(p.stderr))
        }
        m => {
            return Err(Unsupported { method: m, reason: Reason::NoProfile }.into());
        }
    };
    let labels = scene.labels().to_vec();
    Ok(Profile { method: opts.method, r, rd, stderr, labels, depths: opts.depths.clone(), fluence })
}
