//! A request of [`super::field`] in the words its front ends use: `km
//! field`'s flags (with the feature `clap`, this type *is* those flags) and
//! `km.field`'s keyword arguments. One default per setting, one check of
//! each, and one conversion into [`FieldOptions`].

use km_dipole::{DipoleModel, DipoleOptions, FdrModel};

use super::{DEFAULT_INSIDE_CONE_DEG, FieldMethod, FieldOptions};
use crate::Method;
use crate::error::KmError;

/// The method and settings of a depth-field request (`km field`, `km.field`).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct FieldRequest {
    /// The method.
    #[cfg_attr(feature = "clap", arg(long, short, value_parser = crate::settings::command_line::method_parser(&Method::ALL), default_value = FieldRequest::default().method.name(), help = "Method: multiflux, km (two-flux), mc or dipole (direction-set refuses with the reason)"))]
    pub method: Method,
    /// Depths instead of the scene's `[output] depths`.
    #[cfg_attr(feature = "clap", arg(long, value_delimiter = ',', num_args = 1.., help = "Depths instead of the scene's [output] depths (comma-separated, the layers' length unit)"))]
    pub depths: Option<Vec<f64>>,
    /// Gauss nodes per hemisphere (multi-flux; `None`: the solver's choice).
    #[cfg_attr(
        feature = "clap",
        arg(long, help = "Gauss nodes per hemisphere [multiflux] (default: the solver's choice)")
    )]
    pub streams: Option<usize>,
    /// Monte Carlo photons, at least 1.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = FieldRequest::default().samples, help = "Monte Carlo photons [mc]"))]
    pub samples: u64,
    /// Monte Carlo seed.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = FieldRequest::default().seed, help = "Monte Carlo seed [mc]"))]
    pub seed: u64,
    /// Monte Carlo depth-bin width (`None`: half the smallest gap between depths).
    #[cfg_attr(
        feature = "clap",
        arg(
            long,
            help = "Monte Carlo depth-bin width [mc] (default: half the smallest gap between depths)"
        )
    )]
    pub dz: Option<f64>,
    /// Directions `[theta, phi]` (degrees) of the radiance inside instead of
    /// the scene's `[output] inside_directions_deg`.
    #[cfg_attr(feature = "clap", arg(long, value_delimiter = ',', num_args = 1.., value_parser = parse_direction, help = "Directions of the radiance inside, THETA:PHI in degrees, comma-separated (theta from the downward normal, > 90 up-going) instead of the scene's [output] inside_directions_deg [multiflux, mc]"))]
    pub directions: Option<Vec<[f64; 2]>>,
    /// Half-angle (degrees) of the cone the Monte Carlo radiance inside is averaged over.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = FieldRequest::default().mc_cone, help = "Half-angle in degrees of the cone the Monte Carlo radiance inside is averaged over [mc]"))]
    pub mc_cone: f64,
    /// How the dipole's `F_dr` is computed.
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value_t = FieldRequest::default().fdr, help = "How F_dr is computed [dipole]"))]
    pub fdr: FdrModel,
    /// Which dipole.
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value_t = FieldRequest::default().dipole, help = "Which dipole [dipole]"))]
    pub dipole: DipoleModel,
}

impl Default for FieldRequest {
    fn default() -> Self {
        let d = DipoleOptions::default();
        FieldRequest {
            method: Method::Multiflux,
            depths: None,
            streams: None,
            samples: 100_000,
            seed: 1,
            dz: None,
            directions: None,
            mc_cone: DEFAULT_INSIDE_CONE_DEG,
            fdr: d.fdr,
            dipole: d.model,
        }
    }
}

impl FieldRequest {
    /// The options of [`super::field`] for this request.
    ///
    /// # Errors
    /// [`KmError::Option`] naming `samples` when it is 0.
    pub fn options(&self) -> Result<FieldOptions, KmError> {
        if self.samples == 0 {
            return Err(KmError::Option {
                name: "samples",
                value: "0".into(),
                reason: "need at least one photon",
            });
        }
        let mut opts = FieldOptions {
            method: FieldMethod(self.method),
            dz: self.dz,
            directions: self.directions.clone(),
            mc_cone_deg: Some(self.mc_cone),
            dipole: DipoleOptions { fdr: self.fdr, model: self.dipole },
            ..Default::default()
        };
        opts.multiflux.streams = self.streams;
        opts.mc.samples = self.samples;
        opts.mc.seed = self.seed;
        Ok(opts)
    }
}

/// A direction written `THETA:PHI` in degrees (`km field --directions`).
///
/// # Errors
/// The text and what is wrong with it.
///
/// ```
/// assert_eq!(km::field::parse_direction("30:90"), Ok([30.0, 90.0]));
/// assert!(km::field::parse_direction("30").is_err());
/// ```
pub fn parse_direction(s: &str) -> Result<[f64; 2], String> {
    let (t, p) = s.split_once(':').ok_or_else(|| format!("{s}: expected THETA:PHI in degrees"))?;
    let num = |x: &str| x.trim().parse::<f64>().map_err(|e| format!("{s}: {e}"));
    Ok([num(t)?, num(p)?])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The request's options are `FieldOptions`' own defaults where the
    /// request leaves a setting at its default (one default per setting).
    #[test]
    fn default_request_gives_the_default_options() {
        let o = FieldRequest::default().options().unwrap();
        let d = FieldOptions::default();
        assert_eq!(o.method, d.method);
        assert_eq!(o.multiflux.streams, d.multiflux.streams);
        assert_eq!((o.mc.samples, o.mc.seed), (100_000, 1));
        assert_eq!(o.mc_cone_deg, Some(DEFAULT_INSIDE_CONE_DEG));
        assert_eq!(o.dipole, d.dipole);
        assert!(o.directions.is_none() && o.dz.is_none());
    }

    #[test]
    fn zero_photons_are_refused_by_name() {
        let r = FieldRequest { samples: 0, ..Default::default() };
        let e = r.options().unwrap_err().to_string();
        assert!(e.contains("samples") && e.contains("at least one photon"), "{e}");
    }
}
