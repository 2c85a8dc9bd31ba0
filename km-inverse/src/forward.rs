//! The forward model of a measured slab: the sample between optional glass
//! slides, lit by a normal collimated beam (and, for the sphere corrections,
//! by diffuse light), solved by km's multi-flux solver.
//!
//! The stack, top first (`docs/inverse.md` §1):
//!
//! ```text
//! air (n = 1) | slide (n_slide) | sample (tau = b, albedo = a, g, n_sample) | slide | air
//! ```
//!
//! The slides are clear (no absorption, no scattering), so their thickness
//! does not matter; every interface is Fresnel-reflecting and the multiple
//! reflections between them are added incoherently, as in Prahl's iad.

use km_core::{Layer, Light, MonoScene, Substrate};
use km_multiflux::{MultifluxOptions, solve_mono};

use crate::InverseError;

/// What is known about the sample besides its optical properties.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Physical thickness of the sample, length (`> 0`, finite); the
    /// coefficients `mu_a`, `mu_s` come out in 1/length.
    pub thickness: f64,
    /// Refractive index of the sample, `>= 1`.
    pub n_sample: f64,
    /// Refractive index of the clear slides on both faces (`None`: bare sample).
    pub n_slide: Option<f64>,
    /// Polar angle of the collimated beam, degrees, `[0, 90)` (default 0: normal).
    pub theta_deg: f64,
}

/// The smallest sample thickness accepted ([`Sample::new`]).
pub const MIN_THICKNESS: f64 = 1e-290;

impl Sample {
    /// A validated sample description.
    ///
    /// # Errors
    /// [`InverseError::Invalid`] for a thickness that is not positive and
    /// finite, or an index below 1 or not finite.
    ///
    /// ```
    /// use km_inverse::forward::Sample;
    /// assert!(Sample::new(1.0, 1.4, Some(1.5)).is_ok());
    /// assert!(Sample::new(0.0, 1.4, None).is_err());
    /// ```
    pub fn new(thickness: f64, n_sample: f64, n_slide: Option<f64>) -> Result<Self, InverseError> {
        if !(thickness.is_finite() && thickness > 0.0) {
            return Err(InverseError::invalid("thickness", thickness, "must be finite and > 0"));
        }
        // mu = tau / thickness must stay finite for every optical thickness
        // of the search (up to 1e6 and more): below 1e-290 it overflows.
        if thickness < MIN_THICKNESS {
            return Err(InverseError::invalid(
                "thickness",
                thickness,
                &format!(
                    "is below {MIN_THICKNESS:e}: mu = tau / thickness would overflow; \
                     rescale the length unit"
                ),
            ));
        }
        check_index("n_sample", n_sample)?;
        if let Some(n) = n_slide {
            check_index("n_slide", n)?;
        }
        Ok(Sample { thickness, n_sample, n_slide, theta_deg: 0.0 })
    }

    /// The same sample lit at `theta_deg` from the normal.
    ///
    /// # Errors
    /// [`InverseError::Invalid`] for an angle outside `[0, 90)`.
    pub fn with_incidence(self, theta_deg: f64) -> Result<Self, InverseError> {
        if !(0.0..90.0).contains(&theta_deg) {
            return Err(InverseError::invalid(
                "incidence",
                theta_deg,
                "must lie in [0, 90) degrees",
            ));
        }
        Ok(Sample { theta_deg, ..self })
    }
}

fn check_index(name: &str, n: f64) -> Result<(), InverseError> {
    if n.is_finite() && (1.0..=10.0).contains(&n) {
        Ok(())
    } else {
        Err(InverseError::invalid(name, n, "must lie in [1, 10]"))
    }
}

/// Optical properties of the sample in iad's variables.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Optical {
    /// Single-scattering albedo `a = mu_s / (mu_a + mu_s)`, in `[0, 1]`.
    pub albedo: f64,
    /// Optical thickness `b = (mu_a + mu_s) d`, `>= 0`.
    pub tau: f64,
    /// Henyey–Greenstein asymmetry, `(-1, 1)`.
    pub g: f64,
}

/// The totals a measurement sees (fractions of the incident power).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Totals {
    /// Total reflectance for normal collimated light (`UR1` in iad), specular included.
    pub r_total: f64,
    /// Its specular part: the unscattered light reflected by the interfaces (`R_u`).
    pub r_specular: f64,
    /// Total transmittance for normal collimated light (`UT1`), unscattered beam included.
    pub t_total: f64,
    /// Its unscattered part (`T_u`, Beer–Lambert with the interface reflections).
    pub t_unscattered: f64,
    /// Total reflectance for diffuse light (`URU`); only filled on request.
    pub r_diffuse: f64,
    /// Total transmittance for diffuse light (`UTU`); only filled on request.
    pub t_diffuse: f64,
}

/// Build the stack of [`Sample`] with properties `p` under `light`.
fn scene(sample: &Sample, p: &Optical, light: Light) -> Result<MonoScene, InverseError> {
    let mut layers = Vec::with_capacity(3);
    // A clear slide: no absorption, no scattering (thickness irrelevant).
    let slide = |n: f64| Layer::new(0.0, 0.0, 1.0, 0.0, n);
    if let Some(n) = sample.n_slide {
        layers.push(slide(n)?);
    }
    layers.push(Layer::from_tau_albedo(p.tau, p.albedo, p.g, sample.n_sample)?);
    if let Some(n) = sample.n_slide {
        layers.push(slide(n)?);
    }
    Ok(MonoScene::new(light, 1.0, layers, Substrate::Transparent { n: 1.0 }, Vec::new())?)
}

/// Forward model: the totals of the sample with properties `p`, computed by
/// km's multi-flux solver (`km_multiflux::solve_mono`) at `streams` Gauss
/// nodes per hemisphere, delta-M scaled; with `diffuse` also the totals for
/// diffuse light (needed by the sphere equations, `crate::sphere`).
///
/// # Reference
/// Multi-flux solver: `docs/multiflux.md` (seed 000 eq. 17–21); the
/// measured quantities are iad's `UR1`, `UT1`, `URU`, `UTU`, `R_u`, `T_u`
/// (Prahl, iad manual, §"Calculating R and T").
///
/// # Errors
/// Properties outside their domain, or a solver failure.
///
/// ```
/// use km_inverse::forward::{Optical, Sample, totals};
/// let s = Sample::new(1.0, 1.4, Some(1.5)).unwrap();
/// let t = totals(&s, &Optical { albedo: 0.9, tau: 1.0, g: 0.0 }, 16, false).unwrap();
/// assert!(t.r_total > t.r_specular && t.t_total > t.t_unscattered);
/// ```
pub fn totals(
    sample: &Sample,
    p: &Optical,
    streams: usize,
    diffuse: bool,
) -> Result<Totals, InverseError> {
    let opts = MultifluxOptions { streams: Some(streams), ..MultifluxOptions::default() };
    let collimated = scene(sample, p, Light::Collimated { theta_deg: sample.theta_deg })?;
    let (c, _) = solve_mono(&collimated, &opts)?;
    let mut out = Totals {
        r_total: c.reflectance,
        r_specular: c.reflectance_specular,
        t_total: c.transmittance,
        t_unscattered: c.transmittance_direct,
        r_diffuse: f64::NAN,
        t_diffuse: f64::NAN,
    };
    if diffuse {
        let (d, _) = solve_mono(&scene(sample, p, Light::Diffuse)?, &opts)?;
        out.r_diffuse = d.reflectance;
        out.t_diffuse = d.transmittance;
    }
    Ok(out)
}

/// Reflectance and transmittance of the sample's boundary at normal
/// incidence: the air–slide–sample interfaces added incoherently,
///
/// `R_12 = r_a + t_a^2 r_b / (1 - r_a r_b)`, `T_12 = t_a t_b / (1 - r_a r_b)`, (F1)
///
/// with `r = ((n_1 - n_2) / (n_1 + n_2))^2` and `t = 1 - r` for each interface.
///
/// # Reference
/// Fresnel at normal incidence (Born & Wolf §1.5.3); incoherent sums of
/// multiple reflections (Prahl, iad manual, "glass slides").
///
/// ```
/// let (r, t) = km_inverse::forward::boundary(1.5, None);
/// assert!((r - 0.04).abs() < 1e-15 && (r + t - 1.0).abs() < 1e-15);
/// ```
pub fn boundary(n_sample: f64, n_slide: Option<f64>) -> (f64, f64) {
    let fresnel = |n1: f64, n2: f64| ((n1 - n2) / (n1 + n2)).powi(2);
    match n_slide {
        None => {
            let r = fresnel(1.0, n_sample);
            (r, 1.0 - r)
        }
        Some(n) => {
            let (r_a, r_b) = (fresnel(1.0, n), fresnel(n, n_sample));
            let (t_a, t_b) = (1.0 - r_a, 1.0 - r_b);
            let d = 1.0 - r_a * r_b;
            (r_a + t_a * t_a * r_b / d, t_a * t_b / d)
        }
    }
}

/// Unscattered transmittance of the sample between its boundaries (F1):
///
/// `T_u = T_12^2 e^{-b} / (1 - R_12^2 e^{-2b})`. (F2)
///
/// # Reference
/// Beer–Lambert with incoherent interface reflections (Prahl, iad manual,
/// "unscattered transmission").
pub fn unscattered_transmittance(n_sample: f64, n_slide: Option<f64>, tau: f64) -> f64 {
    let (r, t) = boundary(n_sample, n_slide);
    let x = (-tau).exp();
    t * t * x / (1.0 - r * r * x * x)
}

/// The optical thickness from a measured unscattered transmittance, the
/// positive root of (F2) as a quadratic in `x = e^{-b}`:
///
/// `R^2 T_u x^2 + T^2 x - T_u = 0`, `b = -ln x`. (F3)
///
/// # Errors
/// `m_u` outside `(0, T_12^2 / (1 - R_12^2))` (the value at `b = 0`).
///
/// ```
/// use km_inverse::forward::{tau_from_unscattered, unscattered_transmittance};
/// let tu = unscattered_transmittance(1.4, Some(1.5), 2.0);
/// assert!((tau_from_unscattered(tu, 1.4, Some(1.5)).unwrap() - 2.0).abs() < 1e-12);
/// ```
pub fn tau_from_unscattered(
    m_u: f64,
    n_sample: f64,
    n_slide: Option<f64>,
) -> Result<f64, InverseError> {
    let (r, t) = boundary(n_sample, n_slide);
    let top = unscattered_transmittance(n_sample, n_slide, 0.0);
    if !(m_u > 0.0 && m_u < top) {
        return Err(InverseError::invalid(
            "m_u",
            m_u,
            &format!("must lie in (0, {top:.6}) (the boundaries alone transmit {top:.6})"),
        ));
    }
    let (qa, qb) = (r * r * m_u, t * t);
    // Stable root of qa x^2 + qb x - m_u = 0 (no cancellation: qb > 0).
    let x = 2.0 * m_u / (qb + (qb * qb + 4.0 * qa * m_u).sqrt());
    Ok(-x.ln())
}
