//! The driver: batches in parallel (rayon), work budget, progress callback, and
//! the public entry points [`solve`], [`run_shard`] and [`radial_profile`].

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Instant;

use km_core::{Scene, Solution};
use rayon::prelude::*;

use crate::error::McError;
use crate::grid::{GridResult, grid_result};
use crate::options::{CANCEL_CHECK_PHOTONS, McOptions, RadialBins};
use crate::rng::batch_rng;
use crate::shard::{
    BatchRecord, ChannelBatch, ChannelMeta, Merged, PARTIAL_FORMAT, Partial, accumulate,
    accumulate_in_memory, batch_photons, build_solution, fnv1a_hex, shard_batches,
};
use crate::tally::Layout;
use crate::transport::{Counts, Tracer};

/// Trace the whole scene: one [`Solution`] with one result per channel.
///
/// Per channel: totals (reflectance with its specular part, transmittance
/// with its direct part, absorptance), absorptance per layer, BRDF/BTDF at
/// the scene's `directions_deg` (averaged over cones of
/// `opts.bin_half_angle_deg`, eq. B1), and `stderr` for each from batch
/// statistics (eq. T1). `extra["mc"]` holds the settings, the counts
/// (interactions, steps, photons stopped by the step cap and their weight,
/// the bias bound) and, when asked, rings and `Rd(r)`. `seconds` is the
/// tracing time only. Same seed and options give a bit-identical result
/// whatever `opts.threads`.
///
/// Identical to `merge(&[run_shard(scene, opts, 0, 1)?])`.
///
/// # Errors
/// Invalid options ([`McError::Option`]), an invalid scene, a run over its
/// budget ([`McError::TooExpensive`]), a thread pool that cannot be built,
/// a run stopped by its cancel flag ([`McError::Cancelled`]).
///
/// ```
/// use km_montecarlo::{McOptions, solve};
/// let scene = km_core::Scene::from_toml_str("[[layer]]\ntau = 1.0\nalbedo = 0.9\n").unwrap();
/// let sol = solve(&scene, &McOptions { samples: 20_000, ..Default::default() }).unwrap();
/// let c = &sol.channels[0];
/// assert!((c.reflectance + c.transmittance + c.absorptance - 1.0).abs() < 1e-9);
/// ```
pub fn solve(scene: &Scene, opts: &McOptions) -> Result<Solution, McError> {
    let parts = [trace_shard(scene, opts, 0, 1)?];
    let m = accumulate_in_memory(&parts)?;
    Ok(build_solution(&parts, &m))
}

/// [`solve`] with the grid tallies of `opts.grid` ([`crate::McGrid`],
/// docs/montecarlo.md §7): the solution and, per channel, the
/// [`GridResult`].
///
/// # Errors
/// Those of [`solve`]; [`McError::Option`] when `opts.grid` is `None`.
///
/// ```
/// use km_montecarlo::{McGrid, McOptions, solve_grid};
/// let scene = km_core::Scene::from_toml_str("[[layer]]\ntau = 1.0\nalbedo = 0.9\n").unwrap();
/// let grid = McGrid { dz: 0.1, nz: 10, dr: 0.1, nr: 0, na: 0 };
/// let opts = McOptions { samples: 20_000, grid: Some(grid), ..Default::default() };
/// let (sol, g) = solve_grid(&scene, &opts).unwrap();
/// let a: f64 = g[0].a_z.iter().map(|a| a * 0.1).sum();
/// assert!((a - sol.channels[0].absorptance).abs() < 1e-12);
/// ```
pub fn solve_grid(scene: &Scene, opts: &McOptions) -> Result<(Solution, Vec<GridResult>), McError> {
    let parts = [trace_shard(scene, opts, 0, 1)?];
    let m = accumulate_in_memory(&parts)?;
    grids_of(&parts, m)
}

/// The radiance inside the stack of one channel ([`solve_inside`]): per
/// plane and direction (plane-major, `k * directions + j`) the cone average
/// of the radiance per unit incident power (1/sr), its standard error, and
/// per direction the cone's solid angle.
#[derive(Debug, Clone, PartialEq)]
pub struct InsideResult {
    /// Cone averages of the diffuse radiance (the collimated light apart).
    pub radiance: Vec<f64>,
    /// Their standard errors (eq. T1).
    pub radiance_se: Vec<f64>,
    /// Solid angle of each direction's cone, sr.
    pub solid_angle: Vec<f64>,
}

/// [`solve`] with the radiance inside the stack of `opts.inside`
/// ([`crate::options::InsideBins`], docs/field.md §4a): the photons crossing
/// each plane within the cone of a direction score `w / |mu|`, and the sum
/// per photon over the cone's solid angle `Omega` estimates the radiance's
/// cone average, `I = (1/N) sum w / (|mu| Omega)` (eq. D16).
///
/// # Errors
/// Those of [`solve`]; [`McError::Option`] when `opts.inside` is `None`.
///
/// ```
/// use km_montecarlo::{McOptions, options::InsideBins, solve_inside};
/// // A clear slab on a Lambertian floor: up-going radiance rho/pi everywhere.
/// let scene = km_core::Scene::from_toml_str(
///     "[[layer]]\nsigma_a = 0.0\nsigma_s = 0.0\nthickness = 1.0\n\
///      [substrate]\nkind = \"lambertian\"\nalbedo = 0.5\n").unwrap();
/// let inside = InsideBins { depths: vec![0.5], directions: vec![[150.0, 0.0]], half_angle_deg: 5.0 };
/// let opts = McOptions { samples: 20_000, inside: Some(Box::new(inside)), ..Default::default() };
/// let (_, r) = solve_inside(&scene, &opts).unwrap();
/// let want = 0.5 / std::f64::consts::PI;
/// assert!((r[0].radiance[0] - want).abs() < 4.0 * r[0].radiance_se[0]);
/// ```
pub fn solve_inside(
    scene: &Scene,
    opts: &McOptions,
) -> Result<(Solution, Vec<InsideResult>), McError> {
    let Some(bins) = &opts.inside else {
        return Err(McError::Option {
            name: "inside",
            value: "none".into(),
            reason: "the run has no planes inside (set McOptions::inside)",
        });
    };
    let parts = [trace_shard(scene, opts, 0, 1)?];
    let m = accumulate_in_memory(&parts)?;
    let results = inside_of(bins, &parts, &m);
    Ok((build_solution(&parts, &m), results))
}

/// What [`solve_grid_inside`] gives: the solution, per channel the grid,
/// and per channel the radiance inside when the run asked for it.
pub type GridInside = (Solution, Vec<GridResult>, Option<Vec<InsideResult>>);

/// [`solve_grid`] and [`solve_inside`] in one run, when `opts` asks for
/// both (`grid` and `inside`): the photons, and so the tallies, are those
/// of either alone (a tally draws no random number), bit for bit, at the
/// cost of one run.
///
/// # Errors
/// Those of [`solve`]; [`McError::Option`] when `opts.grid` is `None`.
pub fn solve_grid_inside(scene: &Scene, opts: &McOptions) -> Result<GridInside, McError> {
    let parts = [trace_shard(scene, opts, 0, 1)?];
    let m = accumulate_in_memory(&parts)?;
    let inside = opts.inside.as_ref().map(|bins| inside_of(bins, &parts, &m));
    let (solution, grids) = grids_of(&parts, m)?;
    Ok((solution, grids, inside))
}

/// The cone averages of the radiance inside, per channel, from the merged
/// batches of a run with the planes of `bins` (eq. D16).
fn inside_of(
    bins: &crate::options::InsideBins,
    parts: &[Partial],
    m: &Merged,
) -> Vec<InsideResult> {
    let omega: Vec<f64> =
        bins.half_angles().into_iter().map(crate::bins::cone_solid_angle).collect();
    let nd = omega.len();
    m.stats
        .iter()
        .zip(&parts[0].channels)
        .map(|(s, meta)| {
            let l = meta.layout();
            let (mut radiance, mut radiance_se) = (Vec::new(), Vec::new());
            for k in 0..l.inside {
                radiance.push(s.mean(l.inside(k)) / omega[k % nd]);
                radiance_se.push(s.stderr(l.inside(k)) / omega[k % nd]);
            }
            InsideResult { radiance, radiance_se, solid_angle: omega.clone() }
        })
        .collect()
}

/// [`crate::merge`] with the grid tallies: the merged solution and, per
/// channel, the [`GridResult`] (bit-identical to [`solve_grid`]'s).
///
/// # Errors
/// Those of [`crate::merge`]; [`McError::Option`] when the run had no grid.
pub fn merge_grid(parts: &[Partial]) -> Result<(Solution, Vec<GridResult>), McError> {
    let m = accumulate(parts)?;
    grids_of(parts, m)
}

fn grids_of(parts: &[Partial], m: Merged) -> Result<(Solution, Vec<GridResult>), McError> {
    let p0 = &parts[0];
    let Some(grid) = p0.options.grid else {
        return Err(McError::Option {
            name: "grid",
            value: "none".into(),
            reason: "the run has no grid (set McOptions::grid)",
        });
    };
    let grids = m
        .stats
        .iter()
        .zip(&p0.channels)
        .map(|(s, meta)| grid_result(s, &meta.layout().grid(), grid, Layout::R))
        .collect();
    Ok((build_solution(parts, &m), grids))
}

/// Trace shard `index` of `count` of the run `opts` (0-based): the
/// contiguous batches `[floor(index B / count), floor((index + 1) B / count))`
/// of the `B` batches of the whole run, returned as raw sums ([`Partial`]).
/// [`crate::merge`] of all `count` shards gives exactly [`solve`]'s result.
///
/// # Errors
/// [`McError::Shard`] when `count == 0` or `index >= count`, and those of [`solve`].
pub fn run_shard(
    scene: &Scene,
    opts: &McOptions,
    index: u64,
    count: u64,
) -> Result<Partial, McError> {
    trace_shard(scene, opts, index, count).map(Partial::seal)
}

/// [`run_shard`] without the checksum (a part that stays in this process).
fn trace_shard(
    scene: &Scene,
    opts: &McOptions,
    index: u64,
    count: u64,
) -> Result<Partial, McError> {
    opts.validate()?;
    let opts = &opts.resolved();
    if count == 0 || index >= count {
        return Err(McError::Shard { index, count });
    }
    if count > opts.batch_count() {
        return Err(McError::TooManyShards { count, batches: opts.batch_count() });
    }
    crate::sampling::check_phases(scene)?;
    let tracers: Vec<Tracer> = scene.channels().iter().map(|c| Tracer::new(c, opts)).collect();
    let metas: Vec<ChannelMeta> = scene
        .channels()
        .iter()
        .zip(&tracers)
        .map(|(c, t)| {
            let l: Layout = t.layout();
            let n = Tracer::norms(c, opts);
            ChannelMeta {
                layers: l.layers,
                dirs: l.dirs,
                rings: l.rings,
                radial: l.radial,
                cone: n.cone,
                cone_t: n.cone_t,
                ring: n.ring,
                annulus: n.annulus,
                grid_z: l.grid.z,
                grid_r: l.grid.r,
                grid_a: l.grid.a,
                inside: l.inside,
            }
        })
        .collect();
    let batch_size = opts.effective_batch_size();
    let batch_count = opts.batch_count();
    let range = shard_batches(batch_count, index, count);
    // Budgets, before any work: tally memory, then photon steps.
    let sums_per_batch: u128 = metas.iter().map(|m| m.layout().len() as u128).sum();
    let tally_bytes = (range.end - range.start) as u128 * sums_per_batch * 8;
    if tally_bytes > opts.max_tally_bytes as u128 {
        return Err(McError::TooMuchMemory {
            bytes: tally_bytes as f64,
            budget: opts.max_tally_bytes as f64,
            hint: format!(
                "{} batches x {sums_per_batch} sums per batch; use fewer channels, \
                 directions or annuli, or run the batches as shards",
                range.end - range.start
            ),
        });
    }
    let shard_photons = (range.start..range.end)
        .map(|b| batch_photons(opts.samples, batch_size, b) as f64)
        .sum::<f64>();
    preflight(&tracers, opts, shard_photons)?;
    let mine: Vec<u64> = range.collect();

    let t0 = Instant::now();
    let run = || trace_batches(&tracers, opts, batch_size, &mine, t0);
    let batches = match opts.threads {
        None => run()?,
        // One thread: on the calling thread, without a pool of its own (a
        // batch of solves on a pool's workers would otherwise build one pool
        // per point: hundreds of threads, and a crash).
        Some(1) => trace_batches_on(&tracers, opts, batch_size, &mine, t0, false)?,
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| McError::Threads { threads: n, reason: e.to_string() })?
            .install(run)?,
    };
    let seconds = t0.elapsed().as_secs_f64();
    Ok(Partial {
        format: PARTIAL_FORMAT.into(),
        scene_hash: fnv1a_hex(format!("{scene:?}").as_bytes()),
        options: opts.result_key(),
        shard_index: index,
        shard_count: count,
        batch_count,
        batch_size,
        labels: scene.labels().to_vec(),
        channels: metas,
        batches,
        seconds,
        checksum: String::new(),
    })
}

/// Pilot photons per sampled channel, and channels sampled, of [`preflight`].
const PILOT_PHOTONS: u64 = 256;
const PILOT_CHANNELS: usize = 16;
/// A sampled channel's pilot stops once it has taken this many steps.
const PILOT_STEPS: u64 = 200_000;
/// Seed offset of the pilot's streams (never those of the run's batches).
const PILOT_SEED: u64 = 0x7069_6c6f_745f_6d63;

/// Refuse a run whose projected photon steps exceed `opts.max_events`,
/// before any batch is traced.
///
/// First the bound that needs no tracing (every photon takes at least one
/// step: `steps >= photons x channels`); then, when even the step cap
/// (`photons x channels x max_steps_per_photon`) does not prove the run
/// cheap, a pilot: up to [`PILOT_PHOTONS`] photons in each of up to
/// [`PILOT_CHANNELS`] evenly spaced channels, on streams of their own (the
/// run's result does not depend on it), gives the mean steps per photon
/// `s`, and the projection is `photons x channels x s`. The check during the
/// run stays as the safety net for a pilot that underestimates.
fn preflight(tracers: &[Tracer], opts: &McOptions, shard_photons: f64) -> Result<(), McError> {
    let Some(budget) = opts.max_events else {
        return Ok(());
    };
    let nch = tracers.len() as f64;
    let hint = |what: &str| {
        format!(
            "{what}; lower samples, split the run into shards (each shard has its own \
             budget), or raise the budget (km: --budget FACTOR; library: max_events)"
        )
    };
    let floor = shard_photons * nch;
    if floor > budget as f64 {
        return Err(McError::TooExpensive {
            expected_events: floor,
            budget: budget as f64,
            expected_seconds: floor / 7e7,
            hint: hint(&format!(
                "{shard_photons:.3e} photons x {nch} channel(s) take at least one step each"
            )),
        });
    }
    if floor * opts.max_steps_per_photon as f64 <= budget as f64 {
        return Ok(());
    }
    // The pilot.
    let t0 = Instant::now();
    let (steps, photons) = pilot(tracers, opts);
    let per_photon = steps as f64 / photons.max(1) as f64;
    let projected = floor * per_photon;
    if projected > budget as f64 {
        let rate = steps as f64 / t0.elapsed().as_secs_f64().max(1e-9);
        return Err(McError::TooExpensive {
            expected_events: projected,
            budget: budget as f64,
            expected_seconds: projected / rate,
            hint: hint(&format!(
                "a pilot of {photons} photons took {per_photon:.1} steps per photon (a thick, \
                 nearly conservative layer costs about tau^2 steps per photon that crosses it)"
            )),
        });
    }
    Ok(())
}

/// The pilot of [`preflight`]: photon steps and photons traced.
fn pilot(tracers: &[Tracer], opts: &McOptions) -> (u64, u64) {
    let step = (tracers.len() / PILOT_CHANNELS).max(1);
    let (mut steps, mut photons) = (0u64, 0u64);
    for (c, t) in tracers.iter().enumerate().step_by(step).take(PILOT_CHANNELS) {
        let mut rng = batch_rng(opts.seed ^ PILOT_SEED, c as u64, u64::MAX);
        let mut sums = vec![0.0; t.layout().len()];
        let mut s = 0;
        for _ in 0..PILOT_PHOTONS.min(opts.samples) {
            s += t.run_batch(&mut rng, 1, &mut sums).steps;
            photons += 1;
            if s > PILOT_STEPS {
                break;
            }
        }
        steps += s;
    }
    (steps, photons)
}

/// The photon steps a run of `opts` on `scene` is projected to take (eq. L2
/// of docs/limits.md: `photons x channels x` the mean steps per photon of the
/// budget check's pilot, on streams of its own), for budgets over many runs
/// (a sweep or a batch of scenes).
///
/// # Errors
/// Options that [`McOptions::validate`] refuses.
pub fn projected_steps(scene: &Scene, opts: &McOptions) -> Result<f64, McError> {
    opts.validate()?;
    let opts = &opts.resolved();
    let tracers: Vec<Tracer> = scene.channels().iter().map(|c| Tracer::new(c, opts)).collect();
    let (steps, photons) = pilot(&tracers, opts);
    let per_photon = (steps as f64 / photons.max(1) as f64).max(1.0);
    Ok(opts.samples as f64 * tracers.len() as f64 * per_photon)
}

/// Trace the listed batches in parallel; results in the listed order.
fn trace_batches(
    tracers: &[Tracer],
    opts: &McOptions,
    batch_size: u64,
    mine: &[u64],
    t0: Instant,
) -> Result<Vec<BatchRecord>, McError> {
    trace_batches_on(tracers, opts, batch_size, mine, t0, true)
}

/// Trace the listed batches, in parallel on the current rayon pool when
/// `parallel`, else one after the other on the calling thread (the same
/// result: every batch has its own random stream); results in the listed order.
fn trace_batches_on(
    tracers: &[Tracer],
    opts: &McOptions,
    batch_size: u64,
    mine: &[u64],
    t0: Instant,
    parallel: bool,
) -> Result<Vec<BatchRecord>, McError> {
    let total = mine.len() as u64;
    // Progress is reported in photons (each traced in every channel).
    let photons_total: u64 = mine.iter().map(|&b| batch_photons(opts.samples, batch_size, b)).sum();
    let photons_done = AtomicU64::new(0);
    let steps_done = AtomicU64::new(0);
    let batches_done = AtomicU64::new(0);
    let abort = AtomicBool::new(false);
    let refusal: Mutex<Option<McError>> = Mutex::new(None);
    let threads = if parallel { rayon::current_num_threads().max(1) as f64 } else { 1.0 };

    let cancelled = || {
        let c = km_core::cancel::cancelled(opts.cancel.as_ref());
        if c {
            abort.store(true, Ordering::Relaxed);
        }
        c
    };
    let one = |&b: &u64| {
        if abort.load(Ordering::Relaxed) || cancelled() {
            return None;
        }
        let photons = batch_photons(opts.samples, batch_size, b);
        let mut channels = Vec::with_capacity(tracers.len());
        let mut steps = 0;
        for (c, t) in tracers.iter().enumerate() {
            let batch = trace_channel(t, opts, c, b, photons, &cancelled)?;
            steps += batch.steps;
            channels.push(batch);
        }
        // Work budget: refuse as soon as the count or its projection exceeds it.
        let s = steps_done.fetch_add(steps, Ordering::Relaxed) + steps;
        let d = batches_done.fetch_add(1, Ordering::Relaxed) + 1;
        if let Some(budget) = opts.max_events {
            let projected = s as f64 * total as f64 / d as f64;
            if s > budget || (d >= total.min(4) && projected > budget as f64) {
                let secs = t0.elapsed().as_secs_f64() * threads;
                let rate = s as f64 / secs.max(1e-9);
                let mut r = refusal.lock().unwrap_or_else(|e| e.into_inner());
                if r.is_none() {
                    let per_photon = s as f64 / (d * batch_size) as f64 / tracers.len() as f64;
                    *r = Some(too_expensive(projected, budget, rate, per_photon, d));
                }
                abort.store(true, Ordering::Relaxed);
                return None;
            }
        }
        if let Some(p) = &opts.progress {
            p.report(photons_done.fetch_add(photons, Ordering::Relaxed) + photons, photons_total);
        }
        Some(BatchRecord { index: b, photons, channels })
    };
    let records: Vec<Option<BatchRecord>> =
        if parallel { mine.par_iter().map(one).collect() } else { mine.iter().map(one).collect() };
    if let Some(e) = refusal.into_inner().unwrap_or_else(|e| e.into_inner()) {
        return Err(e);
    }
    // A batch left out was left out for the cancel flag (the budget's abort
    // returned above).
    if records.iter().any(Option::is_none) {
        return Err(McError::Cancelled);
    }
    Ok(records.into_iter().flatten().collect())
}

/// Trace batch `b` (`photons` photons) of channel `c` with tracer `t` on
/// its own random stream; `None` when `cancelled` stops it.
fn trace_channel(
    t: &Tracer,
    opts: &McOptions,
    c: usize,
    b: u64,
    photons: u64,
    cancelled: &impl Fn() -> bool,
) -> Option<ChannelBatch> {
    let mut rng = batch_rng(opts.seed, c as u64, b);
    let mut sums = vec![0.0; t.layout().len()];
    // In pieces of CANCEL_CHECK_PHOTONS when a flag may stop the run:
    // the same photons on the same stream into the same sums, so the
    // same result bit for bit.
    let piece = if opts.cancel.is_some() { CANCEL_CHECK_PHOTONS } else { photons };
    let mut k = Counts::default();
    let mut left = photons;
    while left > 0 {
        if cancelled() {
            return None;
        }
        let n = left.min(piece);
        k += t.run_batch(&mut rng, n, &mut sums);
        left -= n;
    }
    t.finish_batch(&mut sums);
    Some(ChannelBatch { sums, interactions: k.interactions, steps: k.steps, capped: k.capped })
}

/// The work budget's refusal: `projected` steps against `budget` at `rate`
/// steps per second, `per_photon` steps per photon measured over `d` batches.
fn too_expensive(projected: f64, budget: u64, rate: f64, per_photon: f64, d: u64) -> McError {
    McError::TooExpensive {
        expected_events: projected,
        budget: budget as f64,
        expected_seconds: projected / rate,
        hint: format!(
            "measured {per_photon:.1} steps per photon over {d} batch(es); lower \
                 samples, split the run into shards, or raise the budget (km: \
                 --budget FACTOR; library: max_events) (a thick, nearly \
                 conservative layer costs about tau^2 steps per photon that \
                 crosses it)",
        ),
    }
}

/// The radially resolved diffuse reflectance of a pencil beam entering at the origin.
#[derive(Debug, Clone, PartialEq)]
pub struct RadialProfile {
    /// Annulus width, length unit of the scene.
    pub dr: f64,
    /// Mid radius of each annulus, `(i + 1/2) dr`.
    pub r: Vec<f64>,
    /// Per channel, `Rd(r_i)` in 1/length^2 (eq. R1 of docs/montecarlo.md).
    pub rd: Vec<Vec<f64>>,
    /// Per channel, the standard error of each `Rd(r_i)` (eq. T1).
    pub stderr: Vec<Vec<f64>>,
    /// Per channel, the diffuse reflectance escaping beyond the last annulus.
    pub overflow: Vec<f64>,
    /// The whole solution of the run (totals, BRDF, ...).
    pub solution: Solution,
}

/// `Rd(r)` as MCML (Wang, Jacques & Zheng 1995, eq. 4.9): the scattered
/// reflected weight escaping in annulus `i` divided by `N` and its area
/// `2 pi r_i dr` (`r_i = (i + 1/2) dr`):
///
/// `Rd(r_i) = W_i / (N 2 pi r_i dr)`   (eq. R1)
///
/// The light is the scene's, entering the top surface at the origin: a
/// pencil beam at the scene's incidence (`r` is measured from the point of
/// entry, and the annuli average over the azimuth, so an oblique beam's
/// profile, shifted forward, is averaged around the entry point), or a
/// diffuse point source.
///
/// # Errors
/// Those of [`solve`].
pub fn radial_profile(
    scene: &Scene,
    opts: &McOptions,
    bins: RadialBins,
) -> Result<RadialProfile, McError> {
    let opts = McOptions { radial: Some(bins), ..opts.clone() };
    let parts = [trace_shard(scene, &opts, 0, 1)?];
    let m = accumulate_in_memory(&parts)?;
    let solution = build_solution(&parts, &m);
    let meta = &parts[0].channels;
    let mut rd = Vec::new();
    let mut se = Vec::new();
    let mut overflow = Vec::new();
    for (c, s) in m.stats.iter().enumerate() {
        let l = meta[c].layout();
        rd.push((0..bins.count).map(|k| s.mean(l.radial(k)) / meta[c].annulus[k]).collect());
        se.push((0..bins.count).map(|k| s.stderr(l.radial(k)) / meta[c].annulus[k]).collect());
        overflow.push(s.mean(Layout::RD_OVERFLOW));
    }
    Ok(RadialProfile {
        dr: bins.dr,
        r: (0..bins.count).map(|i| (i as f64 + 0.5) * bins.dr).collect(),
        rd,
        stderr: se,
        overflow,
        solution,
    })
}
