//! From a paint engineer's readings to the film's `K` and `S`: the
//! Kubelka–Munk inverse of [`crate::kubelka`] applied to one set of
//! readings, with Saunderson's correction, the uncertainty for a stated
//! reading uncertainty, and the hiding curves of the fitted film
//! (`docs/inverse-km.md`; `km fit --km` prints what this computes).
//!
//! Three kinds of readings ([`Readings`]):
//! * a drawdown over a dark and a light ground (Kubelka 1948, eq. I5–I7);
//! * an opaque film and one over ideal black (`R_inf`, `R_0`; eq. I4);
//! * an opaque film alone (`R_inf`), which gives only `K/S` (eq. I1).
//!
//! With a [`Saunderson`] correction the readings are instrument readings
//! (specular component included) and are first turned into internal
//! reflectances (eq. I8–I9); without it they are internal reflectances.
//!
//! [`DrawdownInputs`] turns a front end's optional inputs into readings and
//! a correction, naming each missing or conflicting input ([`InputError`]).

use serde_json::{Map, Value, json};

use crate::kubelka::{self, Film, KubelkaError, Saunderson, Uncertainty};

mod inputs;
pub use inputs::{DrawdownInputs, Input, InputError};

/// Standard uncertainty assumed for each reading as given (a
/// spectrophotometer's typical repeatability) in [`DrawdownFit::uncertainty`].
pub const READING_U: f64 = 1e-3;

/// The readings of one film (reflectances as read; thickness in any unit,
/// `K` and `S` come out in its inverse).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Readings {
    /// The film over a dark ground (`r_black`, ground `g_black`) and over a
    /// light ground (`r_white`, ground `g_white`), of thickness `thickness`.
    BlackWhite {
        /// Reading over the dark ground.
        r_black: f64,
        /// Reflectance of the dark ground.
        g_black: f64,
        /// Reading over the light ground.
        r_white: f64,
        /// Reflectance of the light ground.
        g_white: f64,
        /// Film thickness.
        thickness: f64,
    },
    /// An opaque film (`r_inf`) and the film over ideal black (`r_zero`).
    RInfRZero {
        /// Reading of the opaque film.
        r_inf: f64,
        /// Reading over ideal black.
        r_zero: f64,
        /// Film thickness.
        thickness: f64,
    },
    /// An opaque film alone.
    RInf {
        /// Reading of the opaque film.
        r_inf: f64,
    },
}

impl Readings {
    /// The mode's name in the JSON output (`black_white`, `r_inf_r_zero`, `r_inf`).
    pub fn mode(&self) -> &'static str {
        match self {
            Readings::BlackWhite { .. } => "black_white",
            Readings::RInfRZero { .. } => "r_inf_r_zero",
            Readings::RInf { .. } => "r_inf",
        }
    }

    /// The readings as given, by name (the JSON `inputs`).
    pub fn inputs(&self) -> Vec<(&'static str, f64)> {
        match *self {
            Readings::BlackWhite { r_black, g_black, r_white, g_white, thickness } => vec![
                ("r_black", r_black),
                ("r_white", r_white),
                ("r_black_ground", g_black),
                ("r_white_ground", g_white),
                ("thickness", thickness),
            ],
            Readings::RInfRZero { r_inf, r_zero, thickness } => {
                vec![("r_inf", r_inf), ("r_zero", r_zero), ("thickness", thickness)]
            }
            Readings::RInf { r_inf } => vec![("r_inf", r_inf)],
        }
    }

    /// The reflectance readings (those Saunderson's correction applies to), by name.
    fn reflectances(&self) -> Vec<(&'static str, f64)> {
        match *self {
            Readings::BlackWhite { r_black, r_white, .. } => {
                vec![("r_black", r_black), ("r_white", r_white)]
            }
            Readings::RInfRZero { r_inf, r_zero, .. } => vec![("r_inf", r_inf), ("r_zero", r_zero)],
            Readings::RInf { r_inf } => vec![("r_inf", r_inf)],
        }
    }
}

/// The answer of [`fit_drawdown`].
#[derive(Debug, Clone, PartialEq)]
pub struct DrawdownFit {
    /// The readings fitted.
    pub readings: Readings,
    /// Saunderson's correction applied to them, if any.
    pub saunderson: Option<Saunderson>,
    /// The internal reflectances (after the correction), by reading name.
    pub internal: Vec<(&'static str, f64)>,
    /// The film (`K`, `S`, ...); `None` for `R_inf` alone.
    pub film: Option<Film>,
    /// `K/S` (eq. I1).
    pub k_over_s: f64,
    /// Internal reflectance of the opaque film.
    pub r_inf: f64,
    /// What an instrument would read on the opaque film (with a correction).
    pub r_inf_measured: Option<f64>,
    /// Standard uncertainties of `K`, `S` for readings each uncertain by
    /// [`READING_U`] (first-order propagation through the correction);
    /// `None` when not computable or for `R_inf` alone.
    pub uncertainty: Option<Uncertainty>,
}

/// `d(internal)/d(reading)` of Saunderson's correction (1 without it), by a
/// central difference of step 1e-7 (one-sided at the ends of `[0, 1]`);
/// `NaN` when a step leaves the correction's domain.
///
/// # Reference
/// Saunderson 1942 (eq. I9 of `docs/inverse-km.md`), differentiated numerically.
pub fn internal_slope(corr: Option<&Saunderson>, r: f64) -> f64 {
    let Some(c) = corr else { return 1.0 };
    let (lo, hi) = ((r - 1e-7).max(0.0), (r + 1e-7).min(1.0));
    match (c.internal_from_measured(lo), c.internal_from_measured(hi)) {
        (Ok(a), Ok(b)) => (b - a) / (hi - lo),
        _ => f64::NAN,
    }
}

/// `K` and `S` (or `K/S` alone) of a film from its readings: Saunderson's
/// correction to internal reflectances (eq. I8–I9) when `corr` is given,
/// then Kubelka's closed forms ([`kubelka::from_black_white`] eq. I5–I7,
/// [`kubelka::from_r_inf_r0`] eq. I4, [`kubelka::k_over_s`] eq. I1), and the
/// uncertainty for readings uncertain by [`READING_U`].
///
/// # Reference
/// Kubelka 1948 (closed forms); Saunderson 1942 (surface correction).
///
/// # Errors
/// [`KubelkaError`] naming the reading (as in [`Readings::inputs`]): a
/// reading the correction cannot invert, readings no film can produce
/// (`Infeasible`), values out of range (`Invalid`).
///
/// ```
/// use km_inverse::drawdown::{Readings, fit_drawdown};
/// use km_inverse::kubelka::reflectance_over_ground;
/// let (k, s, x) = (0.3, 2.0, 0.5);
/// let r = |g: f64| reflectance_over_ground(k, s, x, g).unwrap();
/// let readings = Readings::BlackWhite {
///     r_black: r(0.0), g_black: 0.0, r_white: r(0.8), g_white: 0.8, thickness: x,
/// };
/// let f = fit_drawdown(readings, None).unwrap().film.unwrap();
/// assert!((f.k - k).abs() < 1e-12 && (f.s - s).abs() < 1e-12);
/// ```
pub fn fit_drawdown(
    readings: Readings,
    corr: Option<Saunderson>,
) -> Result<DrawdownFit, KubelkaError> {
    // Measured -> internal reflectance, naming the reading on failure.
    let mut internal = Vec::new();
    for (name, r) in readings.reflectances() {
        let ri = match &corr {
            None => r,
            Some(c) => c.internal_from_measured(r).map_err(|e| rename(e, name))?,
        };
        internal.push((name, ri));
    }
    let u_of = |r: f64| READING_U * internal_slope(corr.as_ref(), r);
    let (film, uncertainty) = match readings {
        Readings::BlackWhite { r_black, g_black, r_white, g_white, thickness } => {
            let (rb, rw) = (internal[0].1, internal[1].1);
            let film = kubelka::from_black_white(rb, g_black, rw, g_white, thickness)?;
            let (ub, uw) = (u_of(r_black), u_of(r_white));
            let u = kubelka::black_white_uncertainty(rb, g_black, rw, g_white, thickness, ub, uw);
            (Some(film), u.ok())
        }
        Readings::RInfRZero { r_inf, r_zero, thickness } => {
            let (ri, r0) = (internal[0].1, internal[1].1);
            let film = kubelka::from_r_inf_r0(ri, r0, thickness)?;
            let u = kubelka::r_inf_r0_uncertainty(ri, r0, thickness, u_of(r_inf), u_of(r_zero));
            (Some(film), u.ok())
        }
        Readings::RInf { .. } => (None, None),
    };
    let (k_over_s, r_inf) = match &film {
        Some(f) => (f.k_over_s, f.r_inf),
        None => (kubelka::k_over_s(internal[0].1)?, internal[0].1),
    };
    let r_inf_measured = match &corr {
        Some(c) => Some(c.measured_from_internal(r_inf)?),
        None => None,
    };
    let uncertainty = uncertainty.filter(|u| u.k.is_finite() && u.s.is_finite());
    Ok(DrawdownFit {
        readings,
        saunderson: corr,
        internal,
        film,
        k_over_s,
        r_inf,
        r_inf_measured,
        uncertainty,
    })
}

/// The same error, naming the reading `name` instead of the correction's own
/// variable (so "infeasible measured reflectance" reads "infeasible r_inf").
fn rename(e: KubelkaError, name: &str) -> KubelkaError {
    match e {
        KubelkaError::Invalid { value, reason, .. } => {
            KubelkaError::Invalid { name: name.into(), value, reason }
        }
        KubelkaError::Infeasible { value, reason, .. } => {
            KubelkaError::Infeasible { name: name.into(), value, reason }
        }
        other => other,
    }
}

impl DrawdownFit {
    /// The JSON object of the `km fit --km --json` contract
    /// (`docs/inverse-km.md`): `K`, `S` (contract), `K_over_S`, `S_X`,
    /// `R_inf`, `R_inf_measured` (with a correction), `R_0`, `T`,
    /// `thickness`, `inputs`, `internal`, `saunderson` (`k1`, `k2`, or
    /// null), `mode`, `uncertainty` (`K`, `S`, `correlation`, `u_reading`,
    /// or null). `K`, `S`, `S_X`, `R_0`, `T`, `thickness` are null for
    /// `R_inf` alone.
    pub fn to_json(&self) -> Value {
        let mut out = Map::new();
        let obj = |v: &[(&str, f64)]| -> Value {
            Value::Object(v.iter().map(|(k, x)| (k.to_string(), json!(x))).collect())
        };
        out.insert("mode".into(), json!(self.readings.mode()));
        out.insert("inputs".into(), obj(&self.readings.inputs()));
        out.insert("internal".into(), obj(&self.internal));
        out.insert("K_over_S".into(), json!(self.k_over_s));
        out.insert("R_inf".into(), json!(self.r_inf));
        let film_keys = ["K", "S", "S_X", "R_0", "T", "thickness"];
        match &self.film {
            Some(f) => {
                let vals = [f.k, f.s, f.sx, f.r0, f.t, f.sx / f.s];
                for (k, v) in film_keys.iter().zip(vals) {
                    out.insert((*k).into(), json!(v));
                }
            }
            None => {
                for k in film_keys {
                    out.insert(k.into(), Value::Null);
                }
            }
        }
        if let Some(m) = self.r_inf_measured {
            out.insert("R_inf_measured".into(), json!(m));
        }
        out.insert(
            "uncertainty".into(),
            match &self.uncertainty {
                Some(u) => json!({
                    "K": u.k, "S": u.s, "correlation": u.correlation, "u_reading": READING_U
                }),
                None => Value::Null,
            },
        );
        out.insert(
            "saunderson".into(),
            self.saunderson.map(|c| json!({ "k1": c.k1, "k2": c.k2 })).unwrap_or(Value::Null),
        );
        Value::Object(out)
    }
}

/// One hiding curve of a fitted film: its internal reflectance over a
/// ground against film thickness, and the reading at the measured thickness.
#[derive(Debug, Clone, PartialEq)]
pub struct HidingCurve {
    /// What the ground is (`over dark ground`, `over light ground`, `over ideal black`).
    pub label: String,
    /// Reflectance of the ground.
    pub ground: f64,
    /// `(thickness, internal reflectance)` from 0 to the plot's end.
    pub points: Vec<(f64, f64)>,
    /// The (internal) reading at the measured thickness, if any.
    pub reading: Option<f64>,
}

/// The hiding curves of a fitted film (`points + 1` thicknesses each):
/// `R(X)` over each ground (Kubelka 1948 eq. 11 with the fitted `K`, `S`,
/// [`kubelka::reflectance_over_ground`]). The thickness axis runs to 1.2
/// times the hiding thickness (where the film over black reaches
/// `R_0 = 0.98 R_inf`, eq. I4), kept within 2 to 20 times the measured
/// thickness. Returns the curves and the measured thickness; `None` when the
/// fit has no `K`, `S` (`R_inf` alone).
///
/// # Errors
/// Those of [`kubelka::reflectance_over_ground`].
pub fn hiding_curves(
    fit: &DrawdownFit,
    points: usize,
) -> Result<Option<(Vec<HidingCurve>, f64)>, KubelkaError> {
    let Some(f) = &fit.film else { return Ok(None) };
    let (k, s, x) = (f.k, f.s, f.sx / f.s);
    let hiding =
        kubelka::from_r_inf_r0(f.r_inf, 0.98 * f.r_inf, 1.0).map(|h| h.sx / s).unwrap_or(x);
    let x_max = (1.2 * hiding).clamp(2.0 * x, 20.0 * x);
    let reading = |name: &str| fit.internal.iter().find(|(n, _)| *n == name).map(|p| p.1);
    let grounds: Vec<(&str, f64, Option<f64>)> = match fit.readings {
        Readings::BlackWhite { g_black, g_white, .. } => vec![
            ("over dark ground", g_black, reading("r_black")),
            ("over light ground", g_white, reading("r_white")),
        ],
        _ => vec![("over ideal black", 0.0, reading("r_zero"))],
    };
    let mut curves = Vec::with_capacity(grounds.len());
    for (label, g, reading) in grounds {
        let pts = (0..=points)
            .map(|j| {
                let t = x_max * j as f64 / points.max(1) as f64;
                kubelka::reflectance_over_ground(k, s, t, g).map(|r| (t, r))
            })
            .collect::<Result<Vec<_>, _>>()?;
        curves.push(HidingCurve { label: label.into(), ground: g, points: pts, reading });
    }
    Ok(Some((curves, x)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kubelka::{Specular, reflectance_over_ground};

    /// Readings made by the forward model (two-flux adding over each
    /// ground) and passed through Saunderson's surface give back `K`, `S`
    /// (1e-12: the library's round trip, tests/kubelka.rs), and the
    /// uncertainty goes through the correction's slope
    /// `dR/dR_m = (1-k1)(1-k2) / ((1-k1)(1-k2) + k2 y)^2` (eq. I9 differentiated).
    #[test]
    fn readings_give_the_films_k_and_s_through_saunderson() {
        let (k, s, x, n) = (0.3, 2.0, 0.5, 1.5);
        let c = Saunderson::fresnel(n, Specular::Included).unwrap();
        let read = |g: f64| c.measured_from_internal(reflectance_over_ground(k, s, x, g).unwrap());
        let (rb, rw) = (read(0.02).unwrap(), read(0.85).unwrap());
        let readings = Readings::BlackWhite {
            r_black: rb,
            g_black: 0.02,
            r_white: rw,
            g_white: 0.85,
            thickness: x,
        };
        let fit = fit_drawdown(readings, Some(c)).unwrap();
        let f = fit.film.unwrap();
        assert!((f.k - k).abs() < 1e-12 && (f.s - s).abs() < 1e-12, "{f:?}");
        let slope = |rm: f64| {
            let (a, y) = ((1.0 - c.k1) * (1.0 - c.k2), rm - c.k1);
            a / (a + c.k2 * y).powi(2)
        };
        let lib = kubelka::black_white_uncertainty(
            c.internal_from_measured(rb).unwrap(),
            0.02,
            c.internal_from_measured(rw).unwrap(),
            0.85,
            x,
            1e-3 * slope(rb),
            1e-3 * slope(rw),
        )
        .unwrap();
        let u = fit.uncertainty.unwrap();
        // Central differences of step 1e-7 on a smooth function: ~1e-7 relative.
        assert!((u.k / lib.k - 1.0).abs() < 1e-6 && (u.s / lib.s - 1.0).abs() < 1e-6);
        // The hiding curves pass through the readings at the measured thickness.
        let (curves, xm) = hiding_curves(&fit, 200).unwrap().unwrap();
        assert_eq!(xm, x);
        for cv in &curves {
            let at = reflectance_over_ground(k, s, x, cv.ground).unwrap();
            assert!((cv.reading.unwrap() - at).abs() < 1e-12, "{}", cv.label);
            assert_eq!(cv.points.len(), 201);
        }
    }

    #[test]
    fn r_inf_alone_gives_k_over_s_only() {
        let fit = fit_drawdown(Readings::RInf { r_inf: 0.5 }, None).unwrap();
        assert!((fit.k_over_s - 0.25).abs() < 1e-15);
        let v = fit.to_json();
        assert!(v["K"].is_null() && v["S"].is_null() && v["uncertainty"].is_null());
        assert!(hiding_curves(&fit, 10).unwrap().is_none());
        // A reading below the surface reflection names the reading.
        let c = Saunderson::fresnel(1.5, Specular::Included).unwrap();
        let e = fit_drawdown(Readings::RInf { r_inf: 0.01 }, Some(c)).unwrap_err();
        assert!(e.to_string().contains("r_inf = 0.01"), "{e}");
    }
}
