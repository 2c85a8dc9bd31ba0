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
        self.d_parts(h[2] * h[2], h[0] * h[0] + h[1] * h[1], 1.0)
    }

    /// `D(h)` (eq. R1) of the facet normal along `H`, from the squares of
    /// `H`'s vertical part `hz2`, its horizontal part `hxy2` and its length
    /// `l2 = hz2 + hxy2`, `H` unnormalised (as [`Microfacet::d_h`]).
    fn d_parts(&self, hz2: f64, hxy2: f64, l2: f64) -> f64 {
        let a2 = self.alpha * self.alpha;
        match self.distribution {
            Distribution::Ggx => {
                let t = hz2 * a2 + hxy2;
                a2 * l2 * l2 / (PI * t * t)
            }
            Distribution::Beckmann => (-hxy2 / (hz2 * a2)).exp() * l2 * l2 / (PI * a2 * hz2 * hz2),
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
#[inline]
pub fn conductor_reflectance(cos_i: f64, n_i: f64, n: f64, k: f64) -> f64 {
    // The same in real arithmetic (two square roots, two divisions):
    // eta cos_t = a + i b with a^2 + b^2 = |eta^2 - s^2|, a^2 = ((a^2 + b^2)
    // + Re(eta^2 - s^2)) / 2; |r_s|^2 = (|..| + c^2 - 2 a c) / (|..| + c^2 +
    // 2 a c), |r_p|^2 = |r_s|^2 (c^2 |..| + s^4 - 2 a c s^2) / (c^2 |..| +
    // s^4 + 2 a c s^2) (e.g. Pharr, Jakob & Humphreys, pbrt §8.2).
    let c = cos_i.abs().min(1.0);
    let (en, ek) = (n / n_i, k / n_i);
    let s2 = (1.0 - c) * (1.0 + c);
    let t0 = en * en - ek * ek - s2;
    let ab2 = (t0 * t0 + 4.0 * en * en * ek * ek).sqrt();
    let a = (0.5 * (ab2 + t0)).max(0.0).sqrt();
    let c2 = c * c;
    let (t1, t2) = (ab2 + c2, 2.0 * a * c);
    let rs = (t1 - t2) / (t1 + t2);
    let (t3, t4) = (c2 * ab2 + s2 * s2, t2 * s2);
    let rp = rs * (t3 - t4) / (t3 + t4);
    let r = 0.5 * (rs + rp);
    if r.is_finite() { r.clamp(0.0, 1.0) } else { 1.0 }
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

/// The BSDF of one pair of polar angles as a function of the azimuth (eq.
/// R3, R4 written with the (generalised) half vector's vertical part `H_z`
/// and horizontal part `H_xy` unnormalised, whose length `L` gives the
/// facet's cosines: `i.h = L/2` in reflection, `den = L` in refraction):
/// what an azimuthal integral evaluates at thousands of points, with
/// Smith's factors and the constant parts taken once
/// ([`Microfacet::fourier`]; the same values as [`Microfacet::bsdf`] to
/// rounding, test `pair_is_the_bsdf`).
struct AtPair {
    mf: Microfacet,
    n_i: f64,
    far: Far,
    transmit: bool,
    /// `n_i sin_i`, `n_o sin_o` and `H_z` (`sin_i`, `sin_o`, `mu_i + mu_o`
    /// in reflection).
    a: f64,
    b: f64,
    hz: f64,
    /// `mu_i mu_o`, `sin_i sin_o`, `n_o`.
    mumu: f64,
    siso: f64,
    n_o: f64,
    /// The factor of the azimuth-free parts (0: the pair has no lobe).
    k: f64,
}

impl AtPair {
    fn new(mf: Microfacet, (mu_o, mu_i): (f64, f64), n_i: f64, far: Far, transmit: bool) -> AtPair {
        let si = (1.0 - mu_i * mu_i).max(0.0).sqrt();
        let so = (1.0 - mu_o * mu_o).max(0.0).sqrt();
        let smith = |c: f64| 1.0 / (1.0 + mf.lambda(c));
        let g = smith(mu_i) * smith(mu_o);
        let (n_o, k) = match (transmit, far) {
            (false, _) => (n_i, g / (4.0 * mu_i * mu_o)),
            (true, Far::Dielectric(n_o)) if n_o != n_i => (n_o, n_o * n_o * g / (mu_i * mu_o)),
            // A conductor transmits nothing; equal indices pass a delta.
            (true, _) => (n_i, 0.0),
        };
        let k = if mu_i > 0.0 && mu_o > 0.0 && k.is_finite() { k } else { 0.0 };
        // H = n_i i + n_o o in refraction, i + o in reflection.
        let (wi, wo) = if transmit { (n_i, n_o) } else { (1.0, 1.0) };
        AtPair {
            mf,
            n_i,
            far,
            transmit,
            a: wi * si,
            b: wo * so,
            hz: if transmit { wi * mu_i - wo * mu_o } else { mu_i + mu_o },
            mumu: mu_i * mu_o,
            siso: si * so,
            n_o,
            k,
        }
    }

    /// `f` at the azimuth of cosine `c` and sine `s` between the directions
    /// of travel (0 on the mirror / refraction plane).
    #[inline]
    fn at(&self, c: f64, s: f64) -> f64 {
        if self.k == 0.0 || self.hz == 0.0 {
            return 0.0;
        }
        let (dx, dy) = (self.a - self.b * c, self.b * s);
        let hxy2 = dx * dx + dy * dy;
        let hz2 = self.hz * self.hz;
        let l2 = hxy2 + hz2;
        let d = self.mf.d_parts(hz2, hxy2, l2);
        if !self.transmit {
            let ih = 0.5 * l2.sqrt();
            let f = match self.far {
                Far::Dielectric(n_t) => crate::fresnel::reflectance(ih, self.n_i, n_t),
                Far::Conductor(n, k) => conductor_reflectance(ih, self.n_i, n, k),
            };
            return self.k * f * d;
        }
        // i.o, and the facet's cosines on the side of the normal.
        let io = -self.siso * c - self.mumu;
        let l = l2.sqrt();
        let sign = self.hz.signum();
        let ih = sign * (self.n_i + self.n_o * io) / l;
        let oh = sign * (self.n_i * io + self.n_o) / l;
        if ih <= 0.0 || oh >= 0.0 {
            return 0.0;
        }
        let f = crate::fresnel::reflectance(ih, self.n_i, self.n_o);
        self.k * (ih * oh).abs() * (1.0 - f) * d / l2
    }
}

impl AtPair {
    /// Whether a pair of refraction is dark at every azimuth (eq. R6c): its
    /// facets carry light only where `i.o < -n_rare / n_dense` and the half
    /// vector's vertical part points to the denser side; `i.o` is least at
    /// `psi = 0`. (Lit, it is dark for `i.o >= -n_rare / n_dense`, i.e.
    /// beyond its kink, [`Microfacet::fourier_add`].)
    fn dark_refraction(&self) -> bool {
        let r = self.n_i.min(self.n_o) / self.n_i.max(self.n_o);
        let towards_dense = if self.n_i < self.n_o { self.hz < 0.0 } else { self.hz > 0.0 };
        !towards_dense || -self.siso - self.mumu >= -r
    }

    /// `out[k] += weight * at(c[k], s[k])` for every `k`: the same values
    /// as [`AtPair::at`] bit for bit (the same operations in the same
    /// order, branches as selects), in loops the compiler vectorises, on
    /// AVX2 where the processor has it (test `batch_is_the_pointwise_bsdf`).
    fn add_many(&self, (c, s): (&[f64], &[f64]), weight: f64, out: &mut [f64]) {
        if self.k == 0.0 || self.hz == 0.0 {
            return;
        }
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2 (checked just above).
            unsafe { self.add_many_avx2((c, s), weight, out) };
            return;
        }
        self.add_many_any((c, s), weight, out);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn add_many_avx2(&self, (c, s): (&[f64], &[f64]), weight: f64, out: &mut [f64]) {
        self.add_many_any((c, s), weight, out);
    }

    /// [`AtPair::add_many`]'s loops, one per kind of pair (the kind is
    /// fixed per pair, so no branch is left inside a loop).
    #[inline(always)]
    fn add_many_any(&self, (c, s): (&[f64], &[f64]), weight: f64, out: &mut [f64]) {
        let (a, b, hz, k) = (self.a, self.b, self.hz, self.k);
        let hz2 = hz * hz;
        let alpha = self.mf.alpha;
        let ggx = matches!(self.mf.distribution, Distribution::Ggx);
        // The half vector's horizontal part and its length at one point.
        let parts = |c1: f64, s1: f64| {
            let (dx, dy) = (a - b * c1, b * s1);
            let hxy2 = dx * dx + dy * dy;
            (hxy2, hxy2 + hz2)
        };
        let ggx_d = |hxy2: f64, l2: f64| {
            let a2 = alpha * alpha;
            let t = hz2 * a2 + hxy2;
            a2 * l2 * l2 / (PI * t * t)
        };
        let n_i = self.n_i;
        let lanes = out.iter_mut().zip(c.iter().zip(s));
        match (self.transmit, self.far, ggx) {
            (false, Far::Dielectric(n_t), true) if n_t != n_i => {
                for (o, (&c1, &s1)) in lanes {
                    let (hxy2, l2) = parts(c1, s1);
                    let d = ggx_d(hxy2, l2);
                    let f = crate::fresnel::reflectance_across(0.5 * l2.sqrt(), n_i, n_t);
                    *o += weight * (k * f * d);
                }
            }
            (false, Far::Conductor(n, kc), true) => {
                for (o, (&c1, &s1)) in lanes {
                    let (hxy2, l2) = parts(c1, s1);
                    let d = ggx_d(hxy2, l2);
                    let f = conductor_reflectance(0.5 * l2.sqrt(), n_i, n, kc);
                    *o += weight * (k * f * d);
                }
            }
            (true, Far::Dielectric(n_o), true) if n_o != n_i => {
                let (siso, mumu, sign) = (self.siso, self.mumu, hz.signum());
                for (o, (&c1, &s1)) in lanes {
                    let (hxy2, l2) = parts(c1, s1);
                    let d = ggx_d(hxy2, l2);
                    let io = -siso * c1 - mumu;
                    let l = l2.sqrt();
                    let ih = sign * (n_i + n_o * io) / l;
                    let oh = sign * (n_i * io + n_o) / l;
                    let f = crate::fresnel::reflectance_across(ih, n_i, n_o);
                    let v = k * (ih * oh).abs() * (1.0 - f) * d / l2;
                    *o += weight * if ih <= 0.0 || oh >= 0.0 { 0.0 } else { v };
                }
            }
            _ => {
                for (o, (&c1, &s1)) in lanes {
                    *o += weight * self.at(c1, s1);
                }
            }
        }
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

/// The `n`-point Gauss–Legendre rule mapped to `[0, 1]` (nodes, weights).
fn on_unit(n: usize) -> (Vec<f64>, Vec<f64>) {
    let (x, w) = crate::quadrature::gauss_legendre(n);
    (x.iter().map(|t| 0.5 * (t + 1.0)).collect(), w.iter().map(|v| 0.5 * v).collect())
}

/// The 8-point Gauss–Legendre rule on `[0, 1]` (nodes, weights).
fn rule8() -> &'static (Vec<f64>, Vec<f64>) {
    static R: std::sync::OnceLock<(Vec<f64>, Vec<f64>)> = std::sync::OnceLock::new();
    R.get_or_init(|| on_unit(PANEL_POINTS))
}

/// Gauss points of the panels of [`panel_rule_mu_near`] far from every
/// singular point.
pub const FAR_POINTS: usize = 4;

/// The [`FAR_POINTS`]-point Gauss–Legendre rule on `[0, 1]`.
fn rule4() -> &'static (Vec<f64>, Vec<f64>) {
    static R: std::sync::OnceLock<(Vec<f64>, Vec<f64>)> = std::sync::OnceLock::new();
    R.get_or_init(|| on_unit(FAR_POINTS))
}

/// The 16-point Gauss–Legendre rule on `[0, 1]` (nodes, weights): the
/// pieces around a kink where `cos(m psi)` limits their width
/// ([`kink_rule`]).
fn rule16() -> &'static (Vec<f64>, Vec<f64>) {
    static R: std::sync::OnceLock<(Vec<f64>, Vec<f64>)> = std::sync::OnceLock::new();
    R.get_or_init(|| on_unit(16))
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
    panel_rule_mu_near(edges, top, &[])
}

/// [`panel_rule_mu`] with [`PANEL_POINTS`] only on the panels closer than
/// twice their width to one of `singular` (where the integrand peaks or
/// is not smooth); [`FAR_POINTS`] on the others (empty `singular`: every
/// panel has [`PANEL_POINTS`]). A singularity at distance `d` from a panel
/// of width `h` bounds Gauss's error by the Bernstein ellipse of
/// `1 + 2 d / h`: for `d >= 2 h`, `9.9^(-2n)`, 1e-8 of the panel's share
/// with 4 points.
pub fn panel_rule_mu_near(edges: &[f64], top: f64, singular: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let mut x = Vec::with_capacity(PANEL_POINTS * edges.len());
    let mut w = Vec::with_capacity(PANEL_POINTS * edges.len());
    let mu = |u: f64| (1.0 - u / top).max(0.0).sqrt();
    for p in edges.windows(2) {
        let (m0, m1) = (mu(p[1]), mu(p[0]));
        let h = m1 - m0;
        let width = p[1] - p[0];
        let near = singular.is_empty()
            || singular.iter().any(|&q| (p[0] - q).max(q - p[1]).max(0.0) < 2.0 * width);
        let (xs, ws) = if near { rule8() } else { rule4() };
        for (t, v) in xs.iter().zip(ws) {
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
    /// towards `psi = 0` from half the lobe's width (eq. R6b), carries the
    /// moments of every order per point (eq. R6a), and is split at a kink
    /// (docs/rough.md §2).
    pub fn fourier(
        &self,
        mu_o: f64,
        mu_i: f64,
        n_i: f64,
        far: Far,
        transmit: bool,
        out: &mut [f64],
    ) {
        let mut sum = FourierSum::new(out.len());
        self.fourier_add((mu_o, mu_i), n_i, far, transmit, 1.0, &mut sum);
        sum.finish_into(out);
    }

    /// Add `weight` times the coefficients of [`Microfacet::fourier`] of the
    /// pair `(mu_o, mu_i)` to `sum` (`sum`'s order count).
    pub fn fourier_add(
        &self,
        (mu_o, mu_i): (f64, f64),
        n_i: f64,
        far: Far,
        transmit: bool,
        weight: f64,
        sum: &mut FourierSum,
    ) {
        let si = (1.0 - mu_i * mu_i).max(0.0).sqrt();
        let so = (1.0 - mu_o * mu_o).max(0.0).sqrt();
        let pair = AtPair::new(*self, (mu_o, mu_i), n_i, far, transmit);
        // A pair of refraction dark at every azimuth adds nothing; one lit
        // is dark beyond its kink (eq. R6c).
        let refraction = pair.transmit && pair.k != 0.0;
        if refraction && pair.dark_refraction() {
            return;
        }
        // The lobe in psi (eq. R6b): the (generalised) half vector
        // n_i i + n_o o has the vertical part h_z and a horizontal part of
        // length sqrt(a^2 + b^2 - 2 a b cos psi), a = n_i sin_i, b = n_o sin_o;
        // its slope (their ratio) reaches the facets' alpha within
        // psi ~ sqrt((alpha h_z)^2 + (a - b)^2) / sqrt(a b), and beyond the
        // integrand varies on the scale psi itself. The rule is graded from
        // half that width; grazing pairs (small h_z) get narrow lobes.
        let width = self.psi_width_of(&pair);
        // Quantised to powers of two so the per-thread rule cache stays small.
        let delta = 2f64.powi((0.5 * width.min(PI)).log2().floor() as i32);
        let orders = sum.orders;
        let rule = psi_rule(delta, orders);
        // Where the integrand is not smooth in psi (eq. R6a). Reflection
        // inside a denser medium: facets beyond the critical angle reflect
        // totally, a square-root kink of F at i.o = 2 c_c^2 - 1 (the angle
        // between i and o twice the critical one). Refraction: the facets
        // whose (generalised) half vector grazes the side of the rarer
        // medium (o.h = 0 out of the denser one, where 1 - F has the same
        // kink; i.h = 0 into it, where f_t ends as (i.h)^2), at
        // i.o = -n_rare / n_dense.
        let kink = match far {
            Far::Dielectric(n_t) if n_t != n_i && si * so > 0.0 => {
                let r = n_t.min(n_i) / n_t.max(n_i);
                // i.o = mu_i mu_o - si so cos(psi) (reflection), or
                // -mu_i mu_o - si so cos(psi) (refraction).
                let cp = if transmit {
                    Some((r - mu_i * mu_o) / (si * so))
                } else if n_t < n_i {
                    Some((mu_i * mu_o - (1.0 - 2.0 * r * r)) / (si * so))
                } else {
                    None
                };
                cp.filter(|c| c.abs() < 1.0).map(f64::acos)
            }
            _ => None,
        };
        // The panel holding the kink is left out of the cached rule and
        // integrated apart, split at the kink (eq. R6a).
        let span = kink.map(|pk| rule.kink_span(pk));
        // 2 x the half-circle (f is even in psi).
        let w2 = 2.0 * weight;
        let acc = sum.samples_of(&rule);
        let n = acc.len();
        let (skip_lo, skip_hi) =
            span.map_or((n, n), |(lo, hi)| (lo * PANEL_POINTS, (hi + 1) * PANEL_POINTS));
        // Beyond a kink of refraction, dark (above).
        let end = if refraction { skip_hi } else { n };
        for r in [0..skip_lo, skip_hi..end] {
            pair.add_many((&rule.cos[r.clone()], &rule.sin[r.clone()]), w2, &mut acc[r]);
        }
        if let (Some(pk), Some((a, b))) = (kink, span) {
            let (lo, hi) = (rule.edges[a], if refraction { pk } else { rule.edges[b + 1] });
            KINK.with(|k| {
                let k = &mut *k.borrow_mut();
                kink_panel(lo, pk, hi, orders, (&mut k.cos, &mut k.sin, &mut k.w));
                k.f.clear();
                k.f.resize(k.cos.len(), 0.0);
                pair.add_many((&k.cos, &k.sin), 1.0, &mut k.f);
                k.points.clear();
                let each = k.cos.iter().zip(&k.w).zip(&k.f);
                k.points.extend(
                    each.filter(|&(_, &f)| f != 0.0).map(|((&c1, &wt), &f)| (c1, w2 * wt * f)),
                );
                add_cosine_sums(&k.points, &mut sum.direct, &mut k.acc);
            });
        }
    }

    /// The lobe's width in `psi` of the pair (eq. R6b), at most `pi`: the
    /// scale of the azimuthal integrand of [`Microfacet::fourier`], whose
    /// coefficients fall about as `exp(-m width)` beyond `1 / width`.
    pub fn psi_width(&self, (mu_o, mu_i): (f64, f64), n_i: f64, far: Far, transmit: bool) -> f64 {
        self.psi_width_of(&AtPair::new(*self, (mu_o, mu_i), n_i, far, transmit))
    }

    fn psi_width_of(&self, pair: &AtPair) -> f64 {
        let (a, b) = (pair.a, pair.b);
        if a * b > 0.0 {
            (((self.alpha * pair.hz).powi(2) + (a - b).powi(2)).sqrt() / (a * b).sqrt()).min(PI)
        } else {
            PI
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
        let mut sum = FourierSum::new(1);
        for (&u, &wt) in x.iter().zip(&w) {
            let mu_o = (1.0 - u / top).max(0.0).sqrt();
            // mu dmu = du / (2 n_o^2).
            self.fourier_add((mu_o, mu_i), n_i, far, transmit, wt / (2.0 * top), &mut sum);
        }
        let mut f0 = [0.0];
        sum.finish_into(&mut f0);
        f0[0]
    }

    /// The values of `u = s^2` on the exit side where the integrand over
    /// azimuth is not smooth: the plane-facet jump of refraction, and where
    /// the kink of the azimuthal integrand (eq. R6a) enters or leaves
    /// `[0, pi]`: `theta_o = |theta_k -+ theta_i|`, `theta_k + theta_i` with
    /// `theta_k` twice the critical angle (reflection) or
    /// `acos(n_rare / n_dense)` (refraction). Empty when there is no kink.
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
        // The angle between i and the reversed o at the kink (eq. R6a):
        // twice the critical angle (reflection inside the denser medium), or
        // acos(n_rare / n_dense) (refraction, either way).
        let r = n_t.min(n_i) / n_t.max(n_i);
        let tk = if n_t == n_i {
            return cuts;
        } else if transmit {
            r.acos()
        } else if n_t < n_i {
            2.0 * (1.0 - r * r).sqrt().acos()
        } else {
            return cuts;
        };
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

/// The rule over the azimuth `psi` in `[0, pi]` for `orders` Fourier orders:
/// its panels (8 Gauss points each), the cosine and sine of every point, and
/// per point the weights of every order (eq. R6a),
/// `moments[(8 p + k) orders + m] = integral_{panel p} L_k(psi) cos(m psi) dpsi`
/// with `L_k` the Lagrange polynomial of the panel's point `k`: the integral
/// of the degree-7 interpolant of `f` times `cos(m psi)`, exact in `m`
/// (Filon's idea), so the panels need only resolve `f`, not `cos(m psi)`.
/// Order 0's weights are the Gauss weights. Computed once per rule and kept
/// per thread: they serve every pair of directions of a face.
struct PsiRule {
    edges: Vec<f64>,
    cos: Vec<f64>,
    sin: Vec<f64>,
    moments: Vec<f64>,
}

impl PsiRule {
    fn new(edges: Vec<f64>, orders: usize) -> PsiRule {
        let (x8, w8) = rule8();
        // The Lagrange polynomials of the 8 points on [0, 1].
        let lagrange = |t: f64, k: usize| -> f64 {
            (0..PANEL_POINTS).filter(|&j| j != k).map(|j| (t - x8[j]) / (x8[k] - x8[j])).product()
        };
        let npts = PANEL_POINTS * (edges.len() - 1);
        let (mut cos, mut sin) = (Vec::with_capacity(npts), Vec::with_capacity(npts));
        let mut moments = vec![0.0; npts * orders];
        let mut cm = vec![0.0; orders];
        for (p, e) in edges.windows(2).enumerate() {
            let h = e[1] - e[0];
            for t in x8 {
                let (s, c) = (e[0] + h * t).sin_cos();
                cos.push(c);
                sin.push(s);
            }
            // Sub-panels across which the last order turns by at most
            // MOMENT_PHASE, 8 Gauss points each: degree 7 times cos(m psi)
            // integrated to rounding.
            let pieces = ((h * (orders - 1) as f64 / MOMENT_PHASE).ceil() as usize).max(1);
            let block = &mut moments[p * PANEL_POINTS * orders..(p + 1) * PANEL_POINTS * orders];
            for q in 0..pieces {
                for (y, v) in x8.iter().zip(w8) {
                    // t on the panel's [0, 1], and its weight.
                    let t = (q as f64 + y) / pieces as f64;
                    let wt = v * h / pieces as f64;
                    let c1 = (e[0] + h * t).cos();
                    let (mut a, mut b) = (c1, 1.0);
                    for (m, slot) in cm.iter_mut().enumerate() {
                        *slot = b;
                        let next = if m == 0 { c1 } else { 2.0 * c1 * b - a };
                        a = b;
                        b = next;
                    }
                    for k in 0..PANEL_POINTS {
                        let l = wt * lagrange(t, k);
                        let row = &mut block[k * orders..(k + 1) * orders];
                        for (r, c) in row.iter_mut().zip(&cm) {
                            *r += l * c;
                        }
                    }
                }
            }
            // Order 0: the Gauss weights themselves (integral L_k = w_k).
            for (k, v) in w8.iter().enumerate() {
                block[k * orders] = v * h;
            }
        }
        PsiRule { edges, cos, sin, moments }
    }

    /// The panels `first..=last` around a kink at `psi`: the one holding
    /// it and its neighbours closer to it than twice their width, on which
    /// its square root would spoil the interpolant (eq. R6a).
    fn kink_span(&self, psi: f64) -> (usize, usize) {
        let e = &self.edges;
        let last_panel = e.len() - 2;
        let p = e.partition_point(|&x| x <= psi).clamp(1, last_panel + 1) - 1;
        let near = |q: usize| {
            let dist = (e[q] - psi).abs().min((e[q + 1] - psi).abs());
            dist < 2.0 * (e[q + 1] - e[q])
        };
        let (mut first, mut last) = (p, p);
        while first > 0 && near(first - 1) {
            first -= 1;
        }
        while last < last_panel && near(last + 1) {
            last += 1;
        }
        (first, last)
    }
}

/// The largest phase `m h` of the last Fourier order over one azimuthal
/// panel of width `h` where `cos(m psi)` is integrated by Gauss points (the
/// kink's panel, eq. R6a): 8 points integrate `f cos(m psi)` there to about
/// `(PHASE/2)^16 / 16!` (3e-9) of the panel's share.
const PSI_PHASE: f64 = 4.0;

/// The same for 16 Gauss points: `cos(m psi)` over a phase of 20 to 6e-14
/// of the piece's share, as 8 points over a phase of 4 (7e-14): 0.8 points
/// per radian of the last order instead of 2.
const PSI_PHASE_16: f64 = 20.0;

/// The same for the sub-panels that integrate the moments of
/// [`PsiRule`]: polynomials of degree 7 times `cos(m psi)`, to rounding.
const MOMENT_PHASE: f64 = 1.0;

/// The widest panel of an azimuthal rule with more than one order: the
/// interpolant of [`PsiRule`] must follow `f` over a panel, where the
/// graded rule alone lets the panels far from the lobe grow to `pi/2`.
const INTERP_WIDEST: f64 = 1.0;

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

/// The points (as `cos psi`, `sin psi`) and weights over `[lo, hi]` split
/// at the kink `pk` (eq. R6a): on each side, first a piece whose points
/// follow the substitution `psi = pk -+ L s^2` (the square root of the kink
/// smooth in `s`), then pieces no wider than their distance from the kink
/// (8 or 16 Gauss points each then integrate the rest of the square root to
/// ~1e-12), nor than the phase limit of [`kink_rule`] (`cos(m psi)`) or
/// [`INTERP_WIDEST`] (`f`). The offsets from the kink are the same for every
/// pair of directions up to the last piece of a side ([`kink_offsets`]), so
/// their cosines and sines are computed once; a point's follow by the
/// angle-addition formulas.
fn kink_panel(
    lo: f64,
    pk: f64,
    hi: f64,
    orders: usize,
    out: (&mut Vec<f64>, &mut Vec<f64>, &mut Vec<f64>),
) {
    let ((x8, w8), widest) = kink_rule(orders);
    let (spk, cpk) = pk.sin_cos();
    let offsets = kink_offsets(orders);
    let (oc, os, ow) = out;
    oc.clear();
    os.clear();
    ow.clear();
    // A point at `psi` of weight `w` (its cosine and sine computed).
    fn direct(out: (&mut Vec<f64>, &mut Vec<f64>, &mut Vec<f64>), psi: f64, w: f64) {
        let (s, c) = psi.sin_cos();
        out.0.push(c);
        out.1.push(s);
        out.2.push(w);
    }
    for (to, dir) in [(lo, -1.0), (hi, 1.0)] {
        let len = (to - pk).abs();
        if len <= 0.0 {
            continue;
        }
        let mut a = 0.25 * widest;
        if len <= a {
            // The whole side in one substituted piece.
            for (t, v) in x8.iter().zip(w8) {
                direct((oc, os, ow), pk + dir * len * t * t, 2.0 * len * t * v);
            }
            continue;
        }
        // The whole pieces of the side, turned to the kink in bulk.
        let whole = offsets.end.partition_point(|&e| e <= len);
        if let Some(&end) = whole.checked_sub(1).and_then(|p| offsets.end.get(p)) {
            let k = whole * offsets.per_piece;
            let (c, s) = (&offsets.cos[..k], &offsets.sin[..k]);
            oc.extend(c.iter().zip(s).map(|(&c, &s)| cpk * c - dir * spk * s));
            os.extend(c.iter().zip(s).map(|(&c, &s)| spk * c + dir * cpk * s));
            ow.extend_from_slice(&offsets.w[..k]);
            a = end;
        }
        while a < len {
            let b = (a + a.min(widest)).min(len);
            for (t, v) in x8.iter().zip(w8) {
                direct((oc, os, ow), pk + dir * (a + (b - a) * t), (b - a) * v);
            }
            a = b;
        }
    }
}

/// A sum of weighted azimuthal coefficients over many pairs of directions
/// ([`Microfacet::fourier_add`]), kept as samples: per azimuthal rule the
/// weighted sum of the BSDF at its points, whose moments (eq. R6a) are
/// applied once, in [`FourierSum::finish_into`]. The pairs of a face's
/// outgoing cell mostly share a few rules, so the product with the moments
/// (`orders` per point) is paid per rule, not per pair.
pub struct FourierSum {
    orders: usize,
    rules: Vec<(std::rc::Rc<PsiRule>, Vec<f64>)>,
    /// What the pieces around a kink add, order by order.
    direct: Vec<f64>,
}

impl FourierSum {
    /// An empty sum of `orders` orders (at least 1).
    pub fn new(orders: usize) -> FourierSum {
        let orders = orders.max(1);
        FourierSum { orders, rules: Vec::new(), direct: vec![0.0; orders] }
    }

    /// The samples' sums of `rule`, added on first use.
    fn samples_of(&mut self, rule: &std::rc::Rc<PsiRule>) -> &mut [f64] {
        let k = match self.rules.iter().position(|(r, _)| std::rc::Rc::ptr_eq(r, rule)) {
            Some(k) => k,
            None => {
                self.rules.push((std::rc::Rc::clone(rule), vec![0.0; rule.cos.len()]));
                self.rules.len() - 1
            }
        };
        &mut self.rules[k].1
    }

    /// The coefficients summed so far into `out` (overwritten; `out.len()`
    /// orders, at most the sum's), and the sum emptied.
    pub fn finish_into(&mut self, out: &mut [f64]) {
        let orders = self.orders;
        for (slot, d) in out.iter_mut().zip(&self.direct) {
            *slot = *d;
        }
        for (rule, acc) in self.rules.drain(..) {
            for (&a, row) in acc.iter().zip(rule.moments.chunks_exact(orders)) {
                if a == 0.0 {
                    continue;
                }
                for (slot, r) in out.iter_mut().zip(row) {
                    *slot += a * r;
                }
            }
        }
        self.direct.iter_mut().for_each(|x| *x = 0.0);
    }
}

/// The buffers of the pieces around a kink, kept per thread (a face's
/// columns need them for every pair of directions).
#[derive(Default)]
struct KinkScratch {
    cos: Vec<f64>,
    sin: Vec<f64>,
    w: Vec<f64>,
    f: Vec<f64>,
    points: Vec<(f64, f64)>,
    acc: Vec<[f64; LANES]>,
}

thread_local! {
    static KINK: std::cell::RefCell<KinkScratch> = std::cell::RefCell::default();
}

/// `out[m] += sum_k v_k cos(m psi_k)` for `points` `(cos psi_k, v_k)`, the
/// cosines by the Chebyshev recurrence, [`LANES`] points at a time in
/// independent chains (the recurrence of one point alone waits on each
/// step), each lane summed apart in `acc` and the lanes added at the end
/// (no horizontal sum per order); on AVX2 where the processor has it (the
/// same operations: the same sums bit for bit).
fn add_cosine_sums(points: &[(f64, f64)], out: &mut [f64], acc: &mut Vec<[f64; LANES]>) {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        // SAFETY: the processor has AVX2 (checked just above).
        unsafe { cosine_sums_avx2(points, out, acc) };
        return;
    }
    cosine_sums_any(points, out, acc);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn cosine_sums_avx2(points: &[(f64, f64)], out: &mut [f64], acc: &mut Vec<[f64; LANES]>) {
    cosine_sums_any(points, out, acc);
}

#[inline(always)]
fn cosine_sums_any(points: &[(f64, f64)], out: &mut [f64], acc: &mut Vec<[f64; LANES]>) {
    let Some((first, rest)) = out.split_first_mut() else { return };
    acc.clear();
    acc.resize(rest.len(), [0.0; LANES]);
    let mut zero = 0.0;
    for chunk in points.chunks(LANES) {
        let (mut c1, mut v) = ([1.0; LANES], [0.0; LANES]);
        for (k, &(c, w)) in chunk.iter().enumerate() {
            (c1[k], v[k]) = (c, w);
        }
        zero += v.iter().sum::<f64>();
        // Orders 1, 2, ...: T_1 = c1, T_{m+1} = 2 c1 T_m - T_{m-1}.
        let (mut prev, mut cur) = ([1.0; LANES], c1);
        for a in acc.iter_mut() {
            for k in 0..LANES {
                a[k] += v[k] * cur[k];
            }
            let next: [f64; LANES] = std::array::from_fn(|k| 2.0 * c1[k] * cur[k] - prev[k]);
            prev = cur;
            cur = next;
        }
    }
    *first += zero;
    for (slot, a) in rest.iter_mut().zip(acc.iter()) {
        *slot += a.iter().sum::<f64>();
    }
}

/// Points per chunk of [`add_cosine_sums`].
const LANES: usize = 8;

/// The Gauss rule of the pieces of [`kink_panel`] for `orders` orders, and
/// their widest piece: 8 points no wider than `PSI_PHASE / (orders - 1)`,
/// or 16 no wider than `PSI_PHASE_16 / (orders - 1)`, whichever takes fewer
/// points per radian (16 from 10 orders on), and never wider than
/// [`INTERP_WIDEST`] (`f`).
fn kink_rule(orders: usize) -> (&'static (Vec<f64>, Vec<f64>), f64) {
    let last = (orders.max(2) - 1) as f64;
    let w8 = (PSI_PHASE / last).min(INTERP_WIDEST);
    let w16 = (PSI_PHASE_16 / last).min(INTERP_WIDEST);
    if 16.0 / w16 < 8.0 / w8 { (rule16(), w16) } else { (rule8(), w8) }
}

/// The pieces of [`kink_panel`] at fixed offsets from the kink, on one side
/// up to `pi` from it: where each piece ends, and the points of all of them
/// in order (the weight, cosine and sine of each offset), `per_piece` per
/// piece ([`kink_rule`]'s Gauss rule).
struct KinkOffsets {
    end: Vec<f64>,
    per_piece: usize,
    w: Vec<f64>,
    cos: Vec<f64>,
    sin: Vec<f64>,
}

/// [`KinkOffsets`] for `orders` orders, cached per thread.
fn kink_offsets(orders: usize) -> std::rc::Rc<KinkOffsets> {
    use std::cell::RefCell;
    use std::rc::Rc;
    thread_local! {
        static CACHE: RefCell<Vec<(usize, Rc<KinkOffsets>)>> = const { RefCell::new(Vec::new()) };
    }
    CACHE.with(|c| {
        let mut c = c.borrow_mut();
        if let Some((_, r)) = c.iter().find(|(k, _)| *k == orders) {
            return Rc::clone(r);
        }
        let ((x8, w8), widest) = kink_rule(orders);
        let mut o = KinkOffsets {
            end: Vec::new(),
            per_piece: x8.len(),
            w: Vec::new(),
            cos: Vec::new(),
            sin: Vec::new(),
        };
        let mut point = |dj: f64, w: f64| {
            let (s, c) = dj.sin_cos();
            o.w.push(w);
            o.cos.push(c);
            o.sin.push(s);
        };
        let first = 0.25 * widest;
        // psi = pk + dir first s^2, dpsi = 2 first s ds.
        for (t, v) in x8.iter().zip(w8) {
            point(first * t * t, 2.0 * first * t * v);
        }
        let mut ends = vec![first];
        let mut a = first;
        while a < PI {
            let b = a + a.min(widest);
            for (t, v) in x8.iter().zip(w8) {
                point(a + (b - a) * t, (b - a) * v);
            }
            ends.push(b);
            a = b;
        }
        o.end = ends;
        let r = Rc::new(o);
        if c.len() >= 16 {
            c.remove(0);
        }
        c.push((orders, Rc::clone(&r)));
        r
    })
}

/// A cached azimuthal rule's key: the bits of its grading step, and its orders.
type RuleKey = (u64, usize);

/// The rule over `psi` in `[0, pi]` graded towards 0 from `delta`, for
/// `orders` Fourier orders, cached per thread. One order (the albedos, the
/// totals) takes the graded Gauss rule alone; more take panels no wider
/// than [`INTERP_WIDEST`] and their moments.
fn psi_rule(delta: f64, orders: usize) -> std::rc::Rc<PsiRule> {
    use std::cell::RefCell;
    use std::rc::Rc;
    thread_local! {
        static CACHE: RefCell<Vec<(RuleKey, Rc<PsiRule>)>> = const { RefCell::new(Vec::new()) };
    }
    CACHE.with(|c| {
        let mut c = c.borrow_mut();
        let key = (delta.to_bits(), orders);
        if let Some((_, r)) = c.iter().find(|(k, _)| *k == key) {
            return Rc::clone(r);
        }
        let graded = graded_edges(0.0, PI, 0.0, delta, &[]);
        let edges = if orders > 1 { capped(&graded, INTERP_WIDEST) } else { graded };
        let r = Rc::new(PsiRule::new(edges, orders));
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

    /// A minimal complex number: the Fresnel amplitudes of eq. R5 as written.
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

    /// `F^m` by brute force: panels of at most 0.004 rad, graded towards
    /// the lobe from `alpha / 1000` and towards a total-reflection kink from
    /// 1e-9 rad, 8 Gauss points each, `cos(m psi)` evaluated directly.
    fn fourier_brute(
        mf: &Microfacet,
        (mu_o, mu_i): (f64, f64),
        n_i: f64,
        far: Far,
        transmit: bool,
        orders: usize,
    ) -> Vec<f64> {
        let (si, so) = ((1.0 - mu_i * mu_i).sqrt(), (1.0 - mu_o * mu_o).sqrt());
        let z = if transmit { -mu_o } else { mu_o };
        let mut cuts = graded_edges(0.0, PI, 0.0, 1e-3 * mf.alpha(), &[]);
        // Every angle where i.o crosses a total-reflection kink.
        if let Far::Dielectric(n_t) = far {
            let r = n_t.min(n_i) / n_t.max(n_i);
            for target in [r - mu_i * mu_o, mu_i * mu_o - (1.0 - 2.0 * r * r)] {
                let cp = target / (si * so);
                if cp.abs() < 1.0 {
                    cuts = graded_edges(0.0, PI, cp.acos(), 1e-9, &cuts);
                }
            }
        }
        let (x, w) = panel_rule(&capped(&cuts, 0.004));
        let mut out = vec![0.0; orders];
        for (psi, wt) in x.iter().zip(&w) {
            let f = mf.bsdf([si, 0.0, mu_i], [-so * psi.cos(), -so * psi.sin(), z], n_i, far);
            for (m, slot) in out.iter_mut().enumerate() {
                *slot += 2.0 * wt * f * (m as f64 * psi).cos();
            }
        }
        out
    }

    /// The azimuthal coefficients (eq. R6a: moments of the interpolant,
    /// panels split at a kink; eq. R6b: the lobe's width) against brute
    /// force, every order up to 64, over roughness, both distributions,
    /// reflection and refraction from either side of a glass face, and a
    /// conductor; errors relative to order 0 (at least 1e-3).
    #[test]
    fn fourier_coefficients_match_a_brute_force_rule() {
        let faces = [
            (1.0, Far::Dielectric(1.5)),
            (1.5, Far::Dielectric(1.0)),
            (1.0, Far::Conductor(0.35, 2.7)),
        ];
        let mut worst = (0.0f64, String::new());
        for dist in [Distribution::Ggx, Distribution::Beckmann] {
            for alpha in [0.1, 0.3, 0.6] {
                let mf = Microfacet::new(alpha, dist).unwrap();
                for (n_i, far) in faces {
                    for transmit in [false, true] {
                        if transmit && matches!(far, Far::Conductor(..)) {
                            continue;
                        }
                        for mu_i in [0.97, 0.7, 0.35, 0.1, 0.01] {
                            for mu_o in [0.99, 0.9, 0.75, 0.6, 0.45, 0.3, 0.15, 0.05, 0.01] {
                                for orders in [12, 33, 64] {
                                    let mut c = vec![0.0; orders];
                                    mf.fourier(mu_o, mu_i, n_i, far, transmit, &mut c);
                                    let r = fourier_brute(
                                        &mf,
                                        (mu_o, mu_i),
                                        n_i,
                                        far,
                                        transmit,
                                        orders,
                                    );
                                    let scale = r[0].abs().max(1e-3);
                                    for m in 0..orders {
                                        let e = (c[m] - r[m]).abs() / scale;
                                        if e > worst.0 {
                                            worst = (
                                                e,
                                                format!(
                                                    "{dist:?} {alpha} {n_i} {far:?} t{transmit} {mu_i} {mu_o} M{orders} m{m}: {} vs {}",
                                                    c[m], r[m]
                                                ),
                                            );
                                        }
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
        // Measured: 5.4e-6 (Beckmann 0.6, grazing reflection, order 42);
        // the Gauss rule capped at 4/M that eq. R6a replaced: 4.4e-5.
        assert!(worst.0 < 1e-5, "{:.3e} at {}", worst.0, worst.1);
    }

    /// The pairs of directions the two tests of [`AtPair`] go over: both
    /// distributions at `alphas`, every face of `faces`, reflection and
    /// transmission, normal to grazing cosines; `f` gets the pair, its
    /// microfacets, and `(n_i, far, transmit, mu_i, mu_o)`.
    fn each_pair(
        faces: &[(f64, Far)],
        alphas: [f64; 3],
        mut f: impl FnMut(AtPair, &Microfacet, (f64, Far, bool, f64, f64)),
    ) {
        for dist in [Distribution::Ggx, Distribution::Beckmann] {
            for alpha in alphas {
                let mf = Microfacet::new(alpha, dist).unwrap();
                for &(n_i, far) in faces {
                    for transmit in [false, true] {
                        for mu_i in [1.0, 0.9, 0.5, 0.1, 0.01] {
                            for mu_o in [1.0, 0.8, 0.45, 0.2, 0.02] {
                                let pair = AtPair::new(mf, (mu_o, mu_i), n_i, far, transmit);
                                f(pair, &mf, (n_i, far, transmit, mu_i, mu_o));
                            }
                        }
                    }
                }
            }
        }
    }

    /// [`AtPair`] is [`Microfacet::bsdf`] written in the half vector's
    /// parts: the same values to rounding over both distributions, glass
    /// from either side (refraction kinks and total reflection), a
    /// conductor, grazing and normal directions, every azimuth.
    #[test]
    fn pair_is_the_bsdf() {
        let faces = [
            (1.0, Far::Dielectric(1.5)),
            (1.5, Far::Dielectric(1.0)),
            (1.33, Far::Conductor(0.47, 2.4)),
        ];
        let mut worst = 0.0f64;
        each_pair(&faces, [0.05, 0.3, 0.8], |pair, mf, (n_i, far, transmit, mu_i, mu_o)| {
            let (si, so) = ((1.0 - mu_i * mu_i).sqrt(), (1.0 - mu_o * mu_o).sqrt());
            let z = if transmit { -mu_o } else { mu_o };
            for k in 0..=36 {
                let (s, c) = (PI * k as f64 / 36.0).sin_cos();
                let want = mf.bsdf([si, 0.0, mu_i], [-so * c, -so * s, z], n_i, far);
                let got = pair.at(c, s);
                worst = worst.max((got - want).abs() / want.abs().max(1e-3));
            }
        });
        assert!(worst < 1e-11, "{worst:.2e}");
    }

    /// Eq. R6c against the pointwise BSDF ([`Microfacet::bsdf`], the
    /// vector form): a pair of refraction that [`AtPair::dark_refraction`]
    /// calls dark is zero at every azimuth, and a lit one is zero at every
    /// azimuth beyond its kink `cos psi_k = (n_rare / n_dense - mu_i mu_o)
    /// / (sin_i sin_o)`; both are met (lit pairs with a kink inside, dark
    /// pairs), so the test sees both cases.
    #[test]
    fn refraction_is_dark_where_eq_r6c_says() {
        let faces = [
            (1.0, Far::Dielectric(1.5)),
            (1.5, Far::Dielectric(1.0)),
            (1.33, Far::Dielectric(1.0)),
            (1.0, Far::Dielectric(1.7)),
        ];
        let (mut dark, mut kinked, mut lit_values) = (0, 0, 0);
        each_pair(&faces, [0.05, 0.3, 0.8], |pair, mf, (n_i, far, transmit, mu_i, mu_o)| {
            if !transmit {
                return;
            }
            let Far::Dielectric(n_t) = far else { return };
            let (si, so) = ((1.0 - mu_i * mu_i).sqrt(), (1.0 - mu_o * mu_o).sqrt());
            let r = n_i.min(n_t) / n_i.max(n_t);
            let is_dark = pair.dark_refraction();
            let kink = ((r - mu_i * mu_o) / (si * so)).clamp(-1.0, 1.0).acos();
            dark += usize::from(is_dark);
            kinked += usize::from(!is_dark && kink < PI);
            for k in 0..=2000 {
                let psi = PI * k as f64 / 2000.0;
                let f =
                    mf.bsdf([si, 0.0, mu_i], [-so * psi.cos(), -so * psi.sin(), -mu_o], n_i, far);
                if is_dark || psi > kink {
                    assert_eq!(
                        f, 0.0,
                        "{n_i} -> {n_t}, {mu_i} {mu_o}, psi {psi} (kink {kink}): {f}"
                    );
                } else {
                    lit_values += usize::from(f > 0.0);
                }
            }
        });
        assert!(dark > 100 && kinked > 100 && lit_values > 10_000, "{dark} {kinked} {lit_values}");
    }

    /// [`AtPair::add_many`] (the loops the compiler vectorises) against
    /// [`AtPair::at`] point by point: equal bit for bit over both
    /// distributions, glass from either side (total reflection, the kinks
    /// of refraction), a conductor, a face between equal indices, normal
    /// and grazing directions, every azimuth.
    #[test]
    fn batch_is_the_pointwise_bsdf() {
        let faces = [
            (1.0, Far::Dielectric(1.5)),
            (1.5, Far::Dielectric(1.0)),
            (1.33, Far::Conductor(0.47, 2.4)),
            (1.2, Far::Dielectric(1.2)),
        ];
        let (c, s): (Vec<f64>, Vec<f64>) =
            (0..=720).map(|k| (PI * k as f64 / 720.0).sin_cos()).map(|(s, c)| (c, s)).unzip();
        let mut compared = 0;
        each_pair(&faces, [0.01, 0.3, 0.8], |pair, mf, (n_i, far, transmit, mu_i, mu_o)| {
            let mut got = vec![0.0; c.len()];
            pair.add_many((&c, &s), 0.7, &mut got);
            let (alpha, dist) = (mf.alpha(), mf.distribution());
            for k in 0..c.len() {
                let want = 0.0 + 0.7 * pair.at(c[k], s[k]);
                assert_eq!(
                    got[k].to_bits(),
                    want.to_bits(),
                    "{dist:?} {alpha} {n_i} {far:?} t{transmit} {mu_i} {mu_o} {k}: {} {want}",
                    got[k]
                );
                compared += usize::from(want != 0.0);
            }
        });
        assert!(compared > 100_000, "{compared}");
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

    /// The real form of [`conductor_reflectance`] against eq. R5's complex
    /// amplitudes computed as written (Born & Wolf), over metals, a
    /// dielectric (k = 0, total reflection included) and every cosine.
    #[test]
    fn conductor_reflectance_is_the_complex_amplitudes() {
        let complex = |cos_i: f64, n_i: f64, n: f64, k: f64| -> f64 {
            let c = cos_i.abs().min(1.0);
            let eta = C::new(n / n_i, k / n_i);
            let s2 = (1.0 - c) * (1.0 + c);
            let cos_t = (C::new(1.0, 0.0) - C::new(s2, 0.0) / (eta * eta)).sqrt();
            let ci = C::new(c, 0.0);
            let rs = (ci - eta * cos_t) / (ci + eta * cos_t);
            let rp = (eta * ci - cos_t) / (eta * ci + cos_t);
            0.5 * (rs.norm2() + rp.norm2())
        };
        let mut worst = 0.0f64;
        for (n_i, n, k) in [
            (1.0, 0.35, 2.7),
            (1.5, 0.18, 3.4),
            (1.0, 2.9, 3.1),
            (1.33, 1.2, 7.0),
            (1.0, 1.5, 0.0),
            (1.5, 1.0, 0.0),
            (1.0, 1.5, 1e-3),
        ] {
            for i in 0..=400 {
                let c = i as f64 / 400.0;
                let (a, b) = (conductor_reflectance(c, n_i, n, k), complex(c, n_i, n, k));
                worst = worst.max((a - b).abs());
            }
        }
        // Measured 3.3e-16: the two forms differ by rounding alone.
        // Measured 5.1e-15 (n 1.2 + 7i under 1.33, cosines 0.2-0.3): the
        // two forms differ by rounding alone.
        assert!(worst < 2e-14, "{worst:e}");
    }

    /// The panels far from the peak, the kinks and the normal with 4
    /// points ([`panel_rule_mu_near`]) against 8 everywhere: the integrals
    /// over `u` of the coefficients of every order up to 8, as a rough
    /// face's operators take them (cells cut at 16 edges), GGX 0.3 and
    /// 0.05, reflection and refraction from either side of a glass face.
    #[test]
    fn fewer_points_far_from_the_singular_points_keep_the_integrals() {
        let mut worst = [0.0f64; 2];
        for (a, alpha) in [0.3, 0.05].into_iter().enumerate() {
            let mf = Microfacet::new(alpha, Distribution::Ggx).unwrap();
            for (n_i, n_t) in [(1.0, 1.5), (1.5, 1.0)] {
                for transmit in [false, true] {
                    let far = Far::Dielectric(n_t);
                    let n_o = if transmit { n_t } else { n_i };
                    let top = n_o * n_o;
                    for mu_i in [0.99, 0.8, 0.5, 0.2] {
                        let u_in = n_i * n_i * (1.0 - mu_i * mu_i);
                        let mut singular = mf.kink_cuts(mu_i, n_i, far, transmit);
                        let mut cuts: Vec<f64> = (1..16).map(|k| top * k as f64 / 16.0).collect();
                        cuts.extend(&singular);
                        singular.extend([u_in, 0.0]);
                        let width = mf.lobe_width_u(top, mu_i) / sharpness(n_i, far, transmit);
                        let edges = graded_edges(0.0, top, u_in, width, &cuts);
                        let integral = |(x, w): (Vec<f64>, Vec<f64>)| {
                            let mut sum = FourierSum::new(9);
                            for (&u, &wt) in x.iter().zip(&w) {
                                let mu_o = (1.0 - u / top).max(0.0).sqrt();
                                mf.fourier_add((mu_o, mu_i), n_i, far, transmit, wt, &mut sum);
                            }
                            let mut out = vec![0.0; 9];
                            sum.finish_into(&mut out);
                            out
                        };
                        let all = integral(panel_rule_mu(&edges, top));
                        let near = integral(panel_rule_mu_near(&edges, top, &singular));
                        for (x, y) in all.iter().zip(&near) {
                            worst[a] = worst[a].max((x - y).abs() / all[0].abs());
                        }
                    }
                }
            }
        }
        // Measured 2.9e-8 (0.3) and 9.0e-6 (0.05) of order 0. At 0.05 the
        // integrand itself is smooth in u only to the accuracy of the
        // azimuthal coefficients (1e-5 of order 0,
        // `fourier_coefficients_match_a_brute_force_rule`): their rule
        // switches with the lobe's width along u. Panels far at 4 widths
        // instead of 2 still differ by 6.8e-6 there. Without the normal
        // among the singular points: 2.1e-5 at 0.3.
        assert!(worst[0] < 1e-7, "{worst:?}");
        assert!(worst[1] < 1e-5, "{worst:?}");
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
