//! `km fit --km`: the paint engineer's Kubelka–Munk inverse from the command line.
//!
//! Three ways in (docs/inverse-km.md, docs/cli.md):
//! * `--r-black X --r-white Y --r-white-ground W [--r-black-ground B] --thickness D`:
//!   a drawdown over a dark and a light ground (Kubelka 1948, eq. I5–I7);
//! * `--r-inf X --r-zero Y --thickness D`: an opaque film and one over ideal black (eq. I4);
//! * `--r-inf X` alone: an opaque film, which gives only `K/S` (eq. I1).
//!
//! With `--n N` the readings are instrument readings (specular component
//! included) and Saunderson's correction turns them into internal
//! reflectances first: `k1 = ((n - 1)/(n + 1))^2`, `k2` from `--k2` or, by
//! default, the hemispherical Fresnel reflectance from inside (eq. I8–I9).
//! Without `--n` the readings are taken as internal reflectances.
//!
//! JSON keys (contract: `K`, `S`): `K`, `S`, `K_over_S`, `S_X`, `R_inf`,
//! `R_0`, `T`, `thickness`, `inputs`, `internal` (the reflectances after the
//! Saunderson correction), `saunderson` (`k1`, `k2`, or null), `mode`, and
//! `uncertainty` (`K`, `S`, `correlation`, `u_reading`): the standard
//! uncertainties of `K` and `S` if each reading as given carries a standard
//! uncertainty of `u_reading` = 0.001 (first-order propagation, through
//! Saunderson's correction when `--n` is given; null when not computable).
//! `K`, `S` (and `S_X`, `R_0`, `T`, `thickness`) are null when only `R_inf`
//! is given.
//!
//! [`write_plot`] (for `--plot DIR`) draws the fitted film's hiding curves:
//! its internal reflectance over the grounds against thickness, the
//! readings, and `R_inf` (`DIR/km-fit-km.svg` and `.png`).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use km_bench::chart::{LineChart, Mark, Series, write_chart};
use km_inverse::kubelka::{self, Film, Saunderson, Specular, Uncertainty};
use serde_json::{Map, Value, json};

/// The readings and settings of `km fit --km` (all optional; which are
/// required depends on the mode, see the module documentation).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct KmFitInputs {
    /// Reflectance of the film over the dark ground.
    pub r_black: Option<f64>,
    /// Reflectance of the film over the light ground.
    pub r_white: Option<f64>,
    /// Reflectance of the light ground itself.
    pub r_white_ground: Option<f64>,
    /// Reflectance of the dark ground itself (default 0: ideal black).
    pub r_black_ground: Option<f64>,
    /// Reflectance of the opaque film.
    pub r_inf: Option<f64>,
    /// Reflectance of the film over an ideal black ground.
    pub r_zero: Option<f64>,
    /// Film thickness (any unit; K, S come out in its inverse).
    pub thickness: Option<f64>,
    /// Saunderson's internal reflectance k2 (needs `n`).
    pub k2: Option<f64>,
    /// Refractive index of the binder: readings are instrument readings and
    /// get Saunderson's correction.
    pub n: Option<f64>,
}

/// Which inverse the inputs ask for.
enum Mode {
    BlackWhite { r_black: f64, g_black: f64, r_white: f64, g_white: f64, thickness: f64 },
    RInfRZero { r_inf: f64, r_zero: f64, thickness: f64 },
    RInf { r_inf: f64 },
}

fn mode(i: &KmFitInputs) -> Result<Mode> {
    let two_grounds = i.r_black.is_some() || i.r_white.is_some();
    let opaque = i.r_inf.is_some() || i.r_zero.is_some();
    if two_grounds && opaque {
        bail!(
            "give either --r-black/--r-white (film over two grounds) or --r-inf [--r-zero], \
             not both"
        );
    }
    if two_grounds {
        let r_black =
            i.r_black.context("--r-white needs --r-black (the film over the dark ground)")?;
        let r_white =
            i.r_white.context("--r-black needs --r-white (the film over the light ground)")?;
        let g_white = i
            .r_white_ground
            .context("--r-white-ground (the reflectance of the light ground) is required")?;
        let thickness = i.thickness.context("--thickness (the film thickness) is required")?;
        let g_black = i.r_black_ground.unwrap_or(0.0);
        return Ok(Mode::BlackWhite { r_black, g_black, r_white, g_white, thickness });
    }
    if i.r_white_ground.is_some() || i.r_black_ground.is_some() {
        bail!("--r-white-ground/--r-black-ground belong to --r-black/--r-white");
    }
    match (i.r_inf, i.r_zero) {
        (Some(r_inf), Some(r_zero)) => {
            let thickness = i.thickness.context("--thickness (the film thickness) is required")?;
            Ok(Mode::RInfRZero { r_inf, r_zero, thickness })
        }
        (None, Some(_)) => bail!("--r-zero needs --r-inf (the reflectance of the opaque film)"),
        (Some(r_inf), None) => {
            if i.thickness.is_some() {
                bail!("--thickness needs --r-zero: an opaque film alone gives only K/S");
            }
            Ok(Mode::RInf { r_inf })
        }
        (None, None) => bail!(
            "no readings: give --r-black, --r-white, --r-white-ground and --thickness, or \
             --r-inf [--r-zero --thickness]"
        ),
    }
}

/// Saunderson's correction from `--n` and `--k2`, if asked for.
fn saunderson(i: &KmFitInputs) -> Result<Option<Saunderson>> {
    Ok(match (i.n, i.k2) {
        (None, None) => None,
        (None, Some(_)) => bail!("--k2 needs --n (k1 is the Fresnel reflectance of the binder)"),
        (Some(n), None) => Some(Saunderson::fresnel(n, Specular::Included)?),
        (Some(n), Some(k2)) => Some(Saunderson::from_index(n, k2, Specular::Included)?),
    })
}

/// Standard uncertainty assumed for each reading as given (a spectrophotometer's
/// typical repeatability) in the `uncertainty` key.
const READING_U: f64 = 1e-3;

/// `d(internal)/d(reading)` of Saunderson's correction (1 without it), by a
/// central difference of step 1e-7 (one-sided at the ends of `[0, 1]`);
/// `NaN` when a step leaves the correction's domain.
fn internal_slope(corr: &Option<Saunderson>, r: f64) -> f64 {
    let Some(c) = corr else { return 1.0 };
    let (lo, hi) = ((r - 1e-7).max(0.0), (r + 1e-7).min(1.0));
    match (c.internal_from_measured(lo), c.internal_from_measured(hi)) {
        (Ok(a), Ok(b)) => (b - a) / (hi - lo),
        _ => f64::NAN,
    }
}

fn uncertainty_json(u: Option<Uncertainty>) -> Value {
    match u {
        Some(u) if u.k.is_finite() && u.s.is_finite() => json!({
            "K": u.k, "S": u.s, "correlation": u.correlation, "u_reading": READING_U
        }),
        _ => Value::Null,
    }
}

/// Solve and build the JSON object (the contract's `K`, `S` and more).
///
/// # Errors
/// Missing or conflicting inputs; the library's refusals (values out of
/// range, readings no film can produce), each naming the value.
pub fn compute(inputs: &KmFitInputs) -> Result<Value> {
    let mode = mode(inputs)?;
    let corr = saunderson(inputs)?;
    // Measured -> internal reflectance, naming the input on failure.
    let internal = |name: &str, r: f64| -> Result<f64> {
        match &corr {
            None => Ok(r),
            Some(c) => c.internal_from_measured(r).with_context(|| format!("--{name}")),
        }
    };
    let mut inputs_json = Map::new();
    let mut internal_json = Map::new();
    let mut out = Map::new();
    let film: Option<Film> = match mode {
        Mode::BlackWhite { r_black, g_black, r_white, g_white, thickness } => {
            let rb = internal("r-black", r_black)?;
            let rw = internal("r-white", r_white)?;
            for (k, v) in [
                ("r_black", r_black),
                ("r_white", r_white),
                ("r_black_ground", g_black),
                ("r_white_ground", g_white),
                ("thickness", thickness),
            ] {
                inputs_json.insert(k.into(), json!(v));
            }
            internal_json.insert("r_black".into(), json!(rb));
            internal_json.insert("r_white".into(), json!(rw));
            out.insert("mode".into(), json!("black_white"));
            let film = kubelka::from_black_white(rb, g_black, rw, g_white, thickness)?;
            let (ub, uw) = (
                READING_U * internal_slope(&corr, r_black),
                READING_U * internal_slope(&corr, r_white),
            );
            let u = kubelka::black_white_uncertainty(rb, g_black, rw, g_white, thickness, ub, uw);
            out.insert("uncertainty".into(), uncertainty_json(u.ok()));
            Some(film)
        }
        Mode::RInfRZero { r_inf, r_zero, thickness } => {
            let ri = internal("r-inf", r_inf)?;
            let r0 = internal("r-zero", r_zero)?;
            for (k, v) in [("r_inf", r_inf), ("r_zero", r_zero), ("thickness", thickness)] {
                inputs_json.insert(k.into(), json!(v));
            }
            internal_json.insert("r_inf".into(), json!(ri));
            internal_json.insert("r_zero".into(), json!(r0));
            out.insert("mode".into(), json!("r_inf_r_zero"));
            let film = kubelka::from_r_inf_r0(ri, r0, thickness)?;
            let (ui, u0) = (
                READING_U * internal_slope(&corr, r_inf),
                READING_U * internal_slope(&corr, r_zero),
            );
            let u = kubelka::r_inf_r0_uncertainty(ri, r0, thickness, ui, u0);
            out.insert("uncertainty".into(), uncertainty_json(u.ok()));
            Some(film)
        }
        Mode::RInf { r_inf } => {
            let ri = internal("r-inf", r_inf)?;
            inputs_json.insert("r_inf".into(), json!(r_inf));
            internal_json.insert("r_inf".into(), json!(ri));
            out.insert("mode".into(), json!("r_inf"));
            out.insert("K_over_S".into(), json!(kubelka::k_over_s(ri)?));
            out.insert("R_inf".into(), json!(ri));
            out.insert("uncertainty".into(), Value::Null);
            None
        }
    };
    match film {
        Some(f) => {
            out.insert("K".into(), json!(f.k));
            out.insert("S".into(), json!(f.s));
            out.insert("K_over_S".into(), json!(f.k_over_s));
            out.insert("S_X".into(), json!(f.sx));
            out.insert("R_inf".into(), json!(f.r_inf));
            out.insert("R_0".into(), json!(f.r0));
            out.insert("T".into(), json!(f.t));
            out.insert("thickness".into(), json!(f.sx / f.s));
        }
        None => {
            for k in ["K", "S", "S_X", "R_0", "T", "thickness"] {
                out.insert(k.into(), Value::Null);
            }
        }
    }
    if let (Some(c), Some(ri)) = (&corr, out.get("R_inf").and_then(Value::as_f64)) {
        // What an instrument would read on the opaque film.
        out.insert("R_inf_measured".into(), json!(c.measured_from_internal(ri)?));
    }
    out.insert(
        "saunderson".into(),
        corr.map(|c| json!({ "k1": c.k1, "k2": c.k2 })).unwrap_or(Value::Null),
    );
    out.insert("inputs".into(), Value::Object(inputs_json));
    out.insert("internal".into(), Value::Object(internal_json));
    Ok(Value::Object(out))
}

/// Run `km fit --km`: print a table, or the JSON object with `--json`.
///
/// # Errors
/// Those of [`compute`].
pub fn run(inputs: &KmFitInputs, json: bool) -> Result<()> {
    use std::fmt::Write;
    let v = compute(inputs)?;
    if json {
        return crate::stdout::print(&format!("{}\n", serde_json::to_string_pretty(&v)?));
    }
    // The table is built whole, then written through the checked stdout.
    let mut out = String::new();
    writeln!(out, "Kubelka–Munk inverse ({})", v["mode"].as_str().unwrap_or(""))?;
    let rows: [(&str, &str); 8] = [
        ("K", "absorption K (1/length)"),
        ("S", "scattering S (1/length)"),
        ("K_over_S", "K/S"),
        ("S_X", "scattering power S X"),
        ("R_inf", "R_inf (internal, opaque)"),
        ("R_inf_measured", "R_inf (as measured)"),
        ("R_0", "R_0 (internal, over black)"),
        ("T", "T (diffuse transmittance)"),
    ];
    for (key, label) in rows {
        match v.get(key).and_then(Value::as_f64) {
            Some(x) => writeln!(out, "  {label:<30} {x:.6}")?,
            None if key == "K" || key == "S" => {
                writeln!(out, "  {label:<30} (needs --r-zero and --thickness)")?
            }
            None => {}
        }
    }
    if let Some(u) = v.get("uncertainty").filter(|u| !u.is_null()) {
        writeln!(
            out,
            "  u(K), u(S) for readings +-{}: {:.3e}, {:.3e} (correlation {:.3})",
            u["u_reading"],
            u["K"].as_f64().unwrap_or(f64::NAN),
            u["S"].as_f64().unwrap_or(f64::NAN),
            u["correlation"].as_f64().unwrap_or(f64::NAN)
        )?;
    }
    if let Some(s) = v.get("saunderson").filter(|s| !s.is_null()) {
        let (k1, k2) = (s["k1"].as_f64(), s["k2"].as_f64());
        writeln!(
            out,
            "  Saunderson k1 = {:.6}, k2 = {:.6}",
            k1.unwrap_or(f64::NAN),
            k2.unwrap_or(f64::NAN)
        )?;
        if let Some(m) = v["internal"].as_object() {
            for (k, x) in m {
                writeln!(out, "  internal {k:<21} {:.6}", x.as_f64().unwrap_or(f64::NAN))?;
            }
        }
    }
    crate::stdout::print(&out)
}

/// Points of the hiding curves (thicknesses from 0 to this many, at most).
const PLOT_POINTS: usize = 200;

/// Draw the fitted film's hiding curves into `dir/km-fit-km.svg` and `.png`:
/// internal reflectance over each ground against film thickness (Kubelka
/// 1948 eq. 11 with the fitted `K`, `S`), the (internal) readings at the
/// measured thickness, and `R_inf`. The thickness axis runs to 1.2 times the
/// hiding thickness (`R_0 = 0.98 R_inf`, from eq. I4), kept within 2 to 20
/// times the measured thickness. Returns the two paths.
///
/// # Errors
/// Those of [`compute`]; only `--r-inf` given (no `K`, `S` to draw); a
/// directory that cannot be created; drawing errors.
pub fn write_plot(inputs: &KmFitInputs, dir: &Path) -> Result<[PathBuf; 2]> {
    let v = compute(inputs)?;
    let (Some(k), Some(s), Some(x)) = (v["K"].as_f64(), v["S"].as_f64(), v["thickness"].as_f64())
    else {
        bail!("--plot needs K and S: give --r-zero and --thickness, or --r-black and --r-white");
    };
    let r_inf = v["R_inf"].as_f64().unwrap_or(f64::NAN);
    // Hiding thickness: where the film over black reaches 98 % of R_inf.
    let hiding = kubelka::from_r_inf_r0(r_inf, 0.98 * r_inf, 1.0).map(|f| f.sx / s).unwrap_or(x);
    let x_max = (1.2 * hiding).clamp(2.0 * x, 20.0 * x);
    // The grounds and readings to draw.
    let internal = &v["internal"];
    let grounds: Vec<(String, f64, Option<f64>)> = match v["mode"].as_str() {
        Some("black_white") => vec![
            (
                "over dark ground".into(),
                v["inputs"]["r_black_ground"].as_f64().unwrap_or(0.0),
                internal["r_black"].as_f64(),
            ),
            (
                "over light ground".into(),
                v["inputs"]["r_white_ground"].as_f64().unwrap_or(1.0),
                internal["r_white"].as_f64(),
            ),
        ],
        _ => vec![("over ideal black".into(), 0.0, internal["r_zero"].as_f64())],
    };
    let mut series = Vec::new();
    for (i, (label, g, reading)) in grounds.iter().enumerate() {
        let mut pts = Vec::with_capacity(PLOT_POINTS + 1);
        for j in 0..=PLOT_POINTS {
            let t = x_max * j as f64 / PLOT_POINTS as f64;
            pts.push((t, kubelka::reflectance_over_ground(k, s, t, *g)?));
        }
        series.push(Series::new(format!("{label} ({g})"), pts, Mark::Line, i));
        if let Some(r) = reading {
            series.push(Series::new(format!("reading, {label}"), vec![(x, *r)], Mark::Points, i));
        }
    }
    let chart = LineChart {
        title: format!("Kubelka–Munk fit: K = {k:.4}, S = {s:.4} (internal reflectance)"),
        x_label: "film thickness".into(),
        y_label: "reflectance".into(),
        y_range: Some((0.0, 1.0)),
        series,
        h_lines: vec![(r_inf, format!("R_inf = {r_inf:.4}"))],
        ..Default::default()
    };
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    write_chart(dir, "km-fit-km", &chart)
}

#[cfg(test)]
mod tests {
    use super::*;
    use km_inverse::kubelka::reflectance_over_ground;

    #[test]
    fn black_white_readings_give_the_films_k_and_s() {
        // Readings made by the forward model (km-core's two-flux adding),
        // then passed through Saunderson's surface as an instrument sees them.
        let (k, s, x, n) = (0.3, 2.0, 0.5, 1.5);
        let c = Saunderson::fresnel(n, Specular::Included).unwrap();
        let read = |g: f64| c.measured_from_internal(reflectance_over_ground(k, s, x, g).unwrap());
        let inputs = KmFitInputs {
            r_black: Some(read(0.02).unwrap()),
            r_white: Some(read(0.85).unwrap()),
            r_white_ground: Some(0.85),
            r_black_ground: Some(0.02),
            thickness: Some(x),
            n: Some(n),
            ..Default::default()
        };
        let v = compute(&inputs).unwrap();
        // Round trip of the library (1e-12, km-inverse/tests/kubelka.rs).
        assert!((v["K"].as_f64().unwrap() - k).abs() < 1e-12, "{v}");
        assert!((v["S"].as_f64().unwrap() - s).abs() < 1e-12, "{v}");
        assert_eq!(v["mode"], "black_white");
        assert!(run(&inputs, true).is_ok() && run(&inputs, false).is_ok());
        // The uncertainty for readings +-0.001, through Saunderson's slope
        // dR/dR_m = (1-k1)(1-k2) / ((1-k1)(1-k2) + k2 y)^2 (eq. I9 differentiated).
        let slope = |rm: f64| {
            let (a, y) = ((1.0 - c.k1) * (1.0 - c.k2), rm - c.k1);
            a / (a + c.k2 * y).powi(2)
        };
        let (rb, rw) = (inputs.r_black.unwrap(), inputs.r_white.unwrap());
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
        let u = &v["uncertainty"];
        // Central differences of step 1e-7 on a smooth function: ~1e-7 relative.
        assert!((u["K"].as_f64().unwrap() / lib.k - 1.0).abs() < 1e-6, "{u} {lib:?}");
        assert!((u["S"].as_f64().unwrap() / lib.s - 1.0).abs() < 1e-6, "{u} {lib:?}");
    }

    #[test]
    fn plot_draws_the_hiding_curves() {
        let (k, s, x) = (0.3, 2.0, 0.5);
        let inputs = KmFitInputs {
            r_black: Some(reflectance_over_ground(k, s, x, 0.0).unwrap()),
            r_white: Some(reflectance_over_ground(k, s, x, 0.8).unwrap()),
            r_white_ground: Some(0.8),
            thickness: Some(x),
            ..Default::default()
        };
        let dir = std::env::temp_dir().join(format!("km-fit-km-plot-{}", std::process::id()));
        let [svg, png] = write_plot(&inputs, &dir).unwrap();
        let text = std::fs::read_to_string(&svg).unwrap();
        assert!(text.contains("<svg") && text.contains("R_inf"), "{}", svg.display());
        assert!(std::fs::metadata(&png).unwrap().len() > 1000);
        std::fs::remove_dir_all(&dir).unwrap();
        // Only R_inf: nothing to draw, said so.
        let e = write_plot(&KmFitInputs { r_inf: Some(0.5), ..Default::default() }, &dir);
        assert!(e.unwrap_err().to_string().contains("--plot needs K and S"));
    }

    #[test]
    fn r_inf_alone_gives_k_over_s_and_null_k_s() {
        let v = compute(&KmFitInputs { r_inf: Some(0.5), ..Default::default() }).unwrap();
        assert!((v["K_over_S"].as_f64().unwrap() - 0.25).abs() < 1e-15);
        assert!(v["K"].is_null() && v["S"].is_null());
    }

    #[test]
    fn missing_and_conflicting_inputs_are_named() {
        let e = compute(&KmFitInputs { r_black: Some(0.1), ..Default::default() }).unwrap_err();
        assert!(e.to_string().contains("--r-white"), "{e}");
        let e = compute(&KmFitInputs {
            r_black: Some(0.1),
            r_white: Some(0.3),
            r_white_ground: Some(0.8),
            ..Default::default()
        })
        .unwrap_err();
        assert!(e.to_string().contains("--thickness"), "{e}");
        let e =
            compute(&KmFitInputs { r_black: Some(0.1), r_inf: Some(0.3), ..Default::default() })
                .unwrap_err();
        assert!(e.to_string().contains("not both"), "{e}");
        let e = compute(&KmFitInputs { r_inf: Some(0.3), k2: Some(0.6), ..Default::default() })
            .unwrap_err();
        assert!(e.to_string().contains("--k2 needs --n"), "{e}");
        // Swapped readings: the library's message names r_black.
        let e = compute(&KmFitInputs {
            r_black: Some(0.5),
            r_white: Some(0.3),
            r_white_ground: Some(0.8),
            thickness: Some(1.0),
            ..Default::default()
        })
        .unwrap_err();
        assert!(format!("{e:#}").contains("r_black = 0.5"), "{e:#}");
        // A reading below the surface reflection, with --n.
        let e = compute(&KmFitInputs { r_inf: Some(0.01), n: Some(1.5), ..Default::default() })
            .unwrap_err();
        assert!(format!("{e:#}").contains("--r-inf"), "{e:#}");
    }
}
