//! A spectrum (or any list of measurements) fitted row by row: the rows of
//! an `.rxt` or CSV file ([`crate::rxt`]) with the caller's overrides, each
//! fitted by [`crate::slab::fit`]; a row that cannot be fitted is reported
//! in its place and the others are fitted (`docs/inverse.md` §6).

use serde_json::{Value, json};

use crate::InverseError;
use crate::rxt::Row;
use crate::slab::{FitOptions, FitResult, fit};

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
            let result = fit(&setup, &meas, &o).map(|mut r| {
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
