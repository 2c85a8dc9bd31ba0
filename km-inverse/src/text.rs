//! The fits as text for people: the tables `km fit` prints (the JSON of
//! the contracts is [`crate::slab::FitResult::to_json`],
//! [`crate::spectrum::rows_json`] and [`crate::drawdown::DrawdownFit::to_json`]).

use crate::drawdown::{DrawdownFit, READING_U};
use crate::kubelka::Film;
use crate::slab::DEFAULT_SIGMA;
use crate::spectrum::RowFit;

/// The slab fits as a table, one row per fitted measurement (its wavelength,
/// or `-`; `albedo`, `tau`, `g`, `mu_a`, `mu_s'`, `u(mu_a)`, `u(mu_s')`, the
/// model's `M_R` and `M_T` at the answer, the status, and its notes below
/// the row), a line giving the units, a line saying whether the
/// measurement uncertainties behind `u(...)` were given or the default
/// [`DEFAULT_SIGMA`] was assumed, then one line per row that could not be
/// fitted, with its reason.
///
/// ```
/// use km_inverse::spectrum::RowFit;
/// use km_inverse::InverseError;
/// let e = InverseError::Forward("no answer".into());
/// let bad = RowFit { wavelength_nm: Some(500.0), result: Err(e) };
/// let t = km_inverse::text::fits_table(&[bad]);
/// assert!(t.starts_with("   lambda     albedo") && t.contains("    500.0 invalid: "));
/// assert!(t.contains("u(mu_s')") && t.contains("1/length"));
/// ```
pub fn fits_table(fits: &[RowFit]) -> String {
    let mut s = format!(
        "{:>9} {:>10} {:>11} {:>7} {:>11} {:>11} {:>11} {:>11} {:>9} {:>9} {}\n",
        "lambda",
        "albedo",
        "tau",
        "g",
        "mu_a",
        "mu_s'",
        "u(mu_a)",
        "u(mu_s')",
        "M_R fit",
        "M_T fit",
        "status"
    );
    let lambda = |f: &RowFit| f.wavelength_nm.map_or("-".to_string(), |w| format!("{w:.1}"));
    let ok: Vec<_> = fits.iter().filter_map(|f| f.result.as_ref().ok()).collect();
    // Notes every row shares (a file's header) are printed once, after the rows.
    let common: Vec<&String> = match ok.as_slice() {
        [first, _, ..] => {
            first.notes.iter().filter(|n| ok.iter().all(|r| r.notes.contains(n))).collect()
        }
        _ => Vec::new(),
    };
    for f in fits {
        let Ok(r) = &f.result else { continue };
        let flag = if r.uncertainty.ill_conditioned { " (ill-conditioned)" } else { "" };
        s += &format!(
            "{:>9} {:>10.6} {:>11.5e} {:>7.4} {:>11.5e} {:>11.5e} {:>11.3e} {:>11.3e} {:>9.5} \
             {:>9.5} {:?}{flag}\n",
            lambda(f),
            r.albedo,
            r.tau,
            r.g,
            r.mu_a,
            r.mu_s_prime,
            r.uncertainty.mu_a,
            r.uncertainty.mu_s_prime,
            r.fitted[0],
            r.fitted[1],
            r.status
        );
        for n in r.notes.iter().filter(|n| !common.contains(n)) {
            s += &format!("          note: {n}\n");
        }
    }
    for n in common {
        s += &format!("note (every row): {n}\n");
    }
    s += "units: lambda nm; albedo, tau, g, M_R, M_T dimensionless; mu_a, mu_s' and their \
          u(...) in 1/length, the inverse of the thickness's unit\n";
    let given = ok.iter().filter(|r| r.uncertainty.sigma_given).count();
    if !ok.is_empty() {
        s += &match given {
            g if g == ok.len() => "u(...): from the given measurement uncertainties\n".to_string(),
            0 => format!(
                "u(...): from the default measurement uncertainty {DEFAULT_SIGMA:e} (none was \
                 given: --sigma-r, --sigma-t, --sigma-u or the file's columns)\n"
            ),
            g => format!(
                "u(...): {g} of {} rows from given measurement uncertainties, the others from \
                 the default {DEFAULT_SIGMA:e}\n",
                ok.len()
            ),
        };
    }
    for f in fits {
        if let Err(e) = &f.result {
            s += &format!("{:>9} invalid: {e}\n", lambda(f));
        }
    }
    s
}

/// The Kubelka–Munk fit of a film as a short report: the mode, `K`, `S`,
/// `K/S`, `S X`, `R_inf` (internal, and as measured with a correction),
/// `R_0`, `T`; the uncertainties of `K`, `S` for readings uncertain by
/// [`READING_U`]; Saunderson's `k1`, `k2` and the internal reflectances.
/// Values that are not finite are left out; `K` and `S`, when the readings
/// cannot give them (`R_inf` alone), read `(needs {needs})`, where `needs`
/// is how the caller asks for what they need.
///
/// ```
/// use km_inverse::drawdown::{Readings, fit_drawdown};
/// let fit = fit_drawdown(Readings::RInf { r_inf: 0.6 }, None).unwrap();
/// let t = km_inverse::text::drawdown_report(&fit, "r_zero and thickness");
/// assert!(t.contains("(needs r_zero and thickness)") && t.contains("K/S"));
/// ```
pub fn drawdown_report(fit: &DrawdownFit, needs: &str) -> String {
    let finite = |x: f64| x.is_finite().then_some(x);
    let film = |get: fn(&Film) -> f64| fit.film.as_ref().map(get).and_then(finite);
    let rows: [(&str, Option<f64>, bool); 8] = [
        ("absorption K (1/length)", film(|f| f.k), true),
        ("scattering S (1/length)", film(|f| f.s), true),
        ("K/S", finite(fit.k_over_s), false),
        ("scattering power S X", film(|f| f.sx), false),
        ("R_inf (internal, opaque)", finite(fit.r_inf), false),
        ("R_inf (as measured)", fit.r_inf_measured.and_then(finite), false),
        ("R_0 (internal, over black)", film(|f| f.r0), false),
        ("T (diffuse transmittance)", film(|f| f.t), false),
    ];
    let mut out = format!("Kubelka–Munk inverse ({})\n", fit.readings.mode());
    for (label, value, needed) in rows {
        match value {
            Some(x) => out += &format!("  {label:<30} {x:.6}\n"),
            None if needed => out += &format!("  {label:<30} (needs {needs})\n"),
            None => {}
        }
    }
    let or_nan = |x: f64| finite(x).unwrap_or(f64::NAN);
    if let Some(u) = &fit.uncertainty {
        out += &format!(
            "  u(K), u(S) for readings +-{READING_U}: {:.3e}, {:.3e} (correlation {:.3})\n",
            or_nan(u.k),
            or_nan(u.s),
            or_nan(u.correlation)
        );
    }
    if let Some(c) = &fit.saunderson {
        out += &format!("  Saunderson k1 = {:.6}, k2 = {:.6}\n", or_nan(c.k1), or_nan(c.k2));
        for (name, x) in &fit.internal {
            out += &format!("  internal {name:<21} {:.6}\n", or_nan(*x));
        }
    }
    out
}
