//! Text for people: a solution as a table, a scene and a plan in words (what
//! the `km` command prints without `--json`).

use std::fmt::Write;

use km_montecarlo::EXACT_RELATIVE_STDERR;

use crate::{ChannelResult, Light, Method, MethodDiagnostics, Plan, Scene, Solution, Substrate};

/// How a result is printed (`km solve`, `km merge`, `km profile`, `km field`,
/// `km phase`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Format {
    /// Text for people.
    Table,
    /// The JSON contract of docs/cli.md.
    Json,
    /// Comma-separated values with a header.
    Csv,
}

impl Format {
    /// `--json` or `--format` (table by default).
    pub fn of(json: bool, format: Option<Format>) -> Format {
        format.unwrap_or(if json { Format::Json } else { Format::Table })
    }

    /// A result in this format: its `table`, its `csv`, or its `json`
    /// (indented, with a final newline).
    pub fn text(
        self,
        table: impl FnOnce() -> String,
        csv: impl FnOnce() -> String,
        json: impl FnOnce() -> serde_json::Value,
    ) -> String {
        match self {
            Format::Table => table(),
            Format::Csv => csv(),
            Format::Json => format!("{:#}\n", json()),
        }
    }
}

/// Reads one number of a channel's result.
type Getter = fn(&ChannelResult) -> f64;

/// Reads the standard error of one number (Monte Carlo).
type StdGetter = fn(&crate::Uncertainty) -> Option<f64>;

/// The five totals: name, value, standard error.
const TOTALS: [(&str, Getter, StdGetter); 5] = [
    ("reflectance", |c| c.reflectance, |u| u.reflectance),
    ("reflectance_specular", |c| c.reflectance_specular, |u| u.reflectance_specular),
    ("transmittance", |c| c.transmittance, |u| u.transmittance),
    ("transmittance_direct", |c| c.transmittance_direct, |u| u.transmittance_direct),
    ("absorptance", |c| c.absorptance, |u| u.absorptance),
];

/// Words of the totals in the text table.
const TOTAL_WORDS: [&str; 5] =
    ["reflectance", "  specular part", "transmittance", "  direct part", "absorptance"];

/// `x` for people: 6 decimals, or 6 significant digits in exponent form
/// below 1e-3 and from 1e6 (0 as `0`).
fn fixed(x: f64) -> String {
    let a = x.abs();
    if x == 0.0 {
        "0".into()
    } else if !(1e-3..1e6).contains(&a) && x.is_finite() {
        format!("{x:.5e}")
    } else {
        format!("{x:.6}")
    }
}

/// `x ± se` for people (eq. F1 of docs/cli.md): the standard error to two
/// significant digits and the value to the same decimal place (`0.2345 ±
/// 0.0012`; in exponent form when that place is beyond the 6th decimal);
/// `x` alone as [`fixed`] when there is no standard error or it is at most
/// [`km_montecarlo::EXACT_RELATIVE_STDERR`] of `|x|` (a number the same in
/// every batch of photons, e.g. the mirror reflection of a smooth surface).
///
/// ```
/// use km::text::with_stderr;
/// assert_eq!(with_stderr(0.23451234, Some(0.00123)), "0.2345 ± 0.0012");
/// assert_eq!(with_stderr(684.49, Some(12.3)), "684 ± 12");
/// assert_eq!(with_stderr(3.4567e-9, Some(1.23e-10)), "3.46e-9 ± 1.2e-10");
/// assert_eq!(with_stderr(0.04, Some(1.3e-18)), "0.040000");
/// assert_eq!(with_stderr(0.5, None), "0.500000");
/// ```
pub fn with_stderr(x: f64, se: Option<f64>) -> String {
    let Some(e) = se.filter(|e| *e > EXACT_RELATIVE_STDERR * x.abs() && e.is_finite()) else {
        return fixed(x);
    };
    // The decimal place of the standard error's second significant digit.
    let place = 1 - e.log10().floor() as i64;
    if (0..=6).contains(&place) {
        let d = place as usize;
        return format!("{x:.d$} ± {e:.d$}");
    }
    if place < 0 {
        return format!("{x:.0} ± {e:.0}");
    }
    // Small numbers: the value's significant digits down to that place.
    let digits = if x == 0.0 { 0 } else { (x.abs().log10().floor() as i64 + place).max(0) };
    let d = digits as usize;
    format!("{x:.d$e} ± {e:.1e}")
}

/// `x`, with `± stderr` when there is one (see [`with_stderr`]).
fn cell(x: f64, se: Option<f64>) -> String {
    with_stderr(x, se)
}

/// Whether the BTDF is meaningless: every value 0 and nothing transmitted
/// (an opaque substrate or a half-space).
pub(crate) fn btdf_is_empty(sol: &Solution) -> bool {
    sol.channels.iter().all(|c| c.btdf.iter().all(|&v| v == 0.0) && c.transmittance == 0.0)
}

/// A table of the solution, one column per channel (one row per wavelength
/// for a spectral scene), then the accuracy target met, the settings that
/// shape the answer (Monte Carlo photon count, the two-flux mapping) and
/// every note. `scene` supplies the output directions when the solution
/// does not carry them, and the wavelengths.
pub fn table(sol: &Solution, scene: Option<&Scene>) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "method: {}   solver time: {}", sol.method, seconds(sol.seconds));
    let mc = sol.channels.iter().any(|c| c.stderr.is_some());
    let width = if mc { 24 } else { 14 };
    let wavelengths = scene.and_then(|sc| sc.wavelengths_nm());
    let spectral = wavelengths.filter(|w| w.len() == sol.channels.len());
    if let Some(w) = spectral {
        // Spectral: one row per wavelength.
        let _ = write!(s, "{:>14}", "wavelength_nm");
        for name in ["R", "R_specular", "T", "T_direct", "A"] {
            let _ = write!(s, "{name:>width$}");
        }
        let _ = writeln!(s);
        for (c, wl) in sol.channels.iter().zip(w) {
            let _ = write!(s, "{wl:>14}");
            for (_, get, se) in TOTALS {
                let _ = write!(s, "{:>width$}", cell(get(c), c.stderr.as_ref().and_then(se)));
            }
            let _ = writeln!(s);
        }
    } else {
        let _ = write!(s, "{:<24}", "");
        if sol.labels.len() == 1 {
            let _ = write!(s, "{:>width$}", "value");
        } else {
            for l in &sol.labels {
                let _ = write!(s, "{l:>width$}");
            }
        }
        let _ = writeln!(s);
        for ((_, get, se), name) in TOTALS.into_iter().zip(TOTAL_WORDS) {
            let _ = write!(s, "{name:<24}");
            for c in &sol.channels {
                let _ = write!(s, "{:>width$}", cell(get(c), c.stderr.as_ref().and_then(se)));
            }
            let _ = writeln!(s);
        }
    }
    direction_rows(&mut s, sol, scene, spectral, width);
    depth_rows(&mut s, sol);
    cone_lines(&mut s, sol);
    model_error_lines(&mut s, sol);
    if mc {
        let photons = sol.diagnostics.mc().map(|m| m.samples);
        if let Some(n) = photons {
            let _ = writeln!(s, "Monte Carlo: {n} photons per channel; ± is one standard error");
        }
    }
    if let MethodDiagnostics::TwoFlux { mapping, model } = &sol.diagnostics.method {
        let _ = writeln!(s, "{}", km_mapping_words(mapping.name(), model.name(), scene));
    }
    if let Some(a) = &sol.accuracy {
        let _ = writeln!(
            s,
            "accuracy target {:e} met; limited by {} (estimate {:.2e})",
            a.target, a.limited_by, a.estimate
        );
    }
    for note in &sol.notes {
        let _ = writeln!(s, "note: {note}");
    }
    s
}

/// Depth rows shown at most; more are thinned to every k-th.
const DEPTH_ROWS: usize = 40;

/// The field at the scene's depths (docs/field.md): a row per depth with
/// `phi`, `A` and `F` of each channel (± one standard error for Monte
/// Carlo), thinned to at most [`DEPTH_ROWS`] rows.
fn depth_rows(s: &mut String, sol: &Solution) {
    let Some(f) = &sol.field else { return };
    let n = f.depths.len();
    let step = n.div_ceil(DEPTH_ROWS).max(1);
    let se = f.stderr.as_ref();
    let width = if se.is_some() { 24 } else { 14 };
    let several = f.fluence.len() > 1;
    let _ = write!(s, "{:<24}", "depth");
    for c in 0..f.fluence.len() {
        for q in ["fluence", "absorbed", "net flux"] {
            let head = if several { format!("{q} {}", sol.labels[c]) } else { q.to_string() };
            let _ = write!(s, "{head:>width$}");
        }
    }
    let _ = writeln!(s);
    let mut rows: Vec<usize> = (0..n).step_by(step).collect();
    if rows.last() != Some(&(n - 1)) {
        rows.push(n - 1);
    }
    for &i in &rows {
        let _ = write!(s, "{:<24}", number(f.depths[i]));
        for c in 0..f.fluence.len() {
            for (q, v) in [&f.fluence, &f.absorbed, &f.net_flux].into_iter().enumerate() {
                let e = se.map(|e| e[q][c][i]);
                let _ = write!(s, "{:>width$}", cell(v[c][i], e));
            }
        }
        let _ = writeln!(s);
    }
    if step > 1 {
        let _ = writeln!(s, "(every {step}th of {n} depths shown; --json has them all)");
    }
    // The radiance inside at the same depths (docs/field.md §6).
    if let Some(r) = &f.radiance {
        let _ = writeln!(s);
        s.push_str(&crate::field::inside_table(r, &sol.labels, &f.depths, &rows));
    }
}

/// The BRDF/BTDF rows: one per direction, a column per channel (for a
/// spectral scene under a header of its wavelengths); no BTDF rows when
/// nothing is transmitted.
fn direction_rows(
    s: &mut String,
    sol: &Solution,
    scene: Option<&Scene>,
    spectral: Option<&[f64]>,
    width: usize,
) {
    let scene_dirs = scene.map(|s| s.channels()[0].directions_deg());
    let dirs = if sol.directions.is_empty() {
        scene_dirs.unwrap_or(&sol.directions)
    } else {
        &sol.directions
    };
    let mut wl_header = false;
    for (what, pick) in [("BRDF", 0usize), ("BTDF", 1usize)] {
        if sol
            .channels
            .iter()
            .all(|c| if pick == 0 { c.brdf.is_empty() } else { c.btdf.is_empty() })
            || (pick == 1 && btdf_is_empty(sol))
        {
            continue;
        }
        if let Some(w) = spectral.filter(|_| !std::mem::replace(&mut wl_header, true)) {
            // Directions in rows, wavelengths in columns (as the labels above).
            let _ = write!(s, "{:<24}", "");
            for wl in w {
                let _ = write!(s, "{:>width$}", format!("{wl} nm"));
            }
            let _ = writeln!(s);
        }
        for (i, d) in dirs.iter().enumerate() {
            let _ = write!(s, "{:<24}", format!("{what} ({:.1}, {:.1}) 1/sr", d[0], d[1]));
            for c in &sol.channels {
                let v = if pick == 0 { &c.brdf } else { &c.btdf };
                let se = c
                    .stderr
                    .as_ref()
                    .and_then(|u| if pick == 0 { u.brdf.as_ref() } else { u.btdf.as_ref() });
                let e = se.and_then(|e| e.get(i).copied());
                let _ = write!(s, "{:>width$}", cell(v.get(i).copied().unwrap_or(f64::NAN), e));
            }
            let _ = writeln!(s);
        }
    }
}

/// The cones the BRDF/BTDF values are means over (Monte Carlo bins,
/// cone-averaged multi-flux), per direction, degrees.
fn cone_lines(s: &mut String, sol: &Solution) {
    let Some(c) = sol.channels.iter().find_map(|c| c.cones.as_ref()) else { return };
    let list = |v: &[f64]| v.iter().map(|a| format!("{a:.2}")).collect::<Vec<_>>().join(", ");
    let _ = writeln!(
        s,
        "BRDF/BTDF are means over cones of half-angle (degrees, per direction): BRDF {}; BTDF {}",
        list(&c.brdf),
        list(&c.btdf)
    );
}

/// The model error estimate of a closed form (docs/two-flux.md eq. K25),
/// one row per total, one column per channel.
fn model_error_lines(s: &mut String, sol: &Solution) {
    if sol.channels.iter().all(|c| c.model_error_estimate.is_none()) {
        return;
    }
    let _ = writeln!(s, "model error estimate (against a 4-stream multi-flux solve, eq. K25):");
    for ((_, _, get), word) in TOTALS.into_iter().zip(TOTAL_WORDS) {
        let _ = write!(s, "{word:<24}");
        for c in &sol.channels {
            let e = c.model_error_estimate.as_ref().and_then(get);
            let cell = match e {
                None => "-".to_string(),
                Some(0.0) => "0".to_string(),
                Some(e) => format!("{e:.1e}"),
            };
            let _ = write!(s, "{cell:>14}");
        }
        let _ = writeln!(s);
    }
}

/// Which two-flux model and mapping were used, how K, S relate to the
/// scene's sigma_a, sigma_s and g (docs/two-flux.md eq. K13–K14), and when
/// the multi-flux method is the better answer.
fn km_mapping_words(mapping: &str, model: &str, scene: Option<&Scene>) -> String {
    let formula = match mapping {
        "seed" => "K = sigma_a, S = sigma_s (g ignored)",
        "star1988" => "K = 2 sigma_a, S = 3/4 sigma_s (1 - g) - 1/4 sigma_a",
        "gate1974" => "K = 2 sigma_a, S = 3/4 sigma_s (1 - g)",
        _ => "",
    };
    let mut s = format!(
        "model {model} (--km-model four-flux|two-flux); K/S mapping {mapping}: {formula} \
         (--km-mapping seed|star1988|gate1974)"
    );
    let questionable = scene.is_some_and(|sc| {
        sc.channels()
            .iter()
            .any(|c| c.layers().iter().any(|l| l.g() != 0.0 || l.n() != c.ambient_n()))
    });
    if questionable {
        s.push_str(
            "\nthe scene has a Fresnel interface or g != 0: the two-flux answer depends on the \
             mapping and the model (model error estimate above); --method multiflux solves the \
             angular problem",
        );
    }
    s
}

/// The solution as CSV: a header, then one row per channel (`channel`, or
/// `wavelength_nm` for a spectral scene), the five totals, their standard
/// errors when there are any (`stderr_reflectance`, ...), `brdf_I`,
/// `btdf_I` per output direction, and their standard errors
/// (`stderr_brdf_I`, `stderr_btdf_I`, Monte Carlo). Numbers as [`number`]
/// writes them (every digit of the JSON).
pub fn csv(sol: &Solution, scene: Option<&Scene>) -> String {
    let wavelengths =
        scene.and_then(|sc| sc.wavelengths_nm()).filter(|w| w.len() == sol.channels.len());
    let mc = sol.channels.iter().any(|c| c.stderr.is_some());
    let n_brdf = sol.channels.iter().map(|c| c.brdf.len()).max().unwrap_or(0);
    let n_btdf = if btdf_is_empty(sol) {
        0
    } else {
        sol.channels.iter().map(|c| c.btdf.len()).max().unwrap_or(0)
    };
    let mut head =
        vec![if wavelengths.is_some() { "wavelength_nm" } else { "channel" }.to_string()];
    head.extend(TOTALS.iter().map(|t| t.0.to_string()));
    if mc {
        head.extend(TOTALS.iter().map(|t| format!("stderr_{}", t.0)));
    }
    head.extend((0..n_brdf).map(|i| format!("brdf_{i}")));
    head.extend((0..n_btdf).map(|i| format!("btdf_{i}")));
    if mc {
        head.extend((0..n_brdf).map(|i| format!("stderr_brdf_{i}")));
        head.extend((0..n_btdf).map(|i| format!("stderr_btdf_{i}")));
    }
    let mut s = head.join(",");
    s.push('\n');
    let list = |v: Option<&Vec<f64>>, n: usize| -> Vec<String> {
        (0..n).map(|i| v.and_then(|v| v.get(i)).map(|x| number(*x)).unwrap_or_default()).collect()
    };
    for (k, c) in sol.channels.iter().enumerate() {
        let mut row = vec![match wavelengths {
            Some(w) => w[k].to_string(),
            None => sol.labels.get(k).cloned().unwrap_or_default(),
        }];
        row.extend(TOTALS.iter().map(|t| number(t.1(c))));
        if mc {
            row.extend(
                TOTALS
                    .iter()
                    .map(|t| c.stderr.as_ref().and_then(t.2).map(number).unwrap_or_default()),
            );
        }
        row.extend(list(Some(&c.brdf), n_brdf));
        row.extend(list(Some(&c.btdf), n_btdf));
        if mc {
            let u = c.stderr.as_ref();
            row.extend(list(u.and_then(|u| u.brdf.as_ref()), n_brdf));
            row.extend(list(u.and_then(|u| u.btdf.as_ref()), n_btdf));
        }
        s.push_str(&row.join(","));
        s.push('\n');
    }
    s
}

/// A number for CSV and the sweep's rows: the shortest decimal that reads
/// back as `x` (every digit of the JSON), in exponent form (`1.18e-17`)
/// when `x` is not 0 and below 1e-4 or from 1e16 in magnitude, so that no
/// long run of zeros stands for a small number.
///
/// ```
/// assert_eq!(km::text::number(0.3), "0.3");
/// assert_eq!(km::text::number(1.1802303081984698e-17), "1.1802303081984698e-17");
/// assert_eq!(km::text::number(0.0), "0");
/// ```
pub fn number(x: f64) -> String {
    let a = x.abs();
    if x != 0.0 && x.is_finite() && !(1e-4..1e16).contains(&a) {
        format!("{x:e}")
    } else {
        x.to_string()
    }
}

fn seconds(t: f64) -> String {
    if t < 1e-3 {
        format!("{:.2} us", t * 1e6)
    } else if t < 1.0 {
        format!("{:.3} ms", t * 1e3)
    } else {
        format!("{t:.3} s")
    }
}

/// What a scene describes, in words (`km check`).
pub fn describe(scene: &Scene) -> String {
    let mut s = String::new();
    let c0 = &scene.channels()[0];
    let _ = writeln!(s, "channels: {} ({})", scene.channels().len(), scene.labels().join(", "));
    match c0.light() {
        Light::Collimated { theta_deg } => {
            let _ = writeln!(s, "light: collimated at {theta_deg} degrees");
        }
        Light::Diffuse => {
            let _ = writeln!(s, "light: diffuse");
        }
    }
    let _ = writeln!(s, "ambient index: {}", c0.ambient_n());
    for (ch, c) in scene.channels().iter().enumerate() {
        let _ = writeln!(s, "channel {}:", scene.labels()[ch]);
        for (i, l) in c.layers().iter().enumerate() {
            let _ = writeln!(
                s,
                "  layer {}: sigma_a = {}, sigma_s = {}, thickness = {}, tau = {}, albedo = {:.6}, g = {}, n = {}",
                i + 1,
                l.sigma_a(),
                l.sigma_s(),
                l.thickness(),
                l.tau(),
                l.albedo(),
                l.g(),
                l.n()
            );
        }
        let sub = match c.substrate() {
            Substrate::Transparent { n } => format!("transparent, n = {n}"),
            Substrate::Lambertian { albedo } => format!("lambertian, albedo = {albedo}"),
            Substrate::Black => "black".into(),
            Substrate::Conductor { n, k } => format!("conductor, n = {n}, k = {k}"),
        };
        let _ = writeln!(s, "  substrate: {sub}");
    }
    if !c0.directions_deg().is_empty() {
        let _ = writeln!(s, "output directions (theta, phi): {:?}", c0.directions_deg());
    }
    s
}

/// A plan as JSON with the method it is for (`km plan --json`).
pub fn plan_json(plan: &Plan, method: Method) -> serde_json::Value {
    let mut v = plan.to_json();
    v["method"] = serde_json::json!(method.name());
    v
}

/// A plan in plain words (`km plan`).
pub fn plan_words(plan: &Plan, method: Method) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "plan for method {}", method.name());
    if plan.all_effects {
        let _ = writeln!(s, "planner off (--all-effects): every effect is computed");
    }
    let effects =
        if plan.effects.is_empty() { "none".to_string() } else { plan.effects.join(", ") };
    let _ = writeln!(s, "effects present: {effects}");
    let _ = writeln!(s, "layers taking part: {}", plan.active_layers);
    for (i, l) in plan.layers.iter().enumerate() {
        let mut what = Vec::new();
        what.push(if l.interface_above { "Fresnel interface above" } else { "no interface above" });
        what.push(if l.scatters { "scatters" } else { "absorbs only: closed-form attenuation" });
        if l.half_space {
            what.push("half-space");
        }
        let _ = writeln!(s, "  layer {}: {}", i + 1, what.join(", "));
    }
    if plan.skipped.is_empty() {
        let _ = writeln!(s, "skipped: nothing");
    }
    for name in &plan.skipped {
        let why = plan.reasons.get(name).map_or("", |s| s.as_ref());
        let name = name.name();
        let _ = writeln!(s, "skipped {name}: {why}");
    }
    let per_method = match method {
        Method::Km => "two-flux closed form per layer, adding for the stack",
        Method::Multiflux if plan.azimuth_independent => {
            "Fourier order m = 0 only; eigen-solve only for scattering layers"
        }
        Method::Multiflux => "Fourier orders m = 0..M for the requested directions",
        Method::DirectionSet => "eigen-solve per layer on matched direction sets, exact adding",
        Method::Mc if plan.angular_tallies => "photon tracing with totals and angular bins",
        Method::Mc => "photon tracing with totals only",
        Method::Dipole => "closed form for a semi-infinite layer",
    };
    let _ = writeln!(s, "{}: {per_method}", method.name());
    s
}
