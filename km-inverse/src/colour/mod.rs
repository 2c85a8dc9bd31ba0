//! # Colour of spectra: CIE XYZ, CIELAB, sRGB and CIEDE2000
//!
//! The pipeline of `docs/colour.md`:
//!
//! 1. a [`Spectrum`] (reflectance or transmittance factors at wavelengths in
//!    nm; from numbers, or from a km [`Solution`] of a spectral scene with
//!    [`Spectrum::from_solution`]) is resampled to the 1 nm grid of the CIE
//!    tables, 360–780 nm (Sprague 1880 interpolation as CIE 167:2005
//!    recommends for uniformly spaced data, linear otherwise; constant beyond
//!    the measured range; eq. C1–C2);
//! 2. [`xyz`]: tristimulus values `X = k sum R(l) S(l) xbar(l)`, ... with
//!    `k = 100 / sum S(l) ybar(l)` (CIE 015:2018 eq. 7.1–7.4; eq. C3), for the
//!    CIE 1931 2° or 1964 10° observer ([`Observer`]) under D65 or D50
//!    ([`Illuminant`]);
//! 3. [`lab`]: CIELAB relative to the perfect reflecting diffuser under the
//!    same illuminant (CIE 015:2018 eq. 8.1–8.3; eq. C4);
//! 4. [`srgb`]: sRGB of D65-referred XYZ (IEC 61966-2-1: linear matrix and the
//!    piecewise gamma; eq. C5–C6), and back ([`xyz_from_srgb`]);
//! 5. [`ciede2000`]: the colour difference of two CIELAB colours (CIE
//!    142-2001; Sharma, Wu & Dalal 2005, eq. 1–22; eq. C7);
//! 6. [`swatch_svg`]: a small SVG image of labelled sRGB patches;
//! 7. [`report`]: the colour of a computed spectrum as the front ends report
//!    it (JSON, a line of text, table cells).
//!
//! The tables (`km-inverse/data/`) are the CIE's: colour-matching functions
//! at 1 nm (CIE 015:2018 Tables 1–2) and the D65, D50 relative spectral
//! power at 5 nm (CIE 015:2018 Table 5), extracted from the `colour-science`
//! package by `km-bench/scripts/cie_tables.py`. D illuminants are
//! interpolated linearly to 1 nm (CIE 015:2018 §7.2.1.1).

use std::sync::OnceLock;

use km_core::{Scene, Solution};
use thiserror::Error;

mod adaptation;
mod ciede2000;
pub mod report;
mod srgb;
mod swatch;
mod weights;

pub use adaptation::{SRGB_WHITE, bradford, srgb_adapted};
pub use ciede2000::{De2000Weights, ciede2000, ciede2000_weighted};
pub use srgb::{srgb, srgb_linear, xyz_from_srgb};
pub use swatch::{MAX_PATCHES, Patch, srgb_u8, swatch_svg};
pub use weights::{linear_srgb_weights, spectrum_channel_mix};

/// An error of the colour pipeline, naming the offending value.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ColourError {
    /// A number outside its domain.
    #[error("invalid {name} = {value}: {reason}")]
    Invalid {
        /// What the number is (`wavelength_nm`, `k_l`, ...).
        name: String,
        /// The offending value.
        value: f64,
        /// The domain.
        reason: String,
    },
    /// A spectrum that cannot be used (lengths, order, missing wavelengths).
    #[error("spectrum: {0}")]
    Spectrum(String),
}

fn invalid(name: &str, value: f64, reason: impl Into<String>) -> ColourError {
    ColourError::Invalid { name: name.into(), value, reason: reason.into() }
}

// ---------------------------------------------------------------------------
// The CIE tables, embedded.

/// CIE 1931 2° and 1964 10° colour-matching functions, 360–830 nm at 1 nm.
const CMF_CSV: &str = include_str!("../../data/cie_cmf_1nm.csv");
/// D65 and D50 relative spectral power, 300–780 nm at 5 nm.
const ILLUMINANTS_CSV: &str = include_str!("../../data/cie_illuminants_5nm.csv");

/// First and last wavelength of the integration, nm: the CIE
/// colour-matching functions start at 360 nm; the D illuminant tables carried
/// here end at 780 nm (beyond it `ybar < 5e-5` of its peak).
pub const LAMBDA_MIN_NM: f64 = 360.0;
/// Last wavelength of the integration, nm (see [`LAMBDA_MIN_NM`]).
pub const LAMBDA_MAX_NM: f64 = 780.0;
/// Number of 1 nm samples of the integration grid.
const N_GRID: usize = 421;

/// A CIE standard observer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Observer {
    /// CIE 1931 2° standard colorimetric observer.
    #[default]
    Cie1931TwoDegree,
    /// CIE 1964 10° supplementary standard colorimetric observer.
    Cie1964TenDegree,
}

/// A CIE illuminant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Illuminant {
    /// CIE standard illuminant D65 (average daylight, 6504 K).
    #[default]
    D65,
    /// CIE illuminant D50 (5003 K; graphic arts).
    D50,
}

/// Tristimulus values (`Y = 100` for the perfect reflecting diffuser).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Xyz {
    /// `X`.
    pub x: f64,
    /// `Y` (luminance factor x 100).
    pub y: f64,
    /// `Z`.
    pub z: f64,
}

/// CIELAB coordinates (CIE 1976 L*a*b*).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lab {
    /// Lightness `L*`, 0 (black) to 100 (the white).
    pub l: f64,
    /// `a*`: green (-) to red (+).
    pub a: f64,
    /// `b*`: blue (-) to yellow (+).
    pub b: f64,
}

/// Integration weights `k S(l) xbar(l)`, ... on the 1 nm grid.
struct Weights {
    wx: Vec<f64>,
    wy: Vec<f64>,
    wz: Vec<f64>,
}

/// The parsed tables and the four weight sets.
struct Tables {
    /// `[observer][illuminant]`.
    weights: [[Weights; 2]; 2],
}

/// Rows of numbers of an embedded CSV (comments `#`, one header line).
fn parse_csv(text: &str, columns: usize) -> Vec<Vec<f64>> {
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .skip(1)
        .map(|l| {
            let row: Vec<f64> =
                l.split(',').map(|x| x.trim().parse().unwrap_or(f64::NAN)).collect();
            assert_eq!(row.len(), columns, "embedded CIE table row: {l}");
            row
        })
        .collect()
}

fn tables() -> &'static Tables {
    static TABLES: OnceLock<Tables> = OnceLock::new();
    TABLES.get_or_init(|| {
        // The files are part of the crate and checked by the tests
        // (`tables_are_the_cie_grids`); a malformed row is a build defect.
        let cmf = parse_csv(CMF_CSV, 7);
        let ill = parse_csv(ILLUMINANTS_CSV, 3);
        // CMF rows: 360, 361, ... nm; the grid is the first N_GRID of them.
        let start = (LAMBDA_MIN_NM - cmf[0][0]) as usize;
        // Illuminant at 1 nm by linear interpolation of the 5 nm table
        // (CIE 015:2018 §7.2.1.1 for the D series).
        let illum_at = |col: usize, lambda: f64| -> f64 {
            let pos = (lambda - ill[0][0]) / 5.0;
            let i = (pos.floor() as usize).min(ill.len() - 2);
            let t = pos - i as f64;
            ill[i][col] * (1.0 - t) + ill[i + 1][col] * t
        };
        let make = |obs: usize, col: usize| -> Weights {
            let (mut wx, mut wy, mut wz) =
                (vec![0.0; N_GRID], vec![0.0; N_GRID], vec![0.0; N_GRID]);
            for j in 0..N_GRID {
                let row = &cmf[start + j];
                let s = illum_at(col, LAMBDA_MIN_NM + j as f64);
                wx[j] = s * row[1 + 3 * obs];
                wy[j] = s * row[2 + 3 * obs];
                wz[j] = s * row[3 + 3 * obs];
            }
            // k = 100 / sum S ybar: the perfect diffuser has Y = 100 (eq. C3).
            let k = 100.0 / wy.iter().sum::<f64>();
            for w in [&mut wx, &mut wy, &mut wz] {
                w.iter_mut().for_each(|v| *v *= k);
            }
            Weights { wx, wy, wz }
        };
        Tables { weights: [[make(0, 1), make(0, 2)], [make(1, 1), make(1, 2)]] }
    })
}

fn weights(observer: Observer, illuminant: Illuminant) -> &'static Weights {
    let o = match observer {
        Observer::Cie1931TwoDegree => 0,
        Observer::Cie1964TenDegree => 1,
    };
    let i = match illuminant {
        Illuminant::D65 => 0,
        Illuminant::D50 => 1,
    };
    &tables().weights[o][i]
}

// ---------------------------------------------------------------------------
// Spectra.

/// Which spectrum of a solution to take.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// Total reflectance (specular part included).
    Reflectance,
    /// Total transmittance (unscattered part included).
    Transmittance,
}

/// A spectral reflectance or transmittance factor: values at wavelengths
/// in nm (strictly increasing, finite, `> 0`).
#[derive(Debug, Clone, PartialEq)]
pub struct Spectrum {
    wavelengths_nm: Vec<f64>,
    values: Vec<f64>,
}

impl Spectrum {
    /// A spectrum from wavelengths (nm) and values.
    ///
    /// # Errors
    /// Different lengths, no value, a wavelength not finite or `<= 0`,
    /// wavelengths not strictly increasing, a value not finite.
    ///
    /// ```
    /// use km_inverse::colour::Spectrum;
    /// assert!(Spectrum::new(vec![400.0, 500.0], vec![0.1, 0.2]).is_ok());
    /// assert!(Spectrum::new(vec![500.0, 400.0], vec![0.1, 0.2]).is_err());
    /// ```
    pub fn new(wavelengths_nm: Vec<f64>, values: Vec<f64>) -> Result<Spectrum, ColourError> {
        if wavelengths_nm.len() != values.len() {
            return Err(ColourError::Spectrum(format!(
                "{} wavelengths but {} values",
                wavelengths_nm.len(),
                values.len()
            )));
        }
        if values.is_empty() {
            return Err(ColourError::Spectrum("no value".into()));
        }
        for (i, &w) in wavelengths_nm.iter().enumerate() {
            if !w.is_finite() || w <= 0.0 {
                return Err(invalid("wavelength_nm", w, "must be finite and > 0"));
            }
            if i > 0 && w <= wavelengths_nm[i - 1] {
                return Err(invalid("wavelength_nm", w, "wavelengths must increase strictly"));
            }
        }
        if let Some(&v) = values.iter().find(|v| !v.is_finite()) {
            return Err(invalid("value", v, "must be finite"));
        }
        Ok(Spectrum { wavelengths_nm, values })
    }

    /// The reflectance or transmittance spectrum of a solved spectral scene
    /// (its `[spectrum] wavelengths_nm`, one value per channel).
    ///
    /// # Errors
    /// A scene without wavelengths, a solution with another channel count,
    /// and those of [`Spectrum::new`] (wavelengths must increase).
    ///
    /// ```
    /// use km_core::{Scene, two_flux};
    /// use km_inverse::colour::{Quantity, Spectrum};
    /// let scene = Scene::from_toml_str("[spectrum]\nwavelengths_nm = [450.0, 550.0, 650.0]\n\
    ///     [[layer]]\nsigma_a = [0.5, 0.1, 0.05]\nsigma_s = 4.0\nthickness = 1.0\n").unwrap();
    /// let sol = two_flux::solve(&scene, &Default::default()).unwrap();
    /// let r = Spectrum::from_solution(&scene, &sol, Quantity::Reflectance).unwrap();
    /// assert_eq!(r.wavelengths_nm(), &[450.0, 550.0, 650.0]);
    /// ```
    pub fn from_solution(
        scene: &Scene,
        solution: &Solution,
        quantity: Quantity,
    ) -> Result<Spectrum, ColourError> {
        let w = scene.wavelengths_nm().ok_or_else(|| {
            ColourError::Spectrum("the scene has no [spectrum] wavelengths_nm".into())
        })?;
        if w.len() != solution.channels.len() {
            return Err(ColourError::Spectrum(format!(
                "the scene has {} wavelengths but the solution {} channels",
                w.len(),
                solution.channels.len()
            )));
        }
        let values = solution
            .channels
            .iter()
            .map(|c| match quantity {
                Quantity::Reflectance => c.reflectance,
                Quantity::Transmittance => c.transmittance,
            })
            .collect();
        Spectrum::new(w.to_vec(), values)
    }

    /// The wavelengths, nm.
    pub fn wavelengths_nm(&self) -> &[f64] {
        &self.wavelengths_nm
    }

    /// The values.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// True when the wavelengths are equally spaced (to 1e-9 of the step).
    fn is_uniform(&self) -> bool {
        let w = &self.wavelengths_nm;
        if w.len() < 2 {
            return false;
        }
        let step = (w[w.len() - 1] - w[0]) / (w.len() - 1) as f64;
        w.windows(2).all(|p| ((p[1] - p[0]) - step).abs() <= 1e-9 * step)
    }

    /// The value at `lambda` nm: Sprague interpolation for six or more
    /// equally spaced samples (eq. C1, CIE 167:2005), linear interpolation
    /// otherwise (eq. C2), the nearest end value outside the measured range
    /// (CIE 015:2018 §7.2.2).
    ///
    /// ```
    /// use km_inverse::colour::Spectrum;
    /// // Sprague reproduces polynomials up to degree 5 inside the range.
    /// let w: Vec<f64> = (0..9).map(|i| 400.0 + 10.0 * i as f64).collect();
    /// let f = |x: f64| { let t = (x - 400.0) / 80.0; 0.2 + 0.5 * t - 0.3 * t * t * t };
    /// let s = Spectrum::new(w.clone(), w.iter().map(|&x| f(x)).collect()).unwrap();
    /// assert!((s.value_at(433.0) - f(433.0)).abs() < 1e-12);
    /// assert_eq!(s.value_at(300.0), f(400.0));
    /// ```
    pub fn value_at(&self, lambda: f64) -> f64 {
        let (w, v) = (&self.wavelengths_nm, &self.values);
        let n = w.len();
        // Constant extrapolation beyond the ends.
        if lambda <= w[0] {
            return v[0];
        }
        if lambda >= w[n - 1] {
            return v[n - 1];
        }
        if n >= 6 && self.is_uniform() {
            return sprague(w[0], (w[n - 1] - w[0]) / (n - 1) as f64, v, lambda);
        }
        // Linear between the neighbours.
        let i = w.partition_point(|&x| x <= lambda) - 1;
        let t = (lambda - w[i]) / (w[i + 1] - w[i]);
        v[i] * (1.0 - t) + v[i + 1] * t
    }
}

/// Sprague (1880) quintic interpolation of uniformly spaced samples
/// `v` (first wavelength `w0`, step `dw`, `len >= 6`) at `lambda` inside the
/// range (eq. C1). Two points are added at each end with the boundary
/// coefficients of CIE 167:2005 (Westland, Ripamonti & Cheung 2012, §4.2).
fn sprague(w0: f64, dw: f64, v: &[f64], lambda: f64) -> f64 {
    let n = v.len();
    // Boundary extension (CIE 167:2005): p_{-2}, p_{-1}, p_{n}, p_{n+1}.
    #[rustfmt::skip]
    const C: [[f64; 6]; 4] = [
        [884.0, -1960.0, 3033.0, -2648.0, 1080.0, -180.0],
        [508.0, -540.0, 488.0, -367.0, 144.0, -24.0],
        [-24.0, 144.0, -367.0, 488.0, -540.0, 508.0],
        [-180.0, 1080.0, -2648.0, 3033.0, -1960.0, 884.0],
    ];
    let dot = |c: &[f64; 6], p: &[f64]| c.iter().zip(p).map(|(a, b)| a * b).sum::<f64>() / 209.0;
    let pos = (lambda - w0) / dw;
    let i = (pos.floor() as usize).min(n - 2);
    let x = pos - i as f64;
    // p(j) for j = i-2 ..= i+3, with the extension beyond the ends.
    let p = |j: isize| -> f64 {
        match j {
            -2 => dot(&C[0], &v[0..6]),
            -1 => dot(&C[1], &v[0..6]),
            j if j == n as isize => dot(&C[2], &v[n - 6..]),
            j if j == n as isize + 1 => dot(&C[3], &v[n - 6..]),
            j => v[j as usize],
        }
    };
    let ii = i as isize;
    let (pm2, pm1, p0, p1, p2, p3) = (p(ii - 2), p(ii - 1), p(ii), p(ii + 1), p(ii + 2), p(ii + 3));
    // Sprague's coefficients of the quintic on [p_i, p_{i+1}] (eq. C1).
    let a0 = p0;
    let a1 = (2.0 * pm2 - 16.0 * pm1 + 16.0 * p1 - 2.0 * p2) / 24.0;
    let a2 = (-pm2 + 16.0 * pm1 - 30.0 * p0 + 16.0 * p1 - p2) / 24.0;
    let a3 = (-9.0 * pm2 + 39.0 * pm1 - 70.0 * p0 + 66.0 * p1 - 33.0 * p2 + 7.0 * p3) / 24.0;
    let a4 = (13.0 * pm2 - 64.0 * pm1 + 126.0 * p0 - 124.0 * p1 + 61.0 * p2 - 12.0 * p3) / 24.0;
    let a5 = (-5.0 * pm2 + 25.0 * pm1 - 50.0 * p0 + 50.0 * p1 - 25.0 * p2 + 5.0 * p3) / 24.0;
    a0 + x * (a1 + x * (a2 + x * (a3 + x * (a4 + x * a5))))
}

// ---------------------------------------------------------------------------
// Tristimulus values, CIELAB.

/// CIE tristimulus values of a reflectance or transmittance factor under an
/// illuminant, for an observer:
///
/// `X = k sum_l R(l) S(l) xbar(l) dl`, `Y`, `Z` likewise,
/// `k = 100 / sum_l S(l) ybar(l) dl` (eq. C3), over 360–780 nm at 1 nm.
///
/// # Reference
/// CIE 015:2018 *Colorimetry*, eq. 7.1–7.4; resampling of the spectrum as in
/// [`Spectrum::value_at`].
///
/// ```
/// use km_inverse::colour::{Illuminant, Observer, Spectrum, xyz};
/// // The perfect reflecting diffuser: the white point, Y = 100.
/// let white = Spectrum::new(vec![500.0], vec![1.0]).unwrap();
/// let w = xyz(&white, Observer::Cie1931TwoDegree, Illuminant::D65);
/// assert!((w.y - 100.0).abs() < 1e-12 && (w.x - 95.047).abs() < 0.01);
/// ```
pub fn xyz(spectrum: &Spectrum, observer: Observer, illuminant: Illuminant) -> Xyz {
    let w = weights(observer, illuminant);
    let (mut x, mut y, mut z) = (0.0, 0.0, 0.0);
    for j in 0..N_GRID {
        let r = spectrum.value_at(LAMBDA_MIN_NM + j as f64);
        x += r * w.wx[j];
        y += r * w.wy[j];
        z += r * w.wz[j];
    }
    Xyz { x, y, z }
}

/// The white point: [`xyz`] of the perfect reflecting diffuser (`R = 1`),
/// `Y = 100`.
///
/// ```
/// use km_inverse::colour::{Illuminant, Observer, white_point};
/// let w = white_point(Observer::Cie1931TwoDegree, Illuminant::D50);
/// assert!((w.x - 96.422).abs() < 0.01 && (w.z - 82.521).abs() < 0.01);
/// ```
pub fn white_point(observer: Observer, illuminant: Illuminant) -> Xyz {
    let w = weights(observer, illuminant);
    Xyz { x: w.wx.iter().sum(), y: w.wy.iter().sum(), z: w.wz.iter().sum() }
}

/// `f(t)` of CIELAB: `t^(1/3)` above `(6/29)^3`, else `t / (3 (6/29)^2) + 4/29`.
fn lab_f(t: f64) -> f64 {
    const D: f64 = 6.0 / 29.0;
    if t > D * D * D { t.cbrt() } else { t / (3.0 * D * D) + 4.0 / 29.0 }
}

fn lab_f_inv(f: f64) -> f64 {
    const D: f64 = 6.0 / 29.0;
    if f > D { f * f * f } else { 3.0 * D * D * (f - 4.0 / 29.0) }
}

/// CIELAB of tristimulus values relative to the white `white`:
///
/// `L* = 116 f(Y/Yn) - 16`, `a* = 500 (f(X/Xn) - f(Y/Yn))`,
/// `b* = 200 (f(Y/Yn) - f(Z/Zn))` (eq. C4), `f` as in CIE 015:2018.
///
/// # Errors
/// A white with a component not finite or `<= 0`.
///
/// # Reference
/// CIE 015:2018, eq. 8.1–8.3 (with the linear segment below `(24/116)^3`).
///
/// ```
/// use km_inverse::colour::{Illuminant, Observer, lab, white_point};
/// let w = white_point(Observer::Cie1931TwoDegree, Illuminant::D65);
/// let l = lab(w, w).unwrap();
/// assert!((l.l - 100.0).abs() < 1e-12 && l.a.abs() < 1e-12 && l.b.abs() < 1e-12);
/// ```
pub fn lab(xyz: Xyz, white: Xyz) -> Result<Lab, ColourError> {
    for (name, v) in [("white X", white.x), ("white Y", white.y), ("white Z", white.z)] {
        if !v.is_finite() || v <= 0.0 {
            return Err(invalid(name, v, "the white must be finite and > 0"));
        }
    }
    let (fx, fy, fz) = (lab_f(xyz.x / white.x), lab_f(xyz.y / white.y), lab_f(xyz.z / white.z));
    Ok(Lab { l: 116.0 * fy - 16.0, a: 500.0 * (fx - fy), b: 200.0 * (fy - fz) })
}

/// Tristimulus values of a CIELAB colour relative to `white` (the inverse
/// of [`lab`]).
///
/// # Reference
/// CIE 015:2018, §8.2.1 (inverse of eq. 8.1–8.3).
///
/// ```
/// use km_inverse::colour::{Xyz, lab, xyz_from_lab};
/// let w = Xyz { x: 95.047, y: 100.0, z: 108.883 };
/// let c = Xyz { x: 20.0, y: 30.0, z: 5.0 };
/// let back = xyz_from_lab(lab(c, w).unwrap(), w);
/// assert!((back.x - 20.0).abs() < 1e-12 && (back.z - 5.0).abs() < 1e-12);
/// ```
pub fn xyz_from_lab(lab: Lab, white: Xyz) -> Xyz {
    let fy = (lab.l + 16.0) / 116.0;
    let fx = fy + lab.a / 500.0;
    let fz = fy - lab.b / 200.0;
    Xyz { x: white.x * lab_f_inv(fx), y: white.y * lab_f_inv(fy), z: white.z * lab_f_inv(fz) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_are_the_cie_grids() {
        let cmf = parse_csv(CMF_CSV, 7);
        let ill = parse_csv(ILLUMINANTS_CSV, 3);
        // 360-830 nm at 1 nm; 300-780 nm at 5 nm; every entry a number.
        assert_eq!(cmf.len(), 471);
        assert!(cmf.iter().enumerate().all(|(i, r)| r[0] == 360.0 + i as f64));
        assert_eq!(ill.len(), 97);
        assert!(ill.iter().enumerate().all(|(i, r)| r[0] == 300.0 + 5.0 * i as f64));
        assert!(cmf.iter().chain(&ill).flatten().all(|x| x.is_finite() && *x >= 0.0));
        // Normalisations of the tables: ybar(555 nm) = 1 (2 deg), S(560 nm) = 100.
        assert_eq!(cmf[195][2], 1.0);
        assert!((ill[52][1] - 100.0).abs() < 1e-9 && (ill[52][2] - 100.0).abs() < 1e-9);
        // The grid of the integration lies inside both tables.
        assert_eq!(LAMBDA_MIN_NM + (N_GRID - 1) as f64, LAMBDA_MAX_NM);
    }
}
