//! Error measures shared by the comparisons: relative errors of totals and
//! relative RMS errors of BRDFs over the exit directions.

/// Relative RMS difference of `x` from `reference` over the entries where
/// both are finite: `sqrt(sum (x - ref)^2) / sqrt(sum ref^2)`.
pub fn rel_rms(x: &[f64], reference: &[f64]) -> f64 {
    let mut num = 0.0;
    let mut den = 0.0;
    for (a, b) in x.iter().zip(reference) {
        if a.is_finite() && b.is_finite() {
            num += (a - b) * (a - b);
            den += b * b;
        }
    }
    if den > 0.0 { (num / den).sqrt() } else { f64::NAN }
}

/// Relative RMS of a list of standard errors against a reference:
/// `sqrt(sum se^2) / sqrt(sum ref^2)`, the expected [`rel_rms`] of pure noise.
pub fn rel_rms_noise(se: &[f64], reference: &[f64]) -> f64 {
    let num: f64 = se.iter().filter(|v| v.is_finite()).map(|v| v * v).sum();
    let den: f64 = reference.iter().filter(|v| v.is_finite()).map(|v| v * v).sum();
    if den > 0.0 { (num / den).sqrt() } else { f64::NAN }
}

/// Relative error `|x - ref| / |ref|` (absolute when `ref = 0`).
pub fn rel(x: f64, reference: f64) -> f64 {
    if reference != 0.0 { (x - reference).abs() / reference.abs() } else { (x - reference).abs() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rms_measures() {
        // Hand values: errors (0.1, -0.1) on references (1, 1): sqrt(0.02 / 2) = 0.1.
        assert!((rel_rms(&[1.1, 0.9], &[1.0, 1.0]) - 0.1).abs() < 1e-15);
        assert!((rel_rms_noise(&[0.1, 0.1], &[1.0, 1.0]) - 0.1).abs() < 1e-15);
        assert_eq!(rel(1.5, 1.0), 0.5);
        assert!(rel_rms(&[1.0], &[0.0]).is_nan());
    }
}
