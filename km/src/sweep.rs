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
    /// assert_eq!(a.values(), vec![0.0, 0.2, 0.4, 0.6000000000000001, 0.8]);
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

    /// The values `start + (stop - start) i / (N - 1)`, `i = 0..N` (`start` when `N = 1`).
    pub fn values(&self) -> Vec<f64> {
        if self.n == 1 {
            return vec![self.start];
        }
        let step = (self.stop - self.start) / (self.n - 1) as f64;
        (0..self.n)
            .map(|i| if i + 1 == self.n { self.stop } else { self.start + step * i as f64 })
            .collect()
    }
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

/// The rows of `km sweep` (docs/cli.md): the swept values, the channel (for
/// spectral scenes), then the five totals, one row per point and channel in
/// grid order, with a header for the table and CSV.
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
    let mut header: Vec<String> = axes.iter().map(|a| a.key.clone()).collect();
    if spectral {
        header.push("channel".into());
    }
    header.extend(SWEEP_QUANTITIES.iter().map(|q| q.to_string()));
    let column = |cells: &[String]| cells.iter().map(|c| format!("{c:>22}")).collect::<String>();
    match format {
        SweepFormat::Csv => line(header.join(",")),
        SweepFormat::Table => line(column(&header)),
        SweepFormat::Jsonl => {}
    }
    for p in points {
        for (c, ch) in p.solution.channels.iter().enumerate() {
            let nums = [
                ch.reflectance,
                ch.reflectance_specular,
                ch.transmittance,
                ch.transmittance_direct,
                ch.absorptance,
            ];
            let label = p.solution.labels.get(c).cloned().unwrap_or_default();
            if format == SweepFormat::Jsonl {
                let mut o = serde_json::Map::new();
                for (a, v) in axes.iter().zip(&p.values) {
                    o.insert(a.key.clone(), (*v).into());
                }
                if spectral {
                    o.insert("channel".into(), label.into());
                }
                for (q, v) in SWEEP_QUANTITIES.iter().zip(nums) {
                    o.insert((*q).into(), v.into());
                }
                line(serde_json::Value::Object(o).to_string());
                continue;
            }
            let mut cells: Vec<String> = p.values.iter().map(|v| v.to_string()).collect();
            if spectral {
                cells.push(label);
            }
            cells.extend(nums.iter().map(|v| v.to_string()));
            line(if format == SweepFormat::Csv { cells.join(",") } else { column(&cells) });
        }
    }
    out
}
