//! Chromatic adaptation by the Bradford transform: tristimulus values under
//! one white (e.g. D50, the graphic-arts illuminant) to the corresponding
//! colour under another (D65, the white of sRGB), so that a D50 result can
//! be shown as sRGB (`docs/colour.md` eq. C8).

use super::{Xyz, srgb};

/// The Bradford cone-response matrix (Lam 1985; ICC.1:2010 Annex E.3).
#[rustfmt::skip]
const M_BFD: [[f64; 3]; 3] = [
    [ 0.8951,  0.2664, -0.1614],
    [-0.7502,  1.7135,  0.0367],
    [ 0.0389, -0.0685,  1.0296],
];

/// `M x` for a 3 x 3 matrix.
fn mul(m: &[[f64; 3]; 3], x: [f64; 3]) -> [f64; 3] {
    m.map(|r| r[0] * x[0] + r[1] * x[1] + r[2] * x[2])
}

/// Inverse of a 3 x 3 matrix by cofactors (the Bradford matrix is well
/// conditioned: determinant ~ 1.8).
fn inverse(m: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let c = |r: usize, k: usize| {
        let (r1, r2, k1, k2) = ((r + 1) % 3, (r + 2) % 3, (k + 1) % 3, (k + 2) % 3);
        m[r1][k1] * m[r2][k2] - m[r1][k2] * m[r2][k1]
    };
    let det = m[0][0] * c(0, 0) + m[0][1] * c(0, 1) + m[0][2] * c(0, 2);
    let mut inv = [[0.0; 3]; 3];
    for (i, row) in inv.iter_mut().enumerate() {
        for (j, x) in row.iter_mut().enumerate() {
            *x = c(j, i) / det;
        }
    }
    inv
}

/// The colour under `white_to` corresponding to `xyz` under `white_from`
/// (Bradford, linear form as in ICC profiles):
///
/// `XYZ' = M^-1 diag(rho'_w / rho_w) M XYZ`, `rho_w = M XYZ_w`    (C8)
///
/// with `M` the Bradford matrix. The white goes to the white exactly.
///
/// # Reference
/// K. M. Lam, PhD thesis, University of Bradford (1985); ICC.1:2010
/// (profile format) Annex E.3; B. Lindbloom, "Chromatic adaptation"
/// (brucelindbloom.com), for the worked D50 -> D65 matrix of the test.
///
/// ```
/// use km_inverse::colour::{Illuminant, Observer, bradford, white_point};
/// let d50 = white_point(Observer::Cie1931TwoDegree, Illuminant::D50);
/// let d65 = white_point(Observer::Cie1931TwoDegree, Illuminant::D65);
/// let w = bradford(d50, d50, d65);
/// assert!((w.x - d65.x).abs() < 1e-12 && (w.z - d65.z).abs() < 1e-12);
/// ```
pub fn bradford(xyz: Xyz, white_from: Xyz, white_to: Xyz) -> Xyz {
    let rho = mul(&M_BFD, [xyz.x, xyz.y, xyz.z]);
    let (w0, w1) = (
        mul(&M_BFD, [white_from.x, white_from.y, white_from.z]),
        mul(&M_BFD, [white_to.x, white_to.y, white_to.z]),
    );
    let scaled = [rho[0] * w1[0] / w0[0], rho[1] * w1[1] / w0[1], rho[2] * w1[2] / w0[2]];
    let [x, y, z] = mul(&inverse(&M_BFD), scaled);
    Xyz { x, y, z }
}

/// The white of sRGB, `Y = 100`: `M (1, 1, 1)` of IEC 61966-2-1 eq. C5
/// (`x, y = 0.3127, 0.3290`, D65).
pub const SRGB_WHITE: Xyz = Xyz { x: 95.05, y: 100.0, z: 108.9 };

/// sRGB of tristimulus values referred to the white `white` (e.g. D50):
/// Bradford-adapted to the sRGB white (eq. C8), then [`srgb`]. A white
/// under `white` shows as sRGB white `(1, 1, 1)`.
///
/// # Reference
/// IEC 61966-2-1:1999 (sRGB); ICC.1:2010 Annex E.3 (Bradford).
pub fn srgb_adapted(xyz: Xyz, white: Xyz) -> [f64; 3] {
    srgb(bradford(xyz, white, SRGB_WHITE))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::{Illuminant, Observer, white_point};

    /// The D50 -> D65 matrix that Lindbloom publishes (7 decimals, whites
    /// (0.96422, 1, 0.82521) and (0.95047, 1, 1.08883)): ours to 5e-7, the
    /// rounding of the published digits.
    #[test]
    fn bradford_d50_to_d65_is_lindbloom_s_matrix() {
        #[rustfmt::skip]
        let want = [
            [ 0.9555766, -0.0230393, 0.0631636],
            [-0.0282895,  1.0099416, 0.0210077],
            [ 0.0122982, -0.0204830, 1.3299098],
        ];
        let (d50, d65) =
            (Xyz { x: 0.96422, y: 1.0, z: 0.82521 }, Xyz { x: 0.95047, y: 1.0, z: 1.08883 });
        for j in 0..3 {
            let mut e = [0.0; 3];
            e[j] = 1.0;
            let c = bradford(Xyz { x: e[0], y: e[1], z: e[2] }, d50, d65);
            for (i, got) in [c.x, c.y, c.z].into_iter().enumerate() {
                assert!((got - want[i][j]).abs() < 5e-7, "({i}, {j}): {got} vs {}", want[i][j]);
            }
        }
        // Adapting there and back is the identity.
        let x = Xyz { x: 20.0, y: 30.0, z: 10.0 };
        let back = bradford(bradford(x, d50, d65), d65, d50);
        assert!((back.x - 20.0).abs() < 1e-12 && (back.z - 10.0).abs() < 1e-12);
    }

    #[test]
    fn a_d50_white_shows_as_srgb_white() {
        let d50 = white_point(Observer::Cie1931TwoDegree, Illuminant::D50);
        let rgb = srgb_adapted(d50, d50);
        assert!(rgb.iter().all(|c| (c - 1.0).abs() < 1e-12), "{rgb:?}");
        // Unadapted, the D50 white is visibly yellowish in sRGB (blue well below 1).
        assert!(srgb(d50)[2] < 0.9);
    }
}
