//! A spectrum (or any list of measurements) fitted row by row: the rows of
//! an `.rxt` or CSV file ([`crate::rxt`]) with the caller's overrides, each
//! fitted by [`crate::slab::fit`]; a row that cannot be fitted is reported
//! in its place and the others are fitted (`docs/inverse.md` §6).

use serde_json::{Value, json};

use crate::InverseError;
use crate::reflectance::{Fixed, fit_reflectance};
use crate::rxt::Row;
use crate::slab::{FitOptions, FitResult, fit};

/// The quantity held fixed in the rows that give `M_R` alone (iad's `-F`;
/// `docs/inverse.md` §7, eq. R3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RowFixed {
    /// The same fixed quantity at every row (`-F 1.0` for `mu_s`).
    Same(Fixed),
    /// `mu_s` (or, `reduced`, `mu_s' = mu_s (1 - g)`) as a power law of the
    /// row's wavelength, `value (lambda / lambda0)^exponent` (eq. R3; iad's
    /// `-F 'P lambda0 value exponent'` and `-F 'R ...'`).
    PowerLaw {
        /// The law is for `mu_s'` rather than `mu_s`.
        reduced: bool,
        /// The reference wavelength `lambda0`, nm.
        lambda0_nm: f64,
        /// The coefficient at `lambda0` (1/length).
        value: f64,
        /// The exponent.
        exponent: f64,
    },
}

impl RowFixed {
    /// The one fixed quantity of a reflectance-only fit from its three ways
    /// in (`km fit --fix-mu-s/--fix-mu-a/--semi-infinite`, Python's
    /// `fix_mu_s`, `fix_mu_a`, `semi_infinite`), `None` when none is given.
    ///
    /// # Errors
    /// More than one given: `M_R` determines one unknown.
    pub fn one_of(
        mu_s: Option<RowFixed>,
        mu_a: Option<f64>,
        semi_infinite: bool,
    ) -> Result<Option<RowFixed>, InverseError> {
        let given: Vec<RowFixed> = [
            mu_s,
            mu_a.map(|a| RowFixed::Same(Fixed::MuA(a))),
            semi_infinite.then_some(RowFixed::Same(Fixed::SemiInfinite)),
        ]
        .into_iter()
        .flatten()
        .collect();
        if given.len() > 1 {
            return Err(InverseError::parse(
                None,
                "give one of the fixed quantities (mu_s, mu_a, a semi-infinite sample): M_R \
                 determines one unknown",
            ));
        }
        Ok(given.first().copied())
    }

    /// `mu_s` fixed by a text: a number, or iad's power law `P L0 MU_S0 EXP`
    /// (for `mu_s`) or `R L0 MU_SP0 EXP` (for `mu_s'`), eq. R3 (`km fit
    /// --fix-mu-s`, Python's `fix_mu_s`).
    ///
    /// # Errors
    /// Any other text, a number that is not finite, a law whose `L0` is not
    /// positive or whose value is negative.
    ///
    /// ```
    /// use km_inverse::reflectance::Fixed;
    /// use km_inverse::spectrum::RowFixed;
    /// assert_eq!(RowFixed::parse_mu_s("1.8").unwrap(), RowFixed::Same(Fixed::MuS(1.8)));
    /// assert!(matches!(RowFixed::parse_mu_s("R 500 1 -1.3"), Ok(RowFixed::PowerLaw { reduced: true, .. })));
    /// assert!(RowFixed::parse_mu_s("P 500 1").is_err());
    /// ```
    pub fn parse_mu_s(text: &str) -> Result<RowFixed, String> {
        let words: Vec<&str> = text.split_whitespace().collect();
        let num = |w: &str| {
            w.parse::<f64>().ok().filter(|x| x.is_finite()).ok_or_else(|| {
                format!(
                    "'{w}' is not a finite number (give MU_S, or 'P L0 MU_S0 EXP' / 'R L0 MU_SP0 EXP')"
                )
            })
        };
        match words.as_slice() {
            [v] => Ok(RowFixed::Same(Fixed::MuS(num(v)?))),
            [kind, l0, v, e]
                if kind.eq_ignore_ascii_case("p") || kind.eq_ignore_ascii_case("r") =>
            {
                let law = RowFixed::PowerLaw {
                    reduced: kind.eq_ignore_ascii_case("r"),
                    lambda0_nm: num(l0)?,
                    value: num(v)?,
                    exponent: num(e)?,
                };
                // The law's own numbers, checked before any file is read.
                law.at(Some(num(l0)?), 0.0).map_err(|e| e.to_string())?;
                Ok(law)
            }
            _ => Err(format!(
                "'{text}': give MU_S, or a power law 'P L0 MU_S0 EXP' (mu_s) or 'R L0 MU_SP0 EXP' (mu_s')"
            )),
        }
    }

    /// The fixed quantity at a row of wavelength `wavelength_nm` for
    /// anisotropy `g`.
    ///
    /// # Errors
    /// A power law at a row without a wavelength, or for `mu_s'` with
    /// `g = 1`; a law whose numbers are not finite or whose `lambda0` or
    /// value is not positive.
    ///
    /// ```
    /// use km_inverse::reflectance::Fixed;
    /// use km_inverse::spectrum::RowFixed;
    /// let law = RowFixed::PowerLaw { reduced: true, lambda0_nm: 500.0, value: 1.0, exponent: -1.3 };
    /// // mu_s' = 1 at 500 nm, so mu_s = 1 / (1 - 0.8) = 5 for g = 0.8.
    /// assert_eq!(law.at(Some(500.0), 0.8).unwrap(), Fixed::MuS(5.000000000000001));
    /// assert!(law.at(None, 0.0).is_err());
    /// ```
    pub fn at(self, wavelength_nm: Option<f64>, g: f64) -> Result<Fixed, InverseError> {
        let (reduced, lambda0_nm, value, exponent) = match self {
            RowFixed::Same(f) => return Ok(f),
            RowFixed::PowerLaw { reduced, lambda0_nm, value, exponent } => {
                (reduced, lambda0_nm, value, exponent)
            }
        };
        let bad = |name: &str, v: f64, why: &str| Err(InverseError::invalid(name, v, why));
        if !(lambda0_nm.is_finite() && lambda0_nm > 0.0) {
            return bad("lambda0", lambda0_nm, "the power law's wavelength must be finite and > 0");
        }
        if !(value.is_finite() && value >= 0.0) {
            return bad("mu_s", value, "the power law's value must be finite and >= 0");
        }
        if !exponent.is_finite() {
            return bad("exponent", exponent, "the power law's exponent must be finite");
        }
        let Some(w) = wavelength_nm else {
            return Err(InverseError::parse(
                None,
                "a power law for mu_s needs the rows' wavelengths (an .rxt column L)",
            ));
        };
        let law = value * (w / lambda0_nm).powf(exponent);
        if !reduced {
            return Ok(Fixed::MuS(law));
        }
        if g >= 1.0 || g.is_nan() {
            return bad("g", g, "mu_s' = mu_s (1 - g) fixes no mu_s at g = 1");
        }
        Ok(Fixed::MuS(law / (1.0 - g)))
    }
}

/// What the caller sets over every row of a file (`km fit`'s flags).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RowOverrides {
    /// Fraction of the specular reflection in `M_R` (replaces the file's).
    pub specular_in_m_r: Option<f64>,
    /// Fraction of the unscattered beam in `M_T` (replaces the file's).
    pub unscattered_in_m_t: Option<f64>,
    /// Standard uncertainty of `M_R` for rows that give none.
    pub sigma_r: Option<f64>,
    /// Standard uncertainty of `M_T` for rows that give none.
    pub sigma_t: Option<f64>,
    /// Standard uncertainty of `M_U` for rows that give none.
    pub sigma_u: Option<f64>,
    /// The fixed quantity of the rows that give `M_R` alone (required for them).
    pub fixed: Option<RowFixed>,
}

impl RowOverrides {
    /// The overrides of a caller's options: the fractions of the specular
    /// reflection in `M_R` and of the unscattered beam in `M_T` override the
    /// file's when they differ from 1 (their defaults), the uncertainties
    /// `[sigma_r, sigma_t, sigma_u]` stand where a row gives none.
    pub fn from_options(
        specular_in_m_r: f64,
        unscattered_in_m_t: f64,
        sigmas: [Option<f64>; 3],
        fixed: Option<RowFixed>,
    ) -> RowOverrides {
        let [sigma_r, sigma_t, sigma_u] = sigmas;
        RowOverrides {
            specular_in_m_r: (specular_in_m_r != 1.0).then_some(specular_in_m_r),
            unscattered_in_m_t: (unscattered_in_m_t != 1.0).then_some(unscattered_in_m_t),
            sigma_r,
            sigma_t,
            sigma_u,
            fixed,
        }
    }
}

/// Refuse a fixed quantity for rows that all give `M_T` too (both unknowns
/// are fitted there); in a file mixing both kinds it applies to the rows
/// that give `M_R` alone.
///
/// # Errors
/// `fixed` given and no row with `M_R` alone.
pub fn check_fixed(rows: &[Row], fixed: Option<RowFixed>) -> Result<(), InverseError> {
    if fixed.is_some() && !rows.iter().any(|r| r.reflectance_only) {
        return Err(InverseError::parse(
            None,
            "a fixed quantity (mu_s, mu_a, a semi-infinite sample) applies to the rows that give \
             M_R alone; every row gives M_T too (both mu_a and mu_s are fitted)",
        ));
    }
    Ok(())
}

/// The fit of one row.
#[derive(Debug, Clone, PartialEq)]
pub struct RowFit {
    /// The row's wavelength in nm, if the file gives one.
    pub wavelength_nm: Option<f64>,
    /// The answer, or why the row could not be fitted.
    pub result: Result<FitResult, InverseError>,
}

/// Fit every row: the row's set-up with `over`'s fractions, the row's
/// uncertainties or else `over`'s, the row's `g` or else `opts.g`.
///
/// ```
/// use km_inverse::rxt::parse_rxt;
/// use km_inverse::slab::FitOptions;
/// use km_inverse::spectrum::{RowOverrides, fit_rows};
/// let rows = parse_rxt("IAD1 1.4 1.5 1 1 5 1 0 200 25 12 1 .96 200 25 12 1 .96 2\n\
///                       0.2352 0.5152\n0.2 0.0").unwrap();
/// let fits = fit_rows(&rows, &RowOverrides::default(), &FitOptions::default());
/// assert!(fits[0].result.is_ok() && fits[1].result.is_err()); // M_T = 0: opaque
/// ```
pub fn fit_rows(rows: &[Row], over: &RowOverrides, opts: &FitOptions) -> Vec<RowFit> {
    rows.iter()
        .map(|row| {
            let mut setup = row.setup;
            if let Some(c) = over.specular_in_m_r {
                setup.specular_in_m_r = c;
            }
            if let Some(c) = over.unscattered_in_m_t {
                setup.unscattered_in_m_t = c;
            }
            let mut meas = row.measurement;
            meas.sigma_r = meas.sigma_r.or(over.sigma_r);
            meas.sigma_t = meas.sigma_t.or(over.sigma_t);
            meas.sigma_u = meas.sigma_u.or(over.sigma_u);
            let o = FitOptions { g: row.g.or(opts.g), ..*opts };
            let result = if row.reflectance_only {
                // Eq. R1 with the fixed quantity at the row (R3); g as for
                // M_R and M_T without M_U: the row's, the caller's, else 0.
                let g = o.g.unwrap_or(0.0);
                match over.fixed {
                    Some(f) => f.at(row.wavelength_nm, g).and_then(|fx| {
                        fit_reflectance(&setup, meas.m_r, meas.sigma_r, fx, g, o.streams)
                    }),
                    None => Err(InverseError::parse(
                        None,
                        "the row gives M_R alone: a reflectance-only fit needs a fixed quantity \
                         (km fit --fix-mu-s, --fix-mu-a or --semi-infinite; iad's -F)",
                    )),
                }
            } else {
                fit(&setup, &meas, &o)
            };
            let result = result.map(|mut r| {
                r.notes.extend(row.notes.iter().cloned());
                r
            });
            RowFit { wavelength_nm: row.wavelength_nm, result }
        })
        .collect()
}

/// The JSON list of the `km fit FILE --json` contract: each row's
/// [`FitResult::to_json`] with `wavelength_nm`, or
/// `{"wavelength_nm", "status": "invalid", "error"}` for a row not fitted.
pub fn rows_json(fits: &[RowFit]) -> Value {
    Value::Array(
        fits.iter()
            .map(|f| match &f.result {
                Ok(r) => {
                    let mut v = r.to_json();
                    v["wavelength_nm"] = json!(f.wavelength_nm);
                    v
                }
                Err(e) => json!({
                    "wavelength_nm": f.wavelength_nm, "status": "invalid", "error": e.to_string()
                }),
            })
            .collect(),
    )
}
