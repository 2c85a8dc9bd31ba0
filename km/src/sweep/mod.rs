//! Sweeps: one scene solved at many values of some of its quantities.
//!
//! [`Quantity`] is the one grammar of sweep keys (typed: a layer's field,
//! the light's angle, an index, the substrate's values), [`apply`] sets
//! values on a parsed scene and [`solve_points`] solves a list of points in
//! parallel under one request budget: Python's `km.solve_many(...,
//! params=...)`. [`sweep`] is `km sweep`: a scene file over a grid of
//! `--set KEY=START:STOP:N` axes, the points in parallel, the rows
//! ([`sweep_text`]) in a fixed order; its points are set on the parsed scene
//! whenever that gives the scene file's own point (see `Grid`).

mod quantity;
mod rows;

use km_core::set::SetEdit;
use km_core::{Scene, Solution};
use rayon::prelude::*;

pub use quantity::{LayerField, Quantity, apply, quantities, solve_points};
pub use rows::{SweepFormat, cells_text, sweep_text};

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
    let grid = Grid::new(text, edits, axes, total);
    // One budget for the whole sweep (eq. L4), before any point is solved:
    // the first point stands for all (they differ in values only).
    if let Ok(scene) = grid.text_scene(&grid.point(0)) {
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
        let point = grid.point(index);
        match grid.scene(&point).and_then(|scene| crate::solve(&scene, options)) {
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

/// The points of a grid sweep and their scenes.
///
/// A point is, by definition, the scene file with the fixed edits and the
/// point's values as `--set` edits of its text ([`Grid::text_scene`]). When
/// every axis is a typed [`Quantity`] the values are set on the parsed scene
/// instead ([`apply`]: no text parsed at each point; docs/benchmarks.md), once
/// that is seen to give the same scene at the grid's first and last points
/// (compared field by field). The check stands for every point: where the
/// scene file derives other values from a swept key (a layer or substrate
/// index defaulting to `ambient.n`, `sigma_s` from `mu_s_prime` and `g`, the
/// lengths of `units`, a preset or particles), or refuses the key in that
/// layer's form (`tau` in a layer of `sigma_a`, `sigma_s`), the two routes
/// differ at every value but the file's own, so at one of two distinct
/// values (an axis with equal ends has one value only). A point whose values
/// the parsed scene refuses is built from the text, so its error is the
/// scene file's.
struct Grid<'a> {
    /// The scene file.
    text: &'a str,
    /// The fixed edits.
    edits: &'a [SetEdit],
    /// The axes.
    axes: &'a [SweepAxis],
    /// The values of each axis.
    values: Vec<Vec<f64>>,
    /// The scene file with the fixed edits, and the axes' quantities, when
    /// the values are set on the parsed scene.
    typed: Option<(Scene, Vec<Quantity>)>,
}

impl<'a> Grid<'a> {
    fn new(text: &'a str, edits: &'a [SetEdit], axes: &'a [SweepAxis], total: usize) -> Self {
        let values = axes.iter().map(SweepAxis::values).collect();
        let mut grid = Grid { text, edits, axes, values, typed: None };
        grid.typed = grid.typed(total);
        grid
    }

    /// The parsed scene and the quantities, when both routes agree at the
    /// first and last points.
    fn typed(&self, total: usize) -> Option<(Scene, Vec<Quantity>)> {
        let q: Vec<Quantity> =
            self.axes.iter().map(|a| a.key.parse().ok()).collect::<Option<_>>()?;
        let base = Scene::from_toml_str_edited(self.text, self.edits).ok()?;
        for index in [0, total - 1] {
            let point = self.point(index);
            let pairs: Vec<(Quantity, f64)> =
                q.iter().copied().zip(point.iter().copied()).collect();
            if apply(&base, &pairs).ok()? != self.text_scene(&point).ok()? {
                return None;
            }
        }
        Some((base, q))
    }

    /// The values of point `index`: its mixed-radix digits, the last axis fastest.
    fn point(&self, index: usize) -> Vec<f64> {
        let mut rest = index;
        let mut point = vec![0.0; self.axes.len()];
        for (k, a) in self.axes.iter().enumerate().rev() {
            point[k] = self.values[k][rest % a.n];
            rest /= a.n;
        }
        point
    }

    /// The scene file with the fixed edits and `point`'s values as edits.
    fn text_scene(&self, point: &[f64]) -> Result<Scene, KmError> {
        let mut all = self.edits.to_vec();
        all.extend(
            self.axes
                .iter()
                .zip(point)
                .map(|(a, v)| SetEdit { key: a.key.clone(), value: format!("{v:?}") }),
        );
        Ok(Scene::from_toml_str_edited(self.text, &all)?)
    }

    /// The scene of `point`: set on the parsed scene when the grid allows it.
    fn scene(&self, point: &[f64]) -> Result<Scene, KmError> {
        if let Some((base, q)) = &self.typed {
            let pairs: Vec<(Quantity, f64)> =
                q.iter().copied().zip(point.iter().copied()).collect();
            if let Ok(scene) = apply(base, &pairs) {
                return Ok(scene);
            }
        }
        self.text_scene(point)
    }
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

    fn example(name: &str) -> String {
        std::fs::read_to_string(format!("{}/../examples/{name}", env!("CARGO_MANIFEST_DIR")))
            .unwrap()
    }

    fn grid<'a>(text: &'a str, axes: &'a [SweepAxis]) -> Grid<'a> {
        let total = axes.iter().map(|a| a.n).product();
        Grid::new(text, &[], axes, total)
    }

    /// The typed keys of the example scenes are set on the parsed scene, and
    /// every point equals the scene file's (the text route), field for field.
    #[test]
    fn typed_points_are_the_scene_files_points() {
        let cases = [
            ("paint-over-primer.toml", "layer[1].thickness=5:40:8", "layer[2].g=0:0.9:4"),
            ("paint-over-primer.toml", "layer[1].sigma_s=0.1:0.5:5", "light.theta_deg=0:60:7"),
            ("fresnel-slab.toml", "layer[1].n=1:2:5", "layer[1].roughness=0:0.5:3"),
            ("seed-three-layers.toml", "layer[1].sigma_a=0:0.3:4", "substrate.albedo=0.2:1:5"),
        ];
        for (file, a, b) in cases {
            let text = example(file);
            let axes = [SweepAxis::parse(a).unwrap(), SweepAxis::parse(b).unwrap()];
            let g = grid(&text, &axes);
            assert!(g.typed.is_some(), "{file} {a} {b}: not typed");
            for i in 0..axes[0].n * axes[1].n {
                let p = g.point(i);
                assert_eq!(g.scene(&p).unwrap(), g.text_scene(&p).unwrap(), "{file} {p:?}");
            }
        }
    }

    /// Where the file derives values from the swept key, or refuses it in
    /// that layer's form, the points are the text's.
    #[test]
    fn derived_or_refused_keys_take_the_text_route() {
        let no_n = "[[layer]]\nsigma_a = 0.1\nsigma_s = 1\nthickness = 1\n";
        let mu = "[[layer]]\nmu_a = 0.1\nmu_s_prime = 1\ng = 0.5\nthickness = 1\n";
        let cm = "units = \"cm\"\n[[layer]]\nmu_a = 0.1\nmu_s = 1\nthickness = 1\n";
        let cases = [
            (no_n, "ambient.n=1:1.5:3"),
            (mu, "layer[1].g=0:0.8:5"),
            (cm, "layer[1].thickness=1:2:3"),
            (no_n, "layer[1].tau=1:2:3"),
        ];
        for (text, a) in cases {
            // The file and its points are valid: the text route answers.
            let axes = [SweepAxis::parse(a).unwrap()];
            let g = grid(text, &axes);
            assert!(g.typed.is_none(), "{a} on {text}: typed");
            if !a.contains("tau") {
                assert!(Scene::from_toml_str(text).is_ok() && g.text_scene(&g.point(2)).is_ok());
            }
        }
        // A typed sweep's answers are those of the scene file's points, bit for bit.
        let text = example("paint-over-primer.toml");
        let opts = Options::new(crate::Method::Km);
        let axes = [SweepAxis::parse("layer[2].g=0:0.9:4").unwrap()];
        let g = grid(&text, &axes);
        assert!(g.typed.is_some());
        for (i, p) in sweep(&text, &[], &axes, &opts).unwrap().iter().enumerate() {
            let one = crate::solve(&g.text_scene(&g.point(i)).unwrap(), &opts).unwrap();
            assert_eq!(p.solution.channels, one.channels, "{i}");
        }
    }
}
