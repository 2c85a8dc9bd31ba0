//! sRGB (IEC 61966-2-1): XYZ (D65) to and from encoded sRGB.

use super::Xyz;

/// Linear sRGB -> XYZ (D65, `Y` of white = 1), IEC 61966-2-1:1999 eq. 7.
#[rustfmt::skip]
const SRGB_TO_XYZ: [[f64; 3]; 3] = [
    [0.4124, 0.3576, 0.1805],
    [0.2126, 0.7152, 0.0722],
    [0.0193, 0.1192, 0.9505],
];

/// XYZ -> linear sRGB: the exact inverse of [`SRGB_TO_XYZ`] (the standard
/// prints it rounded to four decimals: 3.2406, -1.5372, -0.4986; -0.9689,
/// 1.8758, 0.0415; 0.0557, -0.2040, 1.0570; the test
/// `srgb_matrix_is_the_standards` checks the agreement to 1e-4).
fn xyz_to_srgb_matrix() -> [[f64; 3]; 3] {
    let m = SRGB_TO_XYZ;
    // Adjugate over determinant.
    let cof =
        |r0: usize, r1: usize, c0: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    let det = m[0][0] * cof(1, 2, 1, 2) - m[0][1] * cof(1, 2, 0, 2) + m[0][2] * cof(1, 2, 0, 1);
    [
        [cof(1, 2, 1, 2) / det, -cof(0, 2, 1, 2) / det, cof(0, 1, 1, 2) / det],
        [-cof(1, 2, 0, 2) / det, cof(0, 2, 0, 2) / det, -cof(0, 1, 0, 2) / det],
        [cof(1, 2, 0, 1) / det, -cof(0, 2, 0, 1) / det, cof(0, 1, 0, 1) / det],
    ]
}

/// sRGB encoding of a linear value (eq. C6), as IEC 61966-2-1 writes it:
/// `12.92 c` for `c <= 0.0031308` (negative, out-of-gamut values included),
/// else `1.055 c^(1/2.4) - 0.055` (values above 1 included). No clipping, so
/// [`xyz_from_srgb`] inverts it everywhere.
fn srgb_encode(c: f64) -> f64 {
    if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 }
}

/// The inverse of [`srgb_encode`]: `e / 12.92` for `e <= 0.04045`, else
/// `((e + 0.055) / 1.055)^2.4`.
fn srgb_decode(e: f64) -> f64 {
    if e <= 0.040_45 { e / 12.92 } else { ((e + 0.055) / 1.055).powf(2.4) }
}

/// sRGB (non-linear, `[0, 1]` in gamut; unclipped) of D65-referred
/// tristimulus values with `Y = 100` for white:
///
/// `(R, G, B)_lin = M^-1 (X, Y, Z) / 100` (eq. C5), then the sRGB transfer
/// function of eq. C6 on each channel. Colours outside the sRGB gamut give
/// values outside `[0, 1]` (clip for display; [`swatch_svg`](super::swatch_svg) does).
///
/// # Reference
/// IEC 61966-2-1:1999, §5.2 (eq. 5–7 and the inverse matrix of Annex).
///
/// ```
/// use km_inverse::colour::{Xyz, srgb};
/// // The sRGB white (x, y = 0.3127, 0.3290) is (1, 1, 1).
/// let w = Xyz { x: 100.0 * 0.4124 + 35.76 + 18.05, y: 100.0, z: 1.93 + 11.92 + 95.05 };
/// let rgb = srgb(w);
/// assert!(rgb.iter().all(|c| (c - 1.0).abs() < 1e-12));
/// ```
pub fn srgb(xyz: Xyz) -> [f64; 3] {
    srgb_linear(xyz).map(srgb_encode)
}

/// Linear sRGB (before the transfer function; white `(1, 1, 1)`) of
/// D65-referred tristimulus values with `Y = 100` for white:
/// `(R, G, B)_lin = M^-1 (X, Y, Z) / 100` (eq. C5). Linear in `XYZ`, so
/// the linear RGB of a spectrum is a weighted sum of its values (what a
/// renderer's RGB texture or BSDF file holds).
///
/// ```
/// use km_inverse::colour::{Xyz, srgb_linear};
/// let rgb = srgb_linear(Xyz { x: 41.24, y: 21.26, z: 1.93 });
/// assert!((rgb[0] - 1.0).abs() < 1e-12 && rgb[1].abs() < 1e-12 && rgb[2].abs() < 1e-12);
/// ```
pub fn srgb_linear(xyz: Xyz) -> [f64; 3] {
    let m = xyz_to_srgb_matrix();
    let v = [xyz.x / 100.0, xyz.y / 100.0, xyz.z / 100.0];
    m.map(|row| row[0] * v[0] + row[1] * v[1] + row[2] * v[2])
}

/// D65-referred tristimulus values (`Y = 100` for white) of an sRGB colour,
/// the inverse of [`srgb`].
///
/// # Reference
/// IEC 61966-2-1:1999, §5.2 (eq. 7 and the decoding of eq. 5).
///
/// ```
/// use km_inverse::colour::{srgb, xyz_from_srgb};
/// let c = xyz_from_srgb([0.2, 0.5, 0.8]);
/// let back = srgb(c);
/// assert!((back[0] - 0.2).abs() < 1e-12 && (back[2] - 0.8).abs() < 1e-12);
/// ```
pub fn xyz_from_srgb(rgb: [f64; 3]) -> Xyz {
    let lin = rgb.map(srgb_decode);
    let m = SRGB_TO_XYZ;
    let row = |r: usize| 100.0 * (m[r][0] * lin[0] + m[r][1] * lin[1] + m[r][2] * lin[2]);
    Xyz { x: row(0), y: row(1), z: row(2) }
}
