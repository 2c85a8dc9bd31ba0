//! `km sweep`: one scene solved over a grid of edited values (`--set
//! KEY=START:STOP:N`), the points in parallel, the rows in a fixed order.

use km_core::set::SetEdit;
use km_core::{Scene, Solution};
use rayon::prelude::*;

use crate::{KmError, Options};

/// The most points one sweep solves.
pub const MAX_POINTS: usize = 100_000;

/// One swept key: `N` equally spaced values from `start` to `stop` (both included).
#[derive(Debug, Clone, PartialEq)]
pub struct SweepAxis {
    /// The key path (`layer[1].g`).
    pub key: String,
    /// First value.
    pub start: f64,
    /// Last value.
    pub stop: f64,
    /// Number of values, at least 1.
    pub n: usize,
}

impl SweepAxis {
    /// Parse `KEY=START:STOP:N`.
    ///
    /// # Errors
    /// A scene error on the key when the range is not `START:STOP:N` with
    /// finite numbers and `1 <= N <= 100000`.
    ///
    /// ```
    /// let a = km::SweepAxis::parse("layer[1].g=0:0.8:5").unwrap();
    /// assert_eq!(a.values(), vec![0.0, 0.2, 0.4, 0.6, 0.8]);
    /// let b = km::SweepAxis::parse("layer[1].g=0.1:0.5:5").unwrap();
    /// assert_eq!(b.values(), vec![0.1, 0.2, 0.3, 0.4, 0.5]);
    /// assert!(km::SweepAxis::parse("layer[1].g=0:0.8").is_err());
    /// ```
    pub fn parse(text: &str) -> Result<SweepAxis, KmError> {
        let e = SetEdit::parse(text)?;
        let bad = || {
            KmError::Scene(km_core::CoreError::scene(
                e.key.clone(),
                None,
                format!("from --set: `{}`: a sweep takes START:STOP:N, e.g. 0:0.9:10", e.value),
            ))
        };
        let parts: Vec<&str> = e.value.split(':').collect();
        let [a, b, n] = parts[..] else { return Err(bad()) };
        let (start, stop): (f64, f64) =
            (a.trim().parse().map_err(|_| bad())?, b.trim().parse().map_err(|_| bad())?);
        let n: usize = n.trim().parse().map_err(|_| bad())?;
        if !start.is_finite() || !stop.is_finite() || n == 0 || n > MAX_POINTS {
            return Err(bad());
        }
        Ok(SweepAxis { key: e.key, start, stop, n })
    }

    /// The texts of a sweep's edits split into the fixed edits (`KEY=VALUE`)
    /// and the axes (`KEY=START:STOP:N`: a value with two colons), each in
    /// the order given.
    ///
    /// # Errors
    /// Those of [`SetEdit::parse`] and [`SweepAxis::parse`].
    ///
    /// ```
    /// let sets = ["layer[1].g=0:0.8:5".to_string(), "light.theta_deg=30".to_string()];
    /// let (edits, axes) = km::SweepAxis::split(&sets).unwrap();
    /// assert_eq!((edits[0].key.as_str(), axes[0].n), ("light.theta_deg", 5));
    /// ```
    pub fn split(texts: &[String]) -> Result<(Vec<SetEdit>, Vec<SweepAxis>), KmError> {
        let (mut edits, mut axes) = (Vec::new(), Vec::new());
        for s in texts {
            // A value with a colon (not a quoted string) is a range: a
            // malformed one (`0:0.5:3:4`) is refused as such.
            let range = |v: &str| {
                let v = v.trim();
                v.contains(':') && !v.starts_with('"') && !v.starts_with('\'')
            };
            if s.split_once('=').is_some_and(|(_, v)| range(v)) {
                axes.push(SweepAxis::parse(s)?);
            } else {
                edits.push(SetEdit::parse(s)?);
            }
        }
        Ok((edits, axes))
    }

    /// The values `start + (stop - start) i / (N - 1)`, `i = 0..N` (`start`
    /// when `N = 1`), each rounded to the decimal places of `start`, `stop`
    /// and the step (eq. S1 of docs/cli.md), so that `0.1:0.5:5` gives `0.3`,
    /// not `0.30000000000000004`: the decimal a person reads in the range,
    /// as its nearest `f64`. A step with no decimal form of 13 significant
    /// digits or fewer (`0:1:4`) leaves the values of the formula unrounded.
    pub fn values(&self) -> Vec<f64> {
        if self.n == 1 {
            return vec![self.start];
        }
        let span = self.stop - self.start;
        let step = span / (self.n - 1) as f64;
        let places = step_places(step)
            .map(|p| p.max(decimal_places(self.start)).max(decimal_places(self.stop)));
        (0..self.n)
            .map(|i| {
                if i + 1 == self.n {
                    return self.stop;
                }
                let v = self.start + span * (i as f64 / (self.n - 1) as f64);
                places.map_or(v, |p| round_to_places(v, p))
            })
            .collect()
    }
}

/// The most decimal places a swept value is rounded to: beyond, the value
/// is kept as computed (numbers below about 1e-300 have no shorter form).
const MAX_PLACES: usize = 340;

/// The decimal places of a decimal in exponent form (`1.25e-1`: 3).
fn places_of(text: &str) -> usize {
    let (mantissa, exp) = text.split_once('e').unwrap_or((text, "0"));
    let exp: i64 = exp.parse().unwrap_or(0);
    let digits = mantissa.split_once('.').map_or(0, |(_, f)| f.trim_end_matches('0').len()) as i64;
    (digits - exp).clamp(0, MAX_PLACES as i64 + 1) as usize
}

/// The decimal places of the shortest decimal form of `x` that reads back
/// as `x` (Rust's `{:e}`: `0.1` has 1, `1e-300` has 300, `2.5e3` has 0).
fn decimal_places(x: f64) -> usize {
    if x == 0.0 || !x.is_finite() {
        return 0;
    }
    places_of(&format!("{x:e}"))
}

/// The decimal places of the step `x` written to 15 significant digits
/// (`0.09999999999999999` is `0.1`: 1 place), or `None` when that form
/// needs more than 13 (`1/3`: no short decimal form).
fn step_places(x: f64) -> Option<usize> {
    if x == 0.0 || !x.is_finite() {
        return Some(0);
    }
    let text = format!("{x:.14e}");
    let (mantissa, _) = text.split_once('e')?;
    let digits = mantissa.split_once('.').map_or(0, |(_, f)| f.trim_end_matches('0').len());
    (digits <= 12).then(|| places_of(&text))
}

/// `v` rounded to `places` decimal places (correctly rounded by the
/// formatter, read back as the nearest `f64`); `v` itself beyond [`MAX_PLACES`].
fn round_to_places(v: f64, places: usize) -> f64 {
    if places > MAX_PLACES {
        return v;
    }
    // `+ 0.0`: a value rounded to zero from below is 0, not -0.
    format!("{v:.places$}").parse::<f64>().map_or(v, |r| r + 0.0)
}

/// One point of a sweep: the swept values (in the order of the axes) and its solution.
#[derive(Debug, Clone)]
pub struct SweepPoint {
    /// The value of each axis.
    pub values: Vec<f64>,
    /// The solution at these values.
    pub solution: Solution,
}

/// Solve the scene file `text`, with the fixed `edits`, at every point of the
/// grid of `axes` (the first axis varies slowest), in parallel; the points
/// are returned in grid order.
///
/// # Errors
/// The first point's error in grid order (scene errors name the key and
/// `--set`), or a scene error when the grid has more than [`MAX_POINTS`].
///
/// ```
/// let text = "[[layer]]\ntau = 1\nalbedo = 0.9\n";
/// let axes = [km::SweepAxis::parse("layer[1].g=0:0.5:3").unwrap()];
/// let pts = km::sweep(text, &[], &axes, &km::Options::new(km::Method::Km)).unwrap();
/// assert_eq!(pts.len(), 3);
/// assert_eq!(pts[2].values, vec![0.5]);
/// ```
pub fn sweep(
    text: &str,
    edits: &[SetEdit],
    axes: &[SweepAxis],
    options: &Options,
) -> Result<Vec<SweepPoint>, KmError> {
    let total = axes.iter().try_fold(1usize, |acc, a| acc.checked_mul(a.n));
    let total = match total {
        Some(t) if t <= MAX_POINTS => t,
        _ => {
            return Err(KmError::Scene(km_core::CoreError::scene(
                "--set",
                None,
                format!("the sweep has more than {MAX_POINTS} points"),
            )));
        }
    };
    let values: Vec<Vec<f64>> = axes.iter().map(SweepAxis::values).collect();
    // One budget for the whole sweep (eq. L4), before any point is solved:
    // the first point stands for all (they differ in values only).
    let edits_at = |point: &[f64]| {
        let mut all = edits.to_vec();
        all.extend(
            axes.iter()
                .zip(point)
                .map(|(a, v)| SetEdit { key: a.key.clone(), value: format!("{v:?}") }),
        );
        all
    };
    let first: Vec<f64> = values.iter().map(|v| v[0]).collect();
    if let Ok(scene) = Scene::from_toml_str_edited(text, &edits_at(&first)) {
        crate::request_budget::check_points(
            &scene,
            total,
            options,
            crate::request_budget::SWEEP_POINT_OVERHEAD,
        )?;
    }
    let named = |point: &[f64], e: KmError| {
        let at: Vec<String> =
            axes.iter().zip(point).map(|(a, v)| format!("{}={v}", a.key)).collect();
        KmError::SweepPoint { point: at.join(" "), source: Box::new(e) }
    };
    let solve_at = |index: usize| {
        // Mixed-radix digits of `index`, the last axis fastest.
        let mut rest = index;
        let mut point = vec![0.0; axes.len()];
        for (k, a) in axes.iter().enumerate().rev() {
            point[k] = values[k][rest % a.n];
            rest /= a.n;
        }
        let solve = || {
            let scene = Scene::from_toml_str_edited(text, &edits_at(&point))?;
            crate::solve(&scene, options)
        };
        match solve() {
            Ok(solution) => Ok(SweepPoint { values: point, solution }),
            Err(e) if e.is_cancelled() => Err(KmError::Cancelled),
            Err(e) => Err(named(&point, e)),
        }
    };
    // The first point alone first: a scene the method cannot treat at all
    // is refused at once, not after every point has failed in parallel.
    let first = solve_at(0)?;
    let rest: Vec<Result<SweepPoint, KmError>> = (1..total).into_par_iter().map(solve_at).collect();
    std::iter::once(Ok(first)).chain(rest).collect()
}

/// How [`sweep_text`] lays out the rows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum SweepFormat {
    /// Aligned columns (22 characters each).
    #[cfg_attr(feature = "clap", value(help = "Aligned columns"))]
    Table,
    /// Comma-separated values with a header.
    Csv,
    /// One JSON object per line.
    Jsonl,
}

/// The five totals of a sweep row, by name.
const SWEEP_QUANTITIES: [&str; 5] =
    ["reflectance", "reflectance_specular", "transmittance", "transmittance_direct", "absorptance"];

/// The columns of a sweep's rows after the swept values and the channel:
/// the totals, their standard errors (Monte Carlo), the BRDF/BTDF values at
/// the scene's `[output]` directions and their standard errors.
struct Columns {
    /// Monte Carlo: standard error columns.
    mc: bool,
    /// BRDF values per row.
    n_brdf: usize,
    /// BTDF values per row (0 when nothing is transmitted at any point).
    n_btdf: usize,
}

impl Columns {
    fn of(points: &[SweepPoint]) -> Columns {
        let sols = || points.iter().map(|p| &p.solution);
        let most = |f: fn(&km_core::ChannelResult) -> usize| {
            sols().flat_map(|s| s.channels.iter().map(f)).max().unwrap_or(0)
        };
        let opaque = sols().all(crate::text::btdf_is_empty);
        Columns {
            mc: sols().any(|s| s.channels.iter().any(|c| c.stderr.is_some())),
            n_brdf: most(|c| c.brdf.len()),
            n_btdf: if opaque { 0 } else { most(|c| c.btdf.len()) },
        }
    }

    fn names(&self) -> Vec<String> {
        let mut h: Vec<String> = SWEEP_QUANTITIES.iter().map(|q| q.to_string()).collect();
        if self.mc {
            h.extend(SWEEP_QUANTITIES.iter().map(|q| format!("stderr_{q}")));
        }
        h.extend((0..self.n_brdf).map(|i| format!("brdf_{i}")));
        h.extend((0..self.n_btdf).map(|i| format!("btdf_{i}")));
        if self.mc {
            h.extend((0..self.n_brdf).map(|i| format!("stderr_brdf_{i}")));
            h.extend((0..self.n_btdf).map(|i| format!("stderr_btdf_{i}")));
        }
        h
    }

    /// The numbers of one channel in the order of [`Columns::names`] (NaN
    /// where a value is missing).
    fn values(&self, c: &km_core::ChannelResult) -> Vec<f64> {
        let mut v =
            vec![c.reflectance, c.reflectance_specular, c.transmittance, c.transmittance_direct];
        v.push(c.absorptance);
        let u = c.stderr.clone().unwrap_or_default();
        if self.mc {
            let se = [
                u.reflectance,
                u.reflectance_specular,
                u.transmittance,
                u.transmittance_direct,
                u.absorptance,
            ];
            v.extend(se.iter().map(|e| e.unwrap_or(f64::NAN)));
        }
        fn list(x: &[f64], n: usize) -> impl Iterator<Item = f64> + '_ {
            (0..n).map(move |i| x.get(i).copied().unwrap_or(f64::NAN))
        }
        v.extend(list(&c.brdf, self.n_brdf));
        v.extend(list(&c.btdf, self.n_btdf));
        if self.mc {
            v.extend(list(u.brdf.as_deref().unwrap_or(&[]), self.n_brdf));
            v.extend(list(u.btdf.as_deref().unwrap_or(&[]), self.n_btdf));
        }
        v
    }
}

/// The rows of `km sweep` (docs/cli.md): the swept values, the channel (for
/// spectral scenes), the five totals, then for Monte Carlo their standard
/// errors, the BRDF/BTDF values at the scene's `[output]` directions
/// (`brdf_I`, `btdf_I`; no BTDF columns when nothing is transmitted) and, for
/// Monte Carlo, theirs; one row per point and channel in grid order, with a
/// header for the table and CSV. Numbers are written as
/// [`crate::text::number`] writes them (round trip, exponent form for small
/// magnitudes).
///
/// ```
/// let text = "[[layer]]\ntau = 1\nalbedo = 0.9\n";
/// let axes = [km::SweepAxis::parse("layer[1].g=0:0.5:2").unwrap()];
/// let pts = km::sweep(text, &[], &axes, &km::Options::new(km::Method::Km)).unwrap();
/// let csv = km::sweep_text(&axes, &pts, km::SweepFormat::Csv);
/// assert_eq!(csv.lines().count(), 3);
/// assert!(csv.starts_with("layer[1].g,reflectance,"));
/// ```
pub fn sweep_text(axes: &[SweepAxis], points: &[SweepPoint], format: SweepFormat) -> String {
    let mut out = String::new();
    let mut line = |l: String| {
        out.push_str(&l);
        out.push('\n');
    };
    let spectral = points.first().is_some_and(|p| p.solution.channels.len() > 1);
    let cols = Columns::of(points);
    let mut header: Vec<String> = axes.iter().map(|a| a.key.clone()).collect();
    if spectral {
        header.push("channel".into());
    }
    let names = cols.names();
    header.extend(names.iter().cloned());
    let column =
        |cells: &[String]| cells.iter().map(|c| format!("{c:>22}")).collect::<Vec<_>>().join(" ");
    match format {
        SweepFormat::Csv => line(header.join(",")),
        SweepFormat::Table => line(column(&header)),
        SweepFormat::Jsonl => {}
    }
    for p in points {
        for (c, ch) in p.solution.channels.iter().enumerate() {
            let nums = cols.values(ch);
            let label = p.solution.labels.get(c).cloned().unwrap_or_default();
            if format == SweepFormat::Jsonl {
                let mut o = serde_json::Map::new();
                for (a, v) in axes.iter().zip(&p.values) {
                    o.insert(a.key.clone(), (*v).into());
                }
                if spectral {
                    o.insert("channel".into(), label.into());
                }
                for (q, v) in names.iter().zip(nums) {
                    o.insert(
                        q.clone(),
                        if v.is_nan() { serde_json::Value::Null } else { v.into() },
                    );
                }
                line(serde_json::Value::Object(o).to_string());
                continue;
            }
            let mut cells: Vec<String> = p.values.iter().map(|v| crate::text::number(*v)).collect();
            if spectral {
                cells.push(label);
            }
            cells.extend(
                nums.iter()
                    .map(|v| if v.is_nan() { String::new() } else { crate::text::number(*v) }),
            );
            line(if format == SweepFormat::Csv { cells.join(",") } else { column(&cells) });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axis(text: &str) -> Vec<f64> {
        SweepAxis::parse(text).unwrap().values()
    }

    /// The decimals of the range, printed shortest (`{}` of `f64`).
    #[test]
    fn values_are_the_decimals_of_the_range() {
        let printed = |v: Vec<f64>| v.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(" ");
        assert_eq!(printed(axis("k=0.1:0.5:5")), "0.1 0.2 0.3 0.4 0.5");
        assert_eq!(printed(axis("k=0:0.9:4")), "0 0.3 0.6 0.9");
        assert_eq!(printed(axis("k=-0.3:0.3:7")), "-0.3 -0.2 -0.1 0 0.1 0.2 0.3");
        assert_eq!(printed(axis("k=1e-3:5e-3:5")), "0.001 0.002 0.003 0.004 0.005");
        assert_eq!(printed(axis("k=10:60:6")), "10 20 30 40 50 60");
        assert_eq!(printed(axis("k=0.7:0.7:1")), "0.7");
    }

    /// A step with no short decimal form keeps the values of the formula.
    #[test]
    fn a_step_without_a_short_decimal_form_keeps_the_formula() {
        for (i, v) in axis("k=0:1:4").into_iter().enumerate() {
            assert_eq!(v, if i == 3 { 1.0 } else { i as f64 / 3.0 }, "{i}");
        }
        // Tiny values: 300 places, still the formula's nearest double.
        let v = axis("k=1e-300:1e-19:3");
        let want = 1e-300 + (1e-19 - 1e-300) * 0.5;
        assert!((v[1] - want).abs() <= 1e-16 * want, "{v:?}");
        assert_eq!((v[0], v[2]), (1e-300, 1e-19));
    }
}
