//! Parameter sweeps and batch solves: the binding of `km.solve_many`.
//!
//! A sweep is a base scene and, per point, new values of some of its
//! quantities, named by the sweep keys of `km::sweep::Quantity` (the one
//! grammar `km sweep` parses too): `layer[i].sigma_a | sigma_s | thickness |
//! tau | albedo | g | n | roughness`, `light.theta_deg`, `ambient.n`,
//! `substrate.n | k | albedo | roughness`, 1-based layer numbers. A value
//! applies to every channel. [`solve_sweep`] solves the points by
//! `km::sweep::solve_points` on a pool of `threads` workers.
//!
//! [`solve_many`] solves a list of scenes on a rayon pool (all cores by
//! default), in any order, each by [`crate::engine::solve`]; the answer of
//! each point does not depend on the thread count. [`Columns`] gathers the
//! answers into column arrays (point-major), what `km.solve_many` returns as
//! numpy arrays.

use km::{CoreError, KmError, Scene, Solution};
use rayon::prelude::*;

use crate::engine::{Options, solve};
use crate::error::Error;

/// Solve every scene by `opts`, in parallel on `threads` workers (`None`: all
/// cores), each point by [`crate::engine::solve`] (Monte Carlo points run on
/// one thread each: the batch is the parallel unit). Results are in input order.
///
/// # Errors
/// A thread pool that cannot be built, a raised cancel flag
/// ([`Options::cancel`]: [`Error::Cancelled`]); each point's own error is in
/// its slot.
pub fn solve_many(
    scenes: &[Scene],
    opts: &Options,
    threads: Option<usize>,
) -> Result<Vec<Result<Solution, Error>>, Error> {
    check_batch(scenes, opts)?;
    let mut point = opts.clone();
    if point.method == km::Method::Mc && point.threads.is_none() {
        point.threads = Some(1);
    }
    whole(in_pool(threads, || scenes.par_iter().map(|s| solve(s, &point)).collect::<Vec<_>>())?)
}

/// The results of a batch, or [`Error::Cancelled`] when its cancel flag
/// stopped any point (a batch cut short is no answer).
fn whole(results: Vec<Result<Solution, Error>>) -> Result<Vec<Result<Solution, Error>>, Error> {
    if results.iter().any(|r| matches!(r, Err(Error::Cancelled))) {
        return Err(Error::Cancelled);
    }
    Ok(results)
}

/// The most points of one batch or sweep: 10^5 points of a two-layer scene
/// took 6.5 s and 274 MB resident and aborted under 500 MB of address
/// space (docs/limits.md §8, case 33); half of that fits in 5 s and 500 MB.
pub const MAX_POINTS: usize = 50_000;

/// At most [`MAX_POINTS`] points in one call.
fn check_count(points: usize) -> Result<(), Error> {
    if points > MAX_POINTS {
        return Err(Error::option(
            "scenes",
            format!("{points} points (at most {MAX_POINTS} per call): solve in chunks"),
        ));
    }
    Ok(())
}

/// One budget for a whole batch of scenes (docs/limits.md eq. L4), before
/// any point is solved: at most [`MAX_POINTS`] points, and their summed work
/// (each point's estimate: `km::request_budget::point_work`) within the
/// budget of one solve (a sweep's: `km::sweep::solve_points`).
fn check_batch(scenes: &[Scene], opts: &Options) -> Result<(), Error> {
    check_count(scenes.len())?;
    // Options the method refuses are each point's error, as before.
    let Ok(lib) = opts.library() else { return Ok(()) };
    let Some((_, budget, unit)) =
        scenes.first().and_then(|s| km::request_budget::point_work(s, &lib))
    else {
        return Ok(());
    };
    let total: f64 =
        scenes.iter().map(|s| km::request_budget::point_work(s, &lib).map_or(0.0, |w| w.0)).sum();
    if scenes.len() > 1 && total > budget {
        return Err(over_budget(scenes.len(), total, budget, unit));
    }
    Ok(())
}

/// The refusal of a request over its budget (`km::KmError::RequestTooLarge`)
/// in the words of a Python call.
fn over_budget(points: usize, total: f64, budget: f64, unit: &str) -> Error {
    Error::option(
        "budget",
        format!(
            "{points} points need about {total:.3e} {unit} in all, over the budget of \
             {budget:.3e} for one call: use fewer points, or a coarser grid"
        ),
    )
}

/// Parse sweep keys by the one grammar (`km::sweep::quantities`), a bad key
/// refused as an invalid option named by the key.
///
/// # Errors
/// The first key that is no sweep key.
pub fn quantities(keys: &[String]) -> Result<Vec<km::sweep::Quantity>, Error> {
    km::sweep::quantities(keys).map_err(|e| match e {
        KmError::Scene(CoreError::Scene { key, message, .. }) => Error::option(&key, message),
        other => other.into(),
    })
}

/// Solve the sweep of `base` over `values` (point-major, `keys.len()` values
/// per point) by `km::sweep::solve_points` (each point set on `base`, then
/// solved), on a pool of `threads` workers (`None`: all cores); Monte Carlo
/// points run on one thread each, as in [`solve_many`].
///
/// # Errors
/// A key that is no sweep key, a `values` length that is not a multiple of
/// the number of keys, more than [`MAX_POINTS`] points, the request's budget,
/// a thread pool that cannot be built, a raised cancel flag; each point's own
/// error is in its slot.
pub fn solve_sweep(
    base: &Scene,
    keys: &[String],
    values: &[f64],
    opts: &Options,
    threads: Option<usize>,
) -> Result<Vec<Result<Solution, Error>>, Error> {
    let targets = quantities(keys)?;
    let k = targets.len();
    if k == 0 || !values.len().is_multiple_of(k) {
        return Err(Error::option("params", "need at least one key and one value per key"));
    }
    check_count(values.len() / k)?;
    let mut point = opts.clone();
    if point.method == km::Method::Mc && point.threads.is_none() {
        point.threads = Some(1);
    }
    let (lib, repeat) = match (point.library(), point.settings()) {
        (Ok(lib), Ok(s)) => (lib, s.repeat()),
        // Options the method refuses are each point's error (after the point's values).
        _ => {
            let each = |row: &[f64]| {
                let pairs: Vec<_> = targets.iter().copied().zip(row.iter().copied()).collect();
                km::sweep::apply(base, &pairs).map_err(Error::from).and_then(|s| solve(&s, &point))
            };
            return whole(in_pool(threads, || values.par_chunks(k).map(each).collect())?);
        }
    };
    match in_pool(threads, || km::sweep::solve_points(base, &targets, values, &lib, repeat))? {
        Ok(results) => Ok(results.into_iter().map(|r| r.map_err(Error::from)).collect()),
        Err(KmError::RequestTooLarge { points, total, budget, unit, .. }) => {
            Err(over_budget(points, total, budget, unit))
        }
        Err(e) => Err(e.into()),
    }
}

/// Run `f` on a pool of `threads` workers (`None`: rayon's global pool, all cores).
fn in_pool<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> Result<T, Error> {
    match threads {
        None => Ok(f()),
        Some(0) => Err(Error::option("threads", "must be at least 1")),
        Some(t) => {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .map_err(|e| Error::option("threads", e.to_string()))?;
            Ok(pool.install(f))
        }
    }
}

/// The answers of a batch as column arrays, point-major: a scalar key is
/// `n x channels`, `brdf`/`btdf` are `n x channels x directions`; a point that
/// failed is NaN throughout and its message is in `errors`.
#[derive(Debug, Clone, PartialEq)]
pub struct Columns {
    /// Number of points.
    pub n: usize,
    /// Channels per point.
    pub channels: usize,
    /// Output directions per point.
    pub directions: usize,
    /// `reflectance`, `reflectance_specular`, `transmittance`,
    /// `transmittance_direct`, `absorptance`: each `n * channels` values.
    pub scalars: Vec<(&'static str, Vec<f64>)>,
    /// Smooth BRDF, `n * channels * directions` values (1/sr).
    pub brdf: Vec<f64>,
    /// Smooth BTDF, `n * channels * directions` values (1/sr).
    pub btdf: Vec<f64>,
    /// Standard errors by key (Monte Carlo), each `n * channels` values.
    pub stderr: Vec<(String, Vec<f64>)>,
    /// Error estimates by key (accuracy targets), each `n * channels` values.
    pub error_estimate: Vec<(String, Vec<f64>)>,
    /// Per point: `None`, or the message of its error.
    pub errors: Vec<Option<String>>,
}

/// The keys of [`Columns::scalars`], in order.
pub const SCALAR_KEYS: [&str; 5] =
    ["reflectance", "reflectance_specular", "transmittance", "transmittance_direct", "absorptance"];

impl Columns {
    /// Gather `results` (all of one shape: `channels` channels and
    /// `directions` output directions).
    pub fn gather(results: &[Result<Solution, Error>], channels: usize, directions: usize) -> Self {
        let n = results.len();
        let nc = n * channels;
        let mut scalars: Vec<(&'static str, Vec<f64>)> =
            SCALAR_KEYS.iter().map(|&k| (k, vec![f64::NAN; nc])).collect();
        let mut brdf = vec![f64::NAN; nc * directions];
        let mut btdf = vec![f64::NAN; nc * directions];
        // Keys of the uncertainties (scalar entries only: list entries, e.g.
        // the BRDF's, are per direction), from every successful point.
        let keys = |get: fn(&km::ChannelResult) -> Option<&km::Uncertainty>| {
            let mut keys: Vec<&'static str> = Vec::new();
            for s in results.iter().flatten() {
                for c in &s.channels {
                    for (k, v) in get(c).map(km::Uncertainty::entries).unwrap_or_default() {
                        if matches!(v, km::UncertaintyValue::Number(_)) && !keys.contains(&k) {
                            keys.push(k);
                        }
                    }
                }
            }
            keys
        };
        let se_keys = keys(|c| c.stderr.as_ref());
        let ee_keys = keys(|c| c.error_estimate.as_ref());
        let mut stderr: Vec<(String, Vec<f64>)> =
            se_keys.into_iter().map(|k| (k.to_string(), vec![f64::NAN; nc])).collect();
        let mut error_estimate: Vec<(String, Vec<f64>)> =
            ee_keys.into_iter().map(|k| (k.to_string(), vec![f64::NAN; nc])).collect();
        let mut errors = vec![None; n];
        for (i, r) in results.iter().enumerate() {
            let sol = match r {
                Ok(s) => s,
                Err(e) => {
                    errors[i] = Some(e.to_string());
                    continue;
                }
            };
            for (c, ch) in sol.channels.iter().enumerate().take(channels) {
                let at = i * channels + c;
                let vals = [
                    ch.reflectance,
                    ch.reflectance_specular,
                    ch.transmittance,
                    ch.transmittance_direct,
                    ch.absorptance,
                ];
                for ((_, col), v) in scalars.iter_mut().zip(vals) {
                    col[at] = v;
                }
                for (d, v) in ch.brdf.iter().enumerate().take(directions) {
                    brdf[at * directions + d] = *v;
                }
                for (d, v) in ch.btdf.iter().enumerate().take(directions) {
                    btdf[at * directions + d] = *v;
                }
                for (cols, map) in
                    [(&mut stderr, &ch.stderr), (&mut error_estimate, &ch.error_estimate)]
                {
                    for (k, col) in cols.iter_mut() {
                        if let Some(v) = map.as_ref().and_then(|m| m.get(k)) {
                            col[at] = v;
                        }
                    }
                }
            }
        }
        Columns { n, channels, directions, scalars, brdf, btdf, stderr, error_estimate, errors }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn slab() -> Scene {
        Scene::from_toml_str(
            "[light]\ntheta_deg = 30.0\n[[layer]]\ntau = 1.0\nalbedo = 0.9\ng = 0.5\nn = 1.5\n\
             [output]\ndirections_deg = [[0.0, 0.0], [40.0, 180.0]]\n",
        )
        .unwrap()
    }

    #[test]
    fn bad_keys_are_invalid_options_named_by_the_key() {
        for key in ["layer[0].g", "layer[1].gg", "layer.g", "ambient"] {
            let e = quantities(&[key.to_string()]).unwrap_err();
            assert_eq!(e.key(), Some(key));
            assert!(e.to_string().contains("unknown sweep key"), "{e}");
        }
    }

    #[test]
    fn batch_equals_one_by_one_for_any_thread_count() {
        let base = slab();
        let keys = ["layer[1].tau".to_string()];
        let tau = quantities(&keys).unwrap()[0];
        let scenes: Vec<Scene> = (0..24)
            .map(|i| km::sweep::apply(&base, &[(tau, 0.1 * (i + 1) as f64)]).unwrap())
            .collect();
        let opts = Options::default();
        for threads in [Some(1), Some(2), None] {
            let many = solve_many(&scenes, &opts, threads).unwrap();
            for (s, r) in scenes.iter().zip(&many) {
                assert_eq!(r.as_ref().unwrap().channels, solve(s, &opts).unwrap().channels);
            }
        }
        // The sweep route (values applied on the workers) gives the same answers.
        let values: Vec<f64> = (0..24).map(|i| 0.1 * (i + 1) as f64).collect();
        let swept = solve_sweep(&base, &keys, &values, &opts, Some(2)).unwrap();
        for (a, b) in swept.iter().zip(&solve_many(&scenes, &opts, Some(2)).unwrap()) {
            assert_eq!(a.as_ref().unwrap().channels, b.as_ref().unwrap().channels);
        }
        let cols = Columns::gather(&swept, 1, 2);
        assert_eq!(cols.brdf.len(), 48);
        // A thicker slab lets less through (R need not grow: the light returned
        // by the bottom interface of this n = 1.5 slab is absorbed on the way).
        let t = &cols.scalars[2].1;
        assert!(t.windows(2).all(|w| w[1] < w[0]), "T falls with tau: {t:?}");
    }

    #[test]
    fn a_failed_point_is_nan_with_its_message() {
        let good = slab();
        let bad = Scene::from_toml_str("[[layer]]\ntau = 1.0\nalbedo = 0.9\n").unwrap();
        let opts = Options { method: km::Method::Dipole, ..Default::default() };
        let res = solve_many(&[good, bad], &opts, Some(1)).unwrap();
        let cols = Columns::gather(&res, 1, 0);
        assert!(cols.errors.iter().all(|e| e.is_some()), "{:?}", cols.errors);
        assert!(cols.scalars[0].1.iter().all(|x| x.is_nan()));
    }

    #[test]
    fn options_the_method_refuses_are_each_points_error() {
        let opts = Options { method: km::Method::Km, streams: Some(8), ..Default::default() };
        let keys = ["layer[1].g".to_string()];
        let res = solve_sweep(&slab(), &keys, &[0.1, 2.0], &opts, Some(1)).unwrap();
        // The point's own value is refused first, then the option.
        assert_eq!(res[0].as_ref().unwrap_err().key(), Some("streams"));
        assert_eq!(res[1].as_ref().unwrap_err().key(), Some("layer[1].g"));
    }
}
