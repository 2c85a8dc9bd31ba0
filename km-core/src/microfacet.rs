//! Rough interfaces: the microfacet BSDF of Walter et al. (2007), as
//! Mitsuba 3's `roughdielectric`/`roughconductor` and pbrt evaluate it.
//!
//! A rough face is a height field of mirror facets whose normals `h` follow
//! a distribution `D(h)` of roughness `alpha` (docs/rough.md eq. R1–R2):
//!
//! ```text
//!   GGX (Trowbridge–Reitz):  D(h) = alpha^2 / (pi cos^4 t (alpha^2 + tan^2 t)^2)
//!                            Lambda(v) = (-1 + sqrt(1 + alpha^2 tan^2 t_v)) / 2
//!   Beckmann:                D(h) = exp(-tan^2 t / alpha^2) / (pi alpha^2 cos^4 t)
//!                            Lambda(v) = (erf(a) - 1)/2 + exp(-a^2)/(2 a sqrt(pi)),  a = 1/(alpha tan t_v)
//!   G1(v, h) = 1 / (1 + Lambda(v))  if (v.h)(v.n) > 0, else 0;   G = G1(i, h) G1(o, h)
//! ```
//!
//! and the BSDF for light arriving from `i` (both `i` and `o` point away
//! from the surface; `n_i` the index on the side of `i`, `n_o` on the side
//! of `o`) is (Walter et al. 2007 eq. 20, 21):
//!
//! ```text
//!   f_r = F(i.h) D(h) G / (4 |i.n| |o.n|),                          h = (i + o)/|i + o|      (R3)
//!   f_t = |i.h| |o.h| / (|i.n| |o.n|) n_o^2 (1 - F(i.h)) D(h) G
//!         / (n_i (i.h) + n_o (o.h))^2,                               h = -(n_i i + n_o o)/|..|  (R4)
//! ```
//!
//! `f` is per unit incident irradiance on the surface (1/sr); `f_t` is the
//! radiance BTDF (it carries the `n^2` law: `f_t / n_o^2` is reciprocal).
//! `F` is the unpolarised Fresnel reflectance of the microfacet: dielectric
//! ([`crate::fresnel::reflectance`]) or conductor ([`conductor_reflectance`],
//! complex index `n + i k`). Single scattering only: light that hits a second
//! facet is lost, so `R + T < 1` at large roughness ([`Microfacet::albedo`]
//! reports the loss).
//!
//! Visible-normal sampling (Heitz 2018 for GGX; for Beckmann the
//! distribution of visible normals is sampled by inverting its slope CDF,
//! Heitz & d'Eon 2014, in [`Microfacet::sample_visible`]).
//!
//! # References
//! - B. Walter, S. Marschner, H. Li, K. Torrance, "Microfacet models for
//!   refraction through rough surfaces", EGSR 2007.
//! - E. Heitz, "Sampling the GGX distribution of visible normals", JCGT 7(4) 2018.
//! - E. Heitz, E. d'Eon, "Importance sampling microfacet-based BSDFs using the
//!   distribution of visible normals", EGSR 2014.

use std::f64::consts::PI;

use crate::error::CoreError;

/// The distribution of microfacet normals.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Distribution {
    /// GGX / Trowbridge–Reitz (the default, as Mitsuba 3 and pbrt-v4).
    Ggx,
    /// Beckmann (Gaussian slopes).
    Beckmann,
}

impl Distribution {
    /// The scene file's name of the distribution.
    pub fn name(self) -> &'static str {
        match self {
            Distribution::Ggx => "ggx",
            Distribution::Beckmann => "beckmann",
        }
    }

    /// The distribution named `s` (`"ggx"` or `"beckmann"`).
    pub fn from_name(s: &str) -> Option<Distribution> {
        match s {
            "ggx" | "GGX" => Some(Distribution::Ggx),
            "beckmann" | "Beckmann" => Some(Distribution::Beckmann),
            _ => None,
        }
    }
}

/// Largest accepted roughness: beyond `alpha = 1` the facets of either
/// distribution are mostly steeper than 45 degrees and the single-scattering
/// model loses over 40 % of the light (docs/rough.md table R1).
pub const MAX_ALPHA: f64 = 1.0;

/// A rough face: isotropic roughness `alpha` of a normal distribution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Microfacet {
    alpha: f64,
    distribution: Distribution,
}

impl Microfacet {
    /// A rough face of roughness `alpha` (checked: `0 < alpha <= 1`).
    ///
    /// # Errors
    /// A [`CoreError::Invalid`] on `roughness` outside `(0, 1]`.
    ///
    /// ```
    /// use km_core::microfacet::{Distribution, Microfacet};
    /// assert!(Microfacet::new(0.1, Distribution::Ggx).is_ok());
    /// assert!(Microfacet::new(0.0, Distribution::Ggx).is_err());
    /// ```
    pub fn new(alpha: f64, distribution: Distribution) -> Result<Microfacet, CoreError> {
        if !(alpha > 0.0 && alpha <= MAX_ALPHA) {
            return Err(CoreError::invalid("roughness", alpha, "must lie in (0, 1] (0 = smooth)"));
        }
        Ok(Microfacet { alpha, distribution })
    }

    /// Roughness `alpha` (the slope scale), `(0, 1]`.
    pub fn alpha(&self) -> f64 {
        self.alpha
    }

    /// The normal distribution.
    pub fn distribution(&self) -> Distribution {
        self.distribution
    }

    /// The normal distribution `D(h)` per unit solid angle of `h`, from the
    /// cosine `cos_h` of the facet normal with the macro normal (eq. R1);
    /// `integral D(h) cos_h dw_h = 1`.
    pub fn d(&self, cos_h: f64) -> f64 {
        if cos_h <= 0.0 {
            return 0.0;
        }
        let c2 = cos_h * cos_h;
        let a2 = self.alpha * self.alpha;
        match self.distribution {
            Distribution::Ggx => {
                // alpha^2 / (pi (c2 (alpha^2 - 1) + 1)^2), written without tan.
                let t = c2 * (a2 - 1.0) + 1.0;
                a2 / (PI * t * t)
            }
            Distribution::Beckmann => {
                let tan2 = (1.0 - c2).max(0.0) / c2;
                (-tan2 / a2).exp() / (PI * a2 * c2 * c2)
            }
        }
    }

    /// `D(h)` of a facet normal given as a unit vector (eq. R1), from its
    /// tangential part `h_x^2 + h_y^2` rather than `1 - h_z^2`: exact near the
    /// normal, where the lobe of a small roughness lives (`alpha^2` would drown
    /// in the rounding of `1 - cos^2`).
    pub fn d_h(&self, h: V3) -> f64 {
        if h[2] <= 0.0 {
            return 0.0;
        }
        let (c2, s2) = (h[2] * h[2], h[0] * h[0] + h[1] * h[1]);
        let a2 = self.alpha * self.alpha;
        match self.distribution {
            Distribution::Ggx => {
                let t = c2 * a2 + s2;
                a2 / (PI * t * t)
            }
            Distribution::Beckmann => (-s2 / (c2 * a2)).exp() / (PI * a2 * c2 * c2),
        }
    }

    /// Smith's `Lambda(v)` for a direction of cosine `cos_v` with the normal (eq. R2).
    pub fn lambda(&self, cos_v: f64) -> f64 {
        let c = cos_v.abs().min(1.0);
        let s2 = ((1.0 - c) * (1.0 + c)).max(0.0);
        if s2 == 0.0 {
            return 0.0;
        }
        if c == 0.0 {
            return f64::INFINITY;
        }
        match self.distribution {
            Distribution::Ggx => {
                let x = self.alpha * self.alpha * s2 / (c * c);
                // (-1 + sqrt(1 + x)) / 2 without cancellation at small x.
                0.5 * x / (1.0 + (1.0 + x).sqrt())
            }
            Distribution::Beckmann => {
                let a = c / (self.alpha * s2.sqrt());
                0.5 * ((-a * a).exp() / (a * PI.sqrt()) - erfc(a))
            }
        }
    }

    /// Smith's masking `G1(v, h) = 1/(1 + Lambda(v))`, zero when `v` sees the
    /// back of the facet (`(v.h)(v.n) <= 0`); `cos_v = v.n`, `v_dot_h = v.h`.
    pub fn g1(&self, cos_v: f64, v_dot_h: f64) -> f64 {
        if v_dot_h * cos_v <= 0.0 {
            return 0.0;
        }
        1.0 / (1.0 + self.lambda(cos_v))
    }
}

/// `erfc(x)` for `x >= 0` to about 1e-15 relative (Taylor series of `erf`
/// below 2, Lentz's continued fraction of `erfc` above; Abramowitz & Stegun
/// 7.1.5 and 7.1.14).
pub fn erfc(x: f64) -> f64 {
    if x < 0.0 {
        return 2.0 - erfc(-x);
    }
    if x < 2.0 {
        // erf(x) = 2/sqrt(pi) sum (-1)^k x^(2k+1) / (k! (2k+1)).
        let (mut term, mut sum, x2) = (x, x, x * x);
        for k in 1..80 {
            term *= -x2 / k as f64;
            let add = term / (2 * k + 1) as f64;
            sum += add;
            if add.abs() < 1e-17 * sum.abs() {
                break;
            }
        }
        return 1.0 - 2.0 / PI.sqrt() * sum;
    }
    // erfc(x) = exp(-x^2)/sqrt(pi) * 1/(x + 1/2/(x + 1/(x + 3/2/(x + ...)))).
    let tiny = 1e-300;
    let (mut f, mut c, mut d) = (x, x, 0.0);
    for k in 1..200 {
        let a = k as f64 / 2.0;
        d = x + a * d;
        d = if d == 0.0 { 1.0 / tiny } else { 1.0 / d };
        c = x + a / c;
        if c == 0.0 {
            c = tiny;
        }
        let delta = c * d;
        f *= delta;
        if (delta - 1.0).abs() < 1e-16 {
            break;
        }
    }
    (-x * x).exp() / (PI.sqrt() * f)
}

/// Unpolarised Fresnel reflectance of a conductor of complex index
/// `n_c = n + i k` under a dielectric of index `n_i`, for the incidence
/// cosine `cos_i` (Born & Wolf §14.2; docs/rough.md eq. R5):
///
/// ```text
///   eta = n_c / n_i,  cos_t = sqrt(1 - (1 - cos_i^2) / eta^2)   (complex)
///   r_s = (cos_i - eta cos_t)/(cos_i + eta cos_t),  r_p = (eta cos_i - cos_t)/(eta cos_i + cos_t)
///   R = (|r_s|^2 + |r_p|^2) / 2
/// ```
///
/// At `k = 0` it is the dielectric reflectance of [`crate::fresnel::reflectance`]
/// (total internal reflection included).
///
/// ```
/// use km_core::microfacet::conductor_reflectance;
/// // k = 0: a dielectric, ((1.5 - 1)/(1.5 + 1))^2 at normal incidence.
/// assert!((conductor_reflectance(1.0, 1.0, 1.5, 0.0) - 0.04).abs() < 1e-15);
/// // Normal incidence on a metal: ((n - 1)^2 + k^2)/((n + 1)^2 + k^2).
/// let r = conductor_reflectance(1.0, 1.0, 0.2, 3.0);
/// assert!((r - (0.64 + 9.0) / (1.44 + 9.0)).abs() < 1e-14);
/// ```
pub fn conductor_reflectance(cos_i: f64, n_i: f64, n: f64, k: f64) -> f64 {
    let c = cos_i.abs().min(1.0);
    let eta = C::new(n / n_i, k / n_i);
    let s2 = (1.0 - c) * (1.0 + c);
    let cos_t = (C::new(1.0, 0.0) - C::new(s2, 0.0) / (eta * eta)).sqrt();
    let ci = C::new(c, 0.0);
    let rs = (ci - eta * cos_t) / (ci + eta * cos_t);
    let rp = (eta * ci - cos_t) / (eta * ci + cos_t);
    let r = 0.5 * (rs.norm2() + rp.norm2());
    if r.is_finite() { r.clamp(0.0, 1.0) } else { 1.0 }
}

/// A minimal complex number (the one place this crate needs complex arithmetic).
#[derive(Debug, Clone, Copy)]
struct C {
    re: f64,
    im: f64,
}

impl C {
    fn new(re: f64, im: f64) -> C {
        C { re, im }
    }
    fn norm2(self) -> f64 {
        self.re * self.re + self.im * self.im
    }
    /// The principal square root (non-negative real part).
    fn sqrt(self) -> C {
        let r = self.norm2().sqrt();
        let re = (0.5 * (r + self.re)).max(0.0).sqrt();
        let im = (0.5 * (r - self.re)).max(0.0).sqrt();
        C::new(re, if self.im < 0.0 { -im } else { im })
    }
}

impl std::ops::Add for C {
    type Output = C;
    fn add(self, o: C) -> C {
        C::new(self.re + o.re, self.im + o.im)
    }
}

impl std::ops::Sub for C {
    type Output = C;
    fn sub(self, o: C) -> C {
        C::new(self.re - o.re, self.im - o.im)
    }
}

impl std::ops::Mul for C {
    type Output = C;
    fn mul(self, o: C) -> C {
        C::new(self.re * o.re - self.im * o.im, self.re * o.im + self.im * o.re)
    }
}

impl std::ops::Div for C {
    type Output = C;
    fn div(self, o: C) -> C {
        let d = o.norm2();
        C::new((self.re * o.re + self.im * o.im) / d, (self.im * o.re - self.re * o.im) / d)
    }
}

/// What lies on the far side of a rough face: a dielectric of index `n`, or
/// a conductor of complex index `n + i k` (opaque: reflection only).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Far {
    /// A dielectric of index `n`.
    Dielectric(f64),
    /// A conductor of complex index `n + i k`.
    Conductor(f64, f64),
}

/// A unit vector `[x, y, z]` in the frame of the face (`z` along the normal
/// on the side of the light's arrival).
pub type V3 = [f64; 3];

fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn normalize(a: V3) -> Option<V3> {
    let l = dot(a, a).sqrt();
    (l > 0.0 && l.is_finite()).then(|| [a[0] / l, a[1] / l, a[2] / l])
}

impl Microfacet {
    /// The microfacet BSDF (eq. R3, R4) for light arriving from `i`
    /// (`i[2] > 0`: `i` points back into the medium of index `n_i`) and
    /// leaving towards `o` (`o[2] > 0`: reflected; `o[2] < 0`: transmitted
    /// into `far`). Per unit incident irradiance on the face, 1/sr.
    pub fn bsdf(&self, i: V3, o: V3, n_i: f64, far: Far) -> f64 {
        let (ci, co) = (i[2], o[2]);
        if ci <= 0.0 || co == 0.0 {
            return 0.0;
        }
        if co > 0.0 {
            // Reflection: the half vector.
            let Some(h) = normalize([i[0] + o[0], i[1] + o[1], i[2] + o[2]]) else {
                return 0.0;
            };
            let ih = dot(i, h);
            let g = self.g1(ci, ih) * self.g1(co, dot(o, h));
            if g == 0.0 {
                return 0.0;
            }
            let f = match far {
                Far::Dielectric(n_t) => crate::fresnel::reflectance(ih, n_i, n_t),
                Far::Conductor(n, k) => conductor_reflectance(ih, n_i, n, k),
            };
            return f * self.d_h(h) * g / (4.0 * ci * co);
        }
        let Far::Dielectric(n_o) = far else {
            return 0.0;
        };
        if n_o == n_i {
            // No index change: every facet transmits straight on (a delta).
            return 0.0;
        }
        // Refraction: the generalised half vector, on the side of the normal.
        let Some(mut h) =
            normalize([n_i * i[0] + n_o * o[0], n_i * i[1] + n_o * o[1], n_i * i[2] + n_o * o[2]])
        else {
            return 0.0;
        };
        if h[2] < 0.0 {
            h = [-h[0], -h[1], -h[2]];
        }
        let (ih, oh) = (dot(i, h), dot(o, h));
        // Physical refraction needs i and o on opposite sides of the facet.
        if ih <= 0.0 || oh >= 0.0 {
            return 0.0;
        }
        let g = self.g1(ci, ih) * self.g1(co, oh);
        if g == 0.0 {
            return 0.0;
        }
        let f = crate::fresnel::reflectance(ih, n_i, n_o);
        let den = n_i * ih + n_o * oh;
        (ih * oh).abs() / (ci * co).abs() * n_o * n_o * (1.0 - f) * self.d_h(h) * g / (den * den)
    }
}

impl Microfacet {
    /// A facet normal sampled for a viewer at `v` (`v[2] > 0`) from two
    /// uniform numbers: GGX by its distribution of visible normals
    /// `D_v(h) = G1(v, h) max(0, v.h) D(h) / v_z` (Heitz 2018); Beckmann by
    /// `D(h) cos_h` (Walter et al. 2007 eq. 28: `tan^2 t = -alpha^2 ln(1 - u1)`).
    /// Returns `(h, weight)`: the sample's weight `f |o.n| / pdf` divided by
    /// the facet's Fresnel choice, i.e. `G1(o, h)` for GGX and
    /// `|v.h| G1(v, h) G1(o, h) / (v_z h_z)` for Beckmann, of which the
    /// caller multiplies in `G1(o, h)` once `o` is known ([`Microfacet::g1`]):
    /// here `weight` is the part that does not depend on `o`
    /// (1 for GGX; `|v.h| G1(v, h) / (v_z h_z)` for Beckmann).
    pub fn sample_visible(&self, v: V3, u1: f64, u2: f64) -> (V3, f64) {
        let a = self.alpha;
        match self.distribution {
            Distribution::Ggx => {
                // Stretch the view vector to the unit-roughness configuration.
                let vh = normalize([a * v[0], a * v[1], v[2]]).unwrap_or([0.0, 0.0, 1.0]);
                let lensq = vh[0] * vh[0] + vh[1] * vh[1];
                let t1v = if lensq > 0.0 {
                    let l = lensq.sqrt();
                    [-vh[1] / l, vh[0] / l, 0.0]
                } else {
                    [1.0, 0.0, 0.0]
                };
                let t2v = [
                    vh[1] * t1v[2] - vh[2] * t1v[1],
                    vh[2] * t1v[0] - vh[0] * t1v[2],
                    vh[0] * t1v[1] - vh[1] * t1v[0],
                ];
                // A point on the projected hemisphere (disk warped towards v).
                let r = u1.sqrt();
                let phi = 2.0 * PI * u2;
                let t1 = r * phi.cos();
                let s = 0.5 * (1.0 + vh[2]);
                let t2 = (1.0 - s) * (1.0 - t1 * t1).max(0.0).sqrt() + s * r * phi.sin();
                let tz = (1.0 - t1 * t1 - t2 * t2).max(0.0).sqrt();
                let nh = [
                    t1 * t1v[0] + t2 * t2v[0] + tz * vh[0],
                    t1 * t1v[1] + t2 * t2v[1] + tz * vh[1],
                    t1 * t1v[2] + t2 * t2v[2] + tz * vh[2],
                ];
                // Unstretch.
                let h =
                    normalize([a * nh[0], a * nh[1], nh[2].max(1e-300)]).unwrap_or([0.0, 0.0, 1.0]);
                (h, 1.0)
            }
            Distribution::Beckmann => {
                let tan2 = -a * a * (1.0 - u1).ln();
                let cos_t = 1.0 / (1.0 + tan2).sqrt();
                let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
                let phi = 2.0 * PI * u2;
                let h = [sin_t * phi.cos(), sin_t * phi.sin(), cos_t];
                let vh = dot(v, h);
                if vh <= 0.0 {
                    return (h, 0.0);
                }
                (h, vh * self.g1(v[2], vh) / (v[2] * cos_t))
            }
        }
    }

    /// The density of [`Microfacet::sample_visible`]'s normal per unit solid
    /// angle of `h`, for a viewer at `v`.
    pub fn pdf_visible(&self, v: V3, h: V3) -> f64 {
        match self.distribution {
            Distribution::Ggx => {
                let vh = dot(v, h);
                if vh <= 0.0 || v[2] <= 0.0 {
                    return 0.0;
                }
                self.g1(v[2], vh) * vh * self.d_h(h) / v[2]
            }
            Distribution::Beckmann => self.d_h(h) * h[2].max(0.0),
        }
    }
}

/// Gauss–Legendre points per panel of the graded rules below (8: exact for
/// polynomials of degree 15 on each panel).
pub const PANEL_POINTS: usize = 8;

/// The 8-point Gauss–Legendre rule on `[0, 1]` (nodes, weights).
fn rule8() -> &'static (Vec<f64>, Vec<f64>) {
    static R: std::sync::OnceLock<(Vec<f64>, Vec<f64>)> = std::sync::OnceLock::new();
    R.get_or_init(|| {
        let (x, w) = crate::quadrature::gauss_legendre(PANEL_POINTS);
        (x.iter().map(|t| 0.5 * (t + 1.0)).collect(), w.iter().map(|v| 0.5 * v).collect())
    })
}

/// Panel edges on `[lo, hi]` graded geometrically towards `peak` (clamped to
/// the interval): `peak ± delta 2^k`, so a lobe of any width down to `delta`
/// centred at `peak` is resolved by a fixed number of points per panel
/// (docs/rough.md §3). `cuts` are further edges (e.g. cell boundaries).
pub fn graded_edges(lo: f64, hi: f64, peak: f64, delta: f64, cuts: &[f64]) -> Vec<f64> {
    let mut e = vec![lo, hi];
    let p = peak.clamp(lo, hi);
    e.push(p);
    let d0 = delta.max((hi - lo) * 1e-15);
    for side in [-1.0, 1.0] {
        let mut d = d0;
        loop {
            let x = p + side * d;
            if x <= lo || x >= hi {
                break;
            }
            e.push(x);
            d *= 2.0;
        }
    }
    e.extend(cuts.iter().copied().filter(|&c| c > lo && c < hi));
    e.sort_by(|a, b| a.total_cmp(b));
    e.dedup_by(|a, b| (*a - *b).abs() <= 1e-15 * (1.0 + b.abs()));
    e
}

/// Quadrature points and weights of the panels `edges` ([`PANEL_POINTS`] each).
pub fn panel_rule(edges: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let (x8, w8) = rule8();
    let mut x = Vec::with_capacity(PANEL_POINTS * edges.len());
    let mut w = Vec::with_capacity(PANEL_POINTS * edges.len());
    for p in edges.windows(2) {
        let h = p[1] - p[0];
        for (t, v) in x8.iter().zip(w8) {
            x.push(p[0] + h * t);
            w.push(h * v);
        }
    }
    (x, w)
}

/// Quadrature points and weights in `u = s^2` (on a side of index `n`,
/// `top = n^2`) of the panels `edges` of `u`, each integrated in
/// `mu = sqrt(1 - u/top)` ([`PANEL_POINTS`] each, weights `2 top mu dmu`):
/// the BSDF is smooth in `mu` near grazing, where it is not in `u`.
pub fn panel_rule_mu(edges: &[f64], top: f64) -> (Vec<f64>, Vec<f64>) {
    let (x8, w8) = rule8();
    let mut x = Vec::with_capacity(PANEL_POINTS * edges.len());
    let mut w = Vec::with_capacity(PANEL_POINTS * edges.len());
    let mu = |u: f64| (1.0 - u / top).max(0.0).sqrt();
    for p in edges.windows(2) {
        let (m0, m1) = (mu(p[1]), mu(p[0]));
        let h = m1 - m0;
        for (t, v) in x8.iter().zip(w8) {
            let m = m0 + h * t;
            x.push(top * (1.0 - m * m));
            w.push(h * v * 2.0 * top * m);
        }
    }
    (x, w)
}

impl Microfacet {
    /// Azimuthal Fourier coefficients of the BSDF (docs/rough.md eq. R6):
    ///
    /// ```text
    ///   F^m(mu_o, mu_i) = integral_0^{2 pi} f(mu_o, mu_i, psi) cos(m psi) dpsi,   m = 0..out.len()
    /// ```
    ///
    /// with `psi` the azimuth between the directions of travel (0 on the
    /// mirror / refraction plane, where the lobe peaks). `mu_i` is the
    /// incidence cosine on the side of `n_i`, `mu_o` the exit cosine, on the
    /// same side (`transmit = false`) or on the far side. The rule is graded
    /// towards `psi = 0` (panels `alpha/2 * 2^k`).
    pub fn fourier(
        &self,
        mu_o: f64,
        mu_i: f64,
        n_i: f64,
        far: Far,
        transmit: bool,
        out: &mut [f64],
    ) {
        out.iter_mut().for_each(|x| *x = 0.0);
        let si = (1.0 - mu_i * mu_i).max(0.0).sqrt();
        let so = (1.0 - mu_o * mu_o).max(0.0).sqrt();
        let i = [si, 0.0, mu_i];
        let z = if transmit { -mu_o } else { mu_o };
        // Near the lobe the integrand varies on the scale alpha in psi; far
        // from it (or near the normal, where psi hardly matters) it is smooth.
        // Near the peak the lobe spans ~alpha in psi; at an angular distance
        // d from it the integrand varies on the scale d (the facet tilt it
        // needs), so the grading starts at the larger of the two (halved, and
        // divided by the sharpness of a refracted lobe).
        let dist = (mu_o.clamp(-1.0, 1.0).acos() - peak_angle(mu_i, n_i, far, transmit)).abs();
        let scale = self.alpha.max(0.5 * dist);
        // Quantised to powers of two so the per-thread rule cache stays small.
        let delta = 2f64.powi((0.5 * scale / sharpness(n_i, far, transmit)).log2().floor() as i32);
        // No panel wider than PHASE / m for the last order m: cos(m psi)
        // then spans at most PHASE radians of a panel's 8 Gauss points.
        let widest = PSI_PHASE / (out.len().max(2) - 1) as f64;
        let psi_rule = psi_rule(delta, widest);
        // Reflection inside a denser medium: facets beyond the critical angle
        // reflect totally, a square-root kink of F at i.o = 2 c_c^2 - 1 (the
        // angle between i and o twice the critical one); split there.
        // Refraction out of it: the facets at the critical angle refract
        // grazing (o.h = 0), where 1 - F has the same kink, at i.o = -n_t/n_i.
        let kink = match far {
            Far::Dielectric(n_t) if n_t < n_i && si * so > 0.0 => {
                let eta = n_t / n_i;
                // i.o = mu_i mu_o - si so cos(psi) (reflection), or
                // -mu_i mu_o - si so cos(psi) (refraction).
                let cp = if transmit {
                    (eta - mu_i * mu_o) / (si * so)
                } else {
                    (mu_i * mu_o - (1.0 - 2.0 * eta * eta)) / (si * so)
                };
                (cp.abs() < 1.0).then(|| cp.acos())
            }
            _ => None,
        };
        let split;
        let rule: &PsiRule = match kink {
            None => &psi_rule,
            Some(pk) => {
                let base = graded_edges(0.0, PI, 0.0, delta, &[]);
                let edges = graded_edges(0.0, PI, pk, 1e-4 * self.alpha, &base);
                split = PsiRule::new(panel_rule(&capped(&edges, widest)));
                &split
            }
        };
        for ((&c1, &s1), &wt) in rule.cos.iter().zip(&rule.sin).zip(&rule.w) {
            let o = [-so * c1, -so * s1, z];
            let f = self.bsdf(i, o, n_i, far);
            if f == 0.0 {
                continue;
            }
            // 2 x the half-circle (f is even in psi); cos(m psi) by recurrence.
            let v = 2.0 * wt * f;
            let (mut cm1, mut cm) = (c1, 1.0);
            for (m, slot) in out.iter_mut().enumerate() {
                *slot += v * cm;
                let next = if m == 0 { c1 } else { 2.0 * c1 * cm - cm1 };
                cm1 = cm;
                cm = next;
            }
        }
    }

    /// Directional albedos `(R(mu_i), T(mu_i))` of the face for light from
    /// the side of `n_i` at cosine `mu_i`: `integral f |cos o| dw_o` over the
    /// same side and over the far side (docs/rough.md eq. R7). `1 - R - T`
    /// is the single-scattering model's loss. Integrated over `u = s^2`
    /// (`s = n sin t`, conserved by a smooth face, so the lobe peaks at the
    /// incident `s` on both sides) with panels graded towards the peak.
    pub fn albedo(&self, mu_i: f64, n_i: f64, far: Far) -> (f64, f64) {
        let r = self.side_integral(mu_i, n_i, far, false);
        let t = match far {
            Far::Dielectric(n_o) if n_o != n_i => self.side_integral(mu_i, n_i, far, true),
            Far::Dielectric(_) => 1.0 - r,
            Far::Conductor(..) => 0.0,
        };
        (r, t)
    }

    /// `integral_0^1 F^0(mu_o, mu_i) mu_o dmu_o` over one side (eq. R7).
    fn side_integral(&self, mu_i: f64, n_i: f64, far: Far, transmit: bool) -> f64 {
        let n_o = match (transmit, far) {
            (true, Far::Dielectric(n)) => n,
            _ => n_i,
        };
        let u_peak = n_i * n_i * (1.0 - mu_i * mu_i);
        let top = n_o * n_o;
        let cuts = self.kink_cuts(mu_i, n_i, far, transmit);
        let width = self.lobe_width_u(top, mu_i) / sharpness(n_i, far, transmit);
        let edges = graded_edges(0.0, top, u_peak, width, &cuts);
        let (x, w) = panel_rule_mu(&edges, top);
        let mut f0 = [0.0];
        let mut sum = 0.0;
        for (&u, &wt) in x.iter().zip(&w) {
            let mu_o = (1.0 - u / top).max(0.0).sqrt();
            self.fourier(mu_o, mu_i, n_i, far, transmit, &mut f0);
            // mu dmu = du / (2 n_o^2).
            sum += wt * f0[0] / (2.0 * top);
        }
        sum
    }

    /// The values of `u = s^2` on the exit side where the integrand over
    /// azimuth is not smooth: the plane-facet jump of refraction, and where the total-reflection kink of the azimuthal integrand enters
    /// or leaves `[0, pi]`: `theta_o = |theta_k -+ theta_i|`, `theta_k + theta_i`
    /// with `theta_k` twice the critical angle. Empty when there is no kink.
    pub fn kink_cuts(&self, mu_i: f64, n_i: f64, far: Far, transmit: bool) -> Vec<f64> {
        let Far::Dielectric(n_t) = far else { return Vec::new() };
        // Refraction: the generalised half vector lies in the face's plane
        // where n_i mu_i = n_t mu_o; beyond, no facet refracts (f_t jumps to 0).
        let mut cuts = Vec::new();
        if transmit && n_t != n_i {
            let m = n_i * mu_i / n_t;
            if m < 1.0 {
                cuts.push(n_t * n_t * (1.0 - m * m));
            }
        }
        if n_t >= n_i {
            return cuts;
        }
        // The angle between i and the reversed o at the kink: twice the
        // critical angle (reflection), or acos(n_t/n_i) (refraction).
        let eta = n_t / n_i;
        let tk = if transmit { eta.acos() } else { 2.0 * (1.0 - eta * eta).sqrt().acos() };
        let ti = mu_i.clamp(-1.0, 1.0).acos();
        let top = if transmit { n_t * n_t } else { n_i * n_i };
        cuts.extend(
            [tk - ti, ti - tk, tk + ti]
                .into_iter()
                .filter(|t| *t > 0.0 && *t < std::f64::consts::FRAC_PI_2)
                .map(|t| top * t.sin() * t.sin()),
        );
        cuts
    }

    /// A width below the lobe's in `u = s^2` on a side of index `n`
    /// (`top = n^2`) for light at cosine `mu_in`: the lobe spans about
    /// `alpha` in angle, i.e. `2 n^2 sin cos alpha` in `u`; near the normal
    /// (`sin -> 0`) `n^2 alpha^2`, near grazing (`cos -> 0`) `2 n^2 mu alpha`:
    /// an eighth of the smaller.
    pub fn lobe_width_u(&self, top: f64, mu_in: f64) -> f64 {
        let a = self.alpha;
        top * a * a.min(2.0 * mu_in.max(1e-6)) / 8.0
    }

    /// Hemispherical albedos `(R_h, T_h) = 2 integral_0^1 (R, T)(mu) mu dmu`
    /// for Lambertian light from the side of `n_i` (eq. R8), the rough
    /// counterpart of [`crate::fresnel::diffuse_reflectance`].
    pub fn hemispherical(&self, n_i: f64, far: Far) -> (f64, f64) {
        // The albedos change fast within ~alpha of the critical cosine (from
        // the denser side): panels graded towards it.
        let mu_c = match far {
            Far::Dielectric(n_o) => crate::fresnel::critical_cos(n_i, n_o),
            Far::Conductor(..) => 0.0,
        };
        let (x, w) = panel_rule(&graded_edges(0.0, 1.0, mu_c, 0.25 * self.alpha, &[]));
        let (mut r, mut t) = (0.0, 0.0);
        for (&mu, &wi) in x.iter().zip(&w) {
            let (a, b) = self.albedo(mu, n_i, far);
            r += 2.0 * wi * mu * a;
            t += 2.0 * wi * mu * b;
        }
        (r, t)
    }
}

/// The exit angle (radians, from the normal on the exit side) of the smooth
/// face's mirror or refracted direction, where the lobe peaks; grazing
/// (`pi/2`) beyond the critical angle.
fn peak_angle(mu_i: f64, n_i: f64, far: Far, transmit: bool) -> f64 {
    let ti = mu_i.clamp(-1.0, 1.0).acos();
    match (transmit, far) {
        (true, Far::Dielectric(n_o)) => {
            let s = n_i / n_o * ti.sin();
            if s >= 1.0 { std::f64::consts::FRAC_PI_2 } else { s.asin() }
        }
        _ => ti,
    }
}

/// How much narrower than a reflected lobe a refracted one is in the exit
/// direction: a change `d o` of the exit direction tilts the (generalised)
/// half vector by `d o / 2` in reflection and by `n_o d o / |n_o - n_i|` in
/// refraction (Walter et al. 2007 eq. 16, 17), so the ratio is
/// `2 n_o / |n_o - n_i|` (at least 1).
pub fn sharpness(n_i: f64, far: Far, transmit: bool) -> f64 {
    match far {
        Far::Dielectric(n_o) if transmit && n_o != n_i => (2.0 * n_o / (n_o - n_i).abs()).max(1.0),
        _ => 1.0,
    }
}

/// A quadrature rule: points and weights.
type Rule = (Vec<f64>, Vec<f64>);

/// A rule over the azimuth `psi` with the cosine and sine of each point,
/// computed once per rule: the cached rules serve every pair of directions
/// of a face without a total-reflection kink (a conductor floor's operators
/// 20 % faster, docs/rough.md §7); a rule split at a kink is made per pair.
struct PsiRule {
    w: Vec<f64>,
    cos: Vec<f64>,
    sin: Vec<f64>,
}

impl PsiRule {
    fn new((x, w): Rule) -> PsiRule {
        let (sin, cos) = x.iter().map(|p| p.sin_cos()).unzip();
        PsiRule { w, cos, sin }
    }
}

/// The largest phase `m h` of the last Fourier order over one azimuthal
/// panel of width `h`: 8 Gauss points integrate `f cos(m psi)` there to
/// about `(PHASE/2)^16 / 16!` (3e-9) of the panel's share, where wider
/// panels alias the high orders (an exit at the normal, whose coefficients
/// above order 0 vanish, read 3e-2 at order 38 with the graded rule alone).
const PSI_PHASE: f64 = 4.0;

/// `edges` with every panel wider than `widest` cut into equal pieces.
fn capped(edges: &[f64], widest: f64) -> Vec<f64> {
    let mut out = Vec::with_capacity(edges.len());
    for p in edges.windows(2) {
        out.push(p[0]);
        let pieces = ((p[1] - p[0]) / widest).ceil();
        if pieces > 1.0 && pieces.is_finite() {
            let k = pieces as usize;
            for j in 1..k {
                out.push(p[0] + (p[1] - p[0]) * j as f64 / pieces);
            }
        }
    }
    out.extend(edges.last());
    out
}

/// A cached azimuthal rule's key: the bits of its grading step and widest panel.
type RuleKey = (u64, u64);

/// The rule over `psi` in `[0, pi]` graded towards 0 from `delta`, no panel
/// wider than `widest`, cached per thread.
fn psi_rule(delta: f64, widest: f64) -> std::rc::Rc<PsiRule> {
    use std::cell::RefCell;
    use std::rc::Rc;
    thread_local! {
        static CACHE: RefCell<Vec<(RuleKey, Rc<PsiRule>)>> = const { RefCell::new(Vec::new()) };
    }
    CACHE.with(|c| {
        let mut c = c.borrow_mut();
        let key = (delta.to_bits(), widest.to_bits());
        if let Some((_, r)) = c.iter().find(|(k, _)| *k == key) {
            return Rc::clone(r);
        }
        let edges = capped(&graded_edges(0.0, PI, 0.0, delta, &[]), widest);
        let r = Rc::new(PsiRule::new(panel_rule(&edges)));
        if c.len() >= 64 {
            c.remove(0);
        }
        c.push((key, Rc::clone(&r)));
        r
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At normal incidence the BSDF does not depend on the azimuth, so its
    /// Fourier coefficients above order 0 vanish; with panels as wide as the
    /// graded rule alone makes them, order 38 read 3e-2 of order 0 (the
    /// aliasing that made a normal exit's value depend on the other exits).
    #[test]
    fn coefficients_of_an_azimuth_free_lobe_vanish_above_order_zero() {
        let mf = Microfacet::new(0.3, Distribution::Ggx).unwrap();
        for (mu_o, transmit) in [(0.9, false), (0.5, false), (0.95, true), (0.85, true)] {
            let mut c = vec![0.0; 40];
            mf.fourier(mu_o, 1.0, 1.0, Far::Dielectric(1.5), transmit, &mut c);
            let worst = c[1..].iter().fold(0.0f64, |a, b| a.max(b.abs()));
            assert!(c[0] > 0.0 && worst < 1e-12 * c[0], "{mu_o} {transmit}: {worst} of {}", c[0]);
        }
    }

    #[test]
    fn distributions_are_normalised_projected() {
        // integral D(h) cos_h dw_h = 1 over the hemisphere (2 pi sin dt).
        for dist in [Distribution::Ggx, Distribution::Beckmann] {
            for alpha in [0.05, 0.2, 0.7] {
                let mf = Microfacet::new(alpha, dist).unwrap();
                // t in [0, pi/2] with a fine rule graded towards 0.
                let mut s = 0.0;
                let edges: Vec<f64> =
                    (0..=400).map(|k| (k as f64 / 400.0).powi(2) * PI / 2.0).collect();
                for w in edges.windows(2) {
                    s += crate::quadrature::integrate_gl(
                        |t| mf.d(t.cos()) * t.cos() * t.sin() * 2.0 * PI,
                        w[0],
                        w[1],
                        crate::quadrature::CACHED_NODES,
                    );
                }
                assert!((s - 1.0).abs() < 1e-9, "{dist:?} {alpha}: {s}");
            }
        }
    }

    #[test]
    fn albedo_conserves_energy_at_small_roughness_and_reciprocity_holds() {
        // At alpha = 0.01 the rough face is nearly smooth: R + T -> 1, R -> R_F.
        let mf = Microfacet::new(0.01, Distribution::Ggx).unwrap();
        for mu in [0.95, 0.7, 0.4] {
            let (r, t) = mf.albedo(mu, 1.0, Far::Dielectric(1.5));
            let rf = crate::fresnel::reflectance(mu, 1.0, 1.5);
            // Single-scattering loss ~ alpha^2 at moderate angles (Walter 2007 fig. 9).
            assert!((r + t - 1.0).abs() < 2e-3, "{mu}: {r} {t}");
            assert!((r - rf).abs() < 2e-3, "{mu}: {r} {rf}");
        }
        // Diffuse energy across the face (n^2 law) for a rough face:
        // n_a^2 T_h(a -> b) = n_b^2 T_h(b -> a) (reciprocity of f_t / n^2).
        let mf = Microfacet::new(0.3, Distribution::Beckmann).unwrap();
        let (_, tab) = mf.hemispherical(1.0, Far::Dielectric(1.5));
        let (_, tba) = mf.hemispherical(1.5, Far::Dielectric(1.0));
        assert!((tab - 2.25 * tba).abs() < 1e-6, "{tab} {tba}");
    }

    #[test]
    fn erfc_matches_known_values() {
        // A&S table 7.1 / closed values.
        assert!((erfc(0.0) - 1.0).abs() < 1e-16);
        assert!((erfc(0.5) - 0.479_500_122_186_953_5).abs() < 1e-15);
        assert!((erfc(1.0) - 0.157_299_207_050_285_1).abs() < 1e-15);
        assert!((erfc(2.0) - 0.004_677_734_981_047_266).abs() < 1e-17);
        assert!((erfc(3.0) / 2.209_049_699_858_544e-5 - 1.0).abs() < 1e-13);
        assert!((erfc(-1.0) - 1.842_700_792_949_715).abs() < 1e-15);
    }

    #[test]
    fn conductor_at_k_zero_is_the_dielectric() {
        for c in [1.0, 0.8, 0.5, 0.2, 0.05] {
            for (ni, n) in [(1.0, 1.5), (1.5, 1.0), (1.33, 1.7)] {
                let a = conductor_reflectance(c, ni, n, 0.0);
                let b = crate::fresnel::reflectance(c, ni, n);
                assert!((a - b).abs() < 1e-13, "{c} {ni} {n}: {a} {b}");
            }
        }
    }

    #[test]
    fn walter_bsdf_is_reciprocal() {
        let mf = Microfacet::new(0.3, Distribution::Ggx).unwrap();
        let dir = |t: f64, p: f64, up: bool| {
            let z = if up { t.cos() } else { -t.cos() };
            [t.sin() * p.cos(), t.sin() * p.sin(), z]
        };
        let (na, nb) = (1.0, 1.5);
        for (ti, to, p) in [(0.3, 0.25, 2.5), (1.2, 0.6, 3.0), (0.7, 0.45, 3.1)] {
            // Reflection: f(i -> o) = f(o -> i).
            let (i, o) = (dir(ti, 0.0, true), dir(to, p, true));
            let a = mf.bsdf(i, o, na, Far::Dielectric(nb));
            let b = mf.bsdf(o, i, na, Far::Dielectric(nb));
            assert!((a - b).abs() <= 1e-12 * a.abs(), "{a} {b}");
            // Transmission: f_t(a -> b) / n_b^2 = f_t(b -> a) / n_a^2, with the
            // frames flipped for light coming from below.
            let o = dir(to, p, false);
            let t_ab = mf.bsdf(i, o, na, Far::Dielectric(nb));
            let flip = |v: V3| [v[0], v[1], -v[2]];
            let t_ba = mf.bsdf(flip(o), flip(i), nb, Far::Dielectric(na));
            assert!(t_ab > 0.0);
            assert!((t_ab / (nb * nb) - t_ba / (na * na)).abs() < 1e-12 * t_ab, "{t_ab} {t_ba}");
        }
    }
}
