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
use km_inverse::drawdown::{DrawdownFit, Readings, fit_drawdown, hiding_curves};
use km_inverse::kubelka::{KubelkaError, Saunderson, Specular};
use serde_json::Value;

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

/// Which readings the flags give (`--r-black`/`--r-white`, or `--r-inf`
/// [`--r-zero`]), each missing or conflicting flag named.
fn mode(i: &KmFitInputs) -> Result<Readings> {
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
        return Ok(Readings::BlackWhite { r_black, g_black, r_white, g_white, thickness });
    }
    if i.r_white_ground.is_some() || i.r_black_ground.is_some() {
        bail!("--r-white-ground/--r-black-ground belong to --r-black/--r-white");
    }
    match (i.r_inf, i.r_zero) {
        (Some(r_inf), Some(r_zero)) => {
            let thickness = i.thickness.context("--thickness (the film thickness) is required")?;
            Ok(Readings::RInfRZero { r_inf, r_zero, thickness })
        }
        (None, Some(_)) => bail!("--r-zero needs --r-inf (the reflectance of the opaque film)"),
        (Some(r_inf), None) => {
            if i.thickness.is_some() {
                bail!("--thickness needs --r-zero: an opaque film alone gives only K/S");
            }
            Ok(Readings::RInf { r_inf })
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

/// Solve and build the JSON object (the contract's `K`, `S` and more):
/// [`km_inverse::drawdown::fit_drawdown`] on the readings of the flags.
///
/// # Errors
/// Missing or conflicting inputs; the library's refusals (values out of
/// range, readings no film can produce), each naming the value and its flag.
pub fn compute(inputs: &KmFitInputs) -> Result<Value> {
    Ok(fit(inputs)?.to_json())
}

fn fit(inputs: &KmFitInputs) -> Result<DrawdownFit> {
    let readings = mode(inputs)?;
    let corr = saunderson(inputs)?;
    fit_drawdown(readings, corr).map_err(|e| {
        // Name the flag of the reading the library names.
        let flag = match &e {
            KubelkaError::Invalid { name, .. } | KubelkaError::Infeasible { name, .. } => {
                format!("--{}", name.replace('_', "-"))
            }
            _ => "--km".into(),
        };
        anyhow::Error::new(e).context(flag)
    })
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

/// Draw the fitted film's hiding curves ([`km_inverse::drawdown::hiding_curves`])
/// into `dir/km-fit-km.svg` and `.png`, with the readings at the measured
/// thickness and `R_inf`. Returns the two paths.
///
/// # Errors
/// Those of [`compute`]; only `--r-inf` given (no `K`, `S` to draw); a
/// directory that cannot be created; drawing errors.
pub fn write_plot(inputs: &KmFitInputs, dir: &Path) -> Result<[PathBuf; 2]> {
    let fit = fit(inputs)?;
    let Some((curves, x)) = hiding_curves(&fit, PLOT_POINTS)? else {
        bail!("--plot needs K and S: give --r-zero and --thickness, or --r-black and --r-white");
    };
    let mut series = Vec::new();
    for (i, c) in curves.into_iter().enumerate() {
        if let Some(r) = c.reading {
            let label = format!("reading, {}", c.label);
            series.push(Series::new(label, vec![(x, r)], Mark::Points, i));
        }
        series.push(Series::new(format!("{} ({})", c.label, c.ground), c.points, Mark::Line, i));
    }
    let (k, s, r_inf) = fit.film.map_or((f64::NAN, f64::NAN, fit.r_inf), |f| (f.k, f.s, f.r_inf));
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
