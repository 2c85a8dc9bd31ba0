//! The CIEDE2000 colour difference (CIE 142:2001; Sharma, Wu & Dalal 2005).

use super::Lab;

/// Parametric factors of CIEDE2000 (`k_L`, `k_C`, `k_H`), 1 for the
/// reference conditions (textiles use `k_L = 2`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct De2000Weights {
    /// Lightness factor `k_L > 0`.
    pub k_l: f64,
    /// Chroma factor `k_C > 0`.
    pub k_c: f64,
    /// Hue factor `k_H > 0`.
    pub k_h: f64,
}

impl Default for De2000Weights {
    fn default() -> Self {
        De2000Weights { k_l: 1.0, k_c: 1.0, k_h: 1.0 }
    }
}

/// The CIEDE2000 colour difference `Delta E_00` of two CIELAB colours, with
/// the reference parametric factors `k_L = k_C = k_H = 1`.
///
/// See [`ciede2000_weighted`] for the formula.
///
/// # Reference
/// CIE 142-2001; Sharma, Wu & Dalal (2005), eq. 1–22.
///
/// ```
/// use km_inverse::colour::{Lab, ciede2000};
/// // Sharma, Wu & Dalal (2005), Table 1, pair 1.
/// let d = ciede2000(Lab { l: 50.0, a: 2.6772, b: -79.7751 },
///                   Lab { l: 50.0, a: 0.0, b: -82.7485 });
/// assert!((d - 2.0425).abs() < 1e-4);
/// ```
pub fn ciede2000(lab1: Lab, lab2: Lab) -> f64 {
    ciede2000_weighted(lab1, lab2, De2000Weights::default())
}

/// The CIEDE2000 colour difference with parametric factors:
///
/// ```text
/// C_ab = sqrt(a^2 + b^2),  G = (1 - sqrt(C^7 / (C^7 + 25^7))) / 2 (C: mean C_ab)
/// a' = (1 + G) a,  C' = sqrt(a'^2 + b^2),  h' = atan2(b, a') in [0, 360)
/// dL' = L2 - L1,  dC' = C'2 - C'1,  dh' = h'2 - h'1 wrapped to (-180, 180]
/// dH' = 2 sqrt(C'1 C'2) sin(dh'/2)
/// T = 1 - 0.17 cos(h - 30) + 0.24 cos(2h) + 0.32 cos(3h + 6) - 0.20 cos(4h - 63)
/// S_L = 1 + 0.015 (L - 50)^2 / sqrt(20 + (L - 50)^2),  S_C = 1 + 0.045 C,
/// S_H = 1 + 0.015 C T,  R_T = -sin(60 exp(-((h - 275)/25)^2)) 2 sqrt(C^7/(C^7 + 25^7))
/// dE00 = sqrt((dL'/k_L S_L)^2 + (dC'/k_C S_C)^2 + (dH'/k_H S_H)^2
///             + R_T (dC'/k_C S_C)(dH'/k_H S_H))                            (C7)
/// ```
///
/// with `L`, `C`, `h` the means of `L`, `C'`, `h'` (the hue mean taken on the
/// short arc, Sharma et al. eq. 14; the plain mean when `|h'1 - h'2| <= 180`).
/// Hues exactly 180° apart (Sharma's pairs 10 and 14, where the published
/// values take `|h'1 - h'2| = 180` as `<= 180`) are detected exactly, from
/// `a'1 b2 - b1 a'2 = 0` and `a'1 a'2 + b1 b2 < 0`, not from the rounded
/// difference of the two `atan2` angles.
///
/// # Reference
/// CIE 142-2001; Sharma, Wu & Dalal (2005), eq. 1–22.
pub fn ciede2000_weighted(lab1: Lab, lab2: Lab, w: De2000Weights) -> f64 {
    const P25_7: f64 = 6_103_515_625.0; // 25^7
    let rad = |d: f64| d.to_radians();
    // Chroma and the a* rescaling G (eq. 2-5).
    let c1 = lab1.a.hypot(lab1.b);
    let c2 = lab2.a.hypot(lab2.b);
    let c_bar7 = ((c1 + c2) / 2.0).powi(7);
    let g = 0.5 * (1.0 - (c_bar7 / (c_bar7 + P25_7)).sqrt());
    let (a1p, a2p) = ((1.0 + g) * lab1.a, (1.0 + g) * lab2.a);
    let (c1p, c2p) = (a1p.hypot(lab1.b), a2p.hypot(lab2.b));
    // Hue angles in [0, 360), 0 for a neutral (eq. 7).
    let hue = |a: f64, b: f64| {
        if a == 0.0 && b == 0.0 { 0.0 } else { b.atan2(a).to_degrees().rem_euclid(360.0) }
    };
    let (h1p, h2p) = (hue(a1p, lab1.b), hue(a2p, lab2.b));
    // Differences (eq. 8-11). Hue pairs exactly opposite (Sharma's pairs 10
    // and 14) are decided by the exact test cross = 0, dot < 0 rather than
    // by the rounding of h'2 - h'1 around 180: |h'2 - h'1| = 180 exactly.
    let dl = lab2.l - lab1.l;
    let dc = c2p - c1p;
    let neutral = c1p * c2p == 0.0;
    let cross = a1p * lab2.b - lab1.b * a2p;
    let dot = a1p * a2p + lab1.b * lab2.b;
    let opposite = cross == 0.0 && dot < 0.0;
    let diff = h2p - h1p;
    let dh = if neutral {
        0.0
    } else if opposite {
        180.0_f64.copysign(diff)
    } else if diff.abs() <= 180.0 {
        diff
    } else if diff > 180.0 {
        diff - 360.0
    } else {
        diff + 360.0
    };
    let d_big_h = 2.0 * (c1p * c2p).sqrt() * (rad(dh) / 2.0).sin();
    // Means (eq. 12-14).
    let l_bar = (lab1.l + lab2.l) / 2.0;
    let c_bar = (c1p + c2p) / 2.0;
    let h_sum = h1p + h2p;
    let h_bar = if neutral {
        h_sum
    } else if opposite || diff.abs() <= 180.0 {
        h_sum / 2.0
    } else if h_sum < 360.0 {
        (h_sum + 360.0) / 2.0
    } else {
        (h_sum - 360.0) / 2.0
    };
    // Weighting functions and rotation (eq. 15-22).
    let t = 1.0 - 0.17 * rad(h_bar - 30.0).cos()
        + 0.24 * rad(2.0 * h_bar).cos()
        + 0.32 * rad(3.0 * h_bar + 6.0).cos()
        - 0.20 * rad(4.0 * h_bar - 63.0).cos();
    let d_theta = 30.0 * (-((h_bar - 275.0) / 25.0).powi(2)).exp();
    let c_bar7p = c_bar.powi(7);
    let r_c = 2.0 * (c_bar7p / (c_bar7p + P25_7)).sqrt();
    let l50 = (l_bar - 50.0).powi(2);
    let s_l = 1.0 + 0.015 * l50 / (20.0 + l50).sqrt();
    let s_c = 1.0 + 0.045 * c_bar;
    let s_h = 1.0 + 0.015 * c_bar * t;
    let r_t = -(rad(2.0 * d_theta)).sin() * r_c;
    let (tl, tc, th) = (dl / (w.k_l * s_l), dc / (w.k_c * s_c), d_big_h / (w.k_h * s_h));
    (tl * tl + tc * tc + th * th + r_t * tc * th).max(0.0).sqrt()
}
