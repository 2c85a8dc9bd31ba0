//! The linear sRGB of a spectrum as weights of its samples: what each
//! wavelength of a spectral scene adds to the colour (used to write a
//! spectral BSDF as RGB).

use super::{ColourError, Illuminant, Observer, Spectrum, srgb_linear, xyz};

/// Row `c`: the linear sRGB (D65, CIE 1931 2°; white `(1, 1, 1)`) that the
/// `c`-th sample of a spectrum on `wavelengths_nm` adds per unit value, so
/// that `sum_c w[c] v[c]` is `srgb_linear(xyz(v))` for every spectrum `v`
/// on those wavelengths (the resampling of eq. C1–C2, the sums of eq. C3
/// and the matrix of eq. C5 are all linear in the values).
///
/// # Errors
/// Those of [`Spectrum::new`] (wavelengths finite, > 0, increasing).
///
/// ```
/// use km_inverse::colour::linear_srgb_weights;
/// let w = linear_srgb_weights(&[450.0, 550.0, 650.0, 750.0]).unwrap();
/// // A flat spectrum of 1 is the D65 white: luminance 1, close to sRGB's white.
/// let sum = |j: usize| w.iter().map(|r| r[j]).sum::<f64>();
/// let y = 0.2126 * sum(0) + 0.7152 * sum(1) + 0.0722 * sum(2);
/// assert!((y - 1.0).abs() < 1e-12);
/// assert!((0..3).all(|j| (sum(j) - 1.0).abs() < 1e-3));
/// ```
pub fn linear_srgb_weights(wavelengths_nm: &[f64]) -> Result<Vec<[f64; 3]>, ColourError> {
    let n = wavelengths_nm.len();
    (0..n)
        .map(|c| {
            let values = (0..n).map(|k| if k == c { 1.0 } else { 0.0 }).collect();
            let unit = Spectrum::new(wavelengths_nm.to_vec(), values)?;
            Ok(srgb_linear(xyz(&unit, Observer::Cie1931TwoDegree, Illuminant::D65)))
        })
        .collect()
}

/// The channel mix of a Fourier BSDF file of a spectrum: the
/// [`linear_srgb_weights`] of its wavelengths when there are several, so
/// that the file holds the spectrum's colour; `None` for one wavelength or
/// none (channels with labels).
///
/// # Errors
/// Those of [`linear_srgb_weights`].
pub fn spectrum_channel_mix(
    wavelengths_nm: Option<&[f64]>,
) -> Result<Option<Vec<[f64; 3]>>, ColourError> {
    match wavelengths_nm {
        Some(w) if w.len() > 1 => linear_srgb_weights(w).map(Some),
        _ => Ok(None),
    }
}

#[cfg(test)]
mod tests {
    /// A Fourier file of a spectrum mixes its channels by the weights of
    /// its wavelengths; one wavelength or labels leave the channels as they are.
    #[test]
    fn channel_mix_of_a_spectrum_only() {
        let w = [450.0, 550.0, 650.0];
        assert_eq!(spectrum_channel_mix(Some(&w)).unwrap(), Some(linear_srgb_weights(&w).unwrap()));
        assert_eq!(spectrum_channel_mix(Some(&[550.0])).unwrap(), None);
        assert_eq!(spectrum_channel_mix(None).unwrap(), None);
    }

    use super::*;

    /// The weights give the colour of any spectrum (linearity), to rounding.
    #[test]
    fn weights_are_the_colour_of_every_spectrum() {
        for wl in [
            (400..=700).step_by(10).map(f64::from).collect::<Vec<_>>(), // Sprague
            vec![430.0, 520.0, 610.0, 700.0],                           // linear
        ] {
            let w = linear_srgb_weights(&wl).unwrap();
            let v: Vec<f64> = (0..wl.len()).map(|k| 0.5 + 0.4 * (k as f64 * 0.7).sin()).collect();
            let want = srgb_linear(xyz(
                &Spectrum::new(wl.clone(), v.clone()).unwrap(),
                Observer::Cie1931TwoDegree,
                Illuminant::D65,
            ));
            for j in 0..3 {
                let got: f64 = w.iter().zip(&v).map(|(r, x)| r[j] * x).sum();
                assert!((got - want[j]).abs() < 1e-12, "{j}: {got} vs {}", want[j]);
            }
        }
    }
}
