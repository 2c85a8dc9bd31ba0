//! Shards and their merge: the tally of a run split over processes or
//! machines, combined into exactly (bit for bit) the result of a single run.
//!
//! A run of `samples` photons is cut into `B = ceil(samples / batch_size)`
//! batches; batch `b` holds `min(batch_size, samples - b batch_size)` photons
//! and draws from its own generator seeded from `(seed, channel, b)`. Shard
//! `i` of `N` traces the contiguous batches `[floor(i B / N), floor((i+1) B / N))`
//! and stores each batch's raw sums ([`Partial`]). [`merge`] checks the parts,
//! orders all batches by index and accumulates them exactly as a single run
//! does, so the [`Solution`] is bit-identical (only `seconds` differs: it is
//! the sum of the shards' tracing times).
//!
//! Integrity: a [`Partial`] carries an FNV-1a checksum of its canonical JSON
//! serialisation ([`Partial::content_checksum`]), and [`merge`] re-checks every part
//! before it allocates anything from a number in it: the checksum, the
//! batching (`batch_count = ceil(samples / batch_size)`, no more shards than
//! batches, every shard's batches present), the layout lengths against the
//! vectors actually stored, every sum finite, and per batch the balance
//! `R + T + A + lost = photons` with `R, T, lost >= 0` and, for the analog
//! estimator, `A >= 0` (eq. S1 below). The
//! checksum detects corruption (a flipped bit, an edited number), not a
//! forgery: anyone can recompute it.
//!
//! `R + T + A + lost = n_b` per batch within `1e-9 n_b`   (eq. S1)
//!
//! holds photon by photon in the tracer (roulette outcomes are booked as
//! absorption, docs/montecarlo.md §4), so a batch's sums meet it up to the
//! rounding of `n_b` additions (relative 1e-16 each; 1e-9 leaves a wide margin).

use std::collections::BTreeSet;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use km_core::{ChannelResult, Solution};
use serde::{Deserialize, Serialize};

use crate::error::McError;
use crate::options::McOptions;
use crate::stats::BatchStats;
use crate::tally::Layout;

/// Format tag of [`Partial`] files.
pub const PARTIAL_FORMAT: &str = "km-montecarlo-partial-2";

/// Default largest shard file read by [`read_partial`], bytes (256 MiB;
/// raise with the environment variable `KM_MAX_SHARD_BYTES`). A shard of the
/// default 1000 batches with 100 layout entries per channel is about 2 MB
/// per channel.
pub const DEFAULT_MAX_SHARD_BYTES: u64 = 256 << 20;

/// Exact `f64` vectors in text formats: stored as their IEEE-754 bit patterns.
mod bits {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    pub fn serialize<S: Serializer>(v: &[f64], s: S) -> Result<S::Ok, S::Error> {
        v.iter().map(|x| x.to_bits()).collect::<Vec<u64>>().serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
        Ok(Vec::<u64>::deserialize(d)?.into_iter().map(f64::from_bits).collect())
    }
}

/// What one channel needs to turn sums into results: its tally layout and
/// the bin normalisers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChannelMeta {
    /// Number of layers.
    pub layers: usize,
    /// Number of output directions.
    pub dirs: usize,
    /// Number of azimuthal rings.
    pub rings: usize,
    /// Number of radial annuli.
    pub radial: usize,
    /// Solid angle of each direction's reflection cone (eq. B1, B2'), sr.
    #[serde(with = "bits")]
    pub cone: Vec<f64>,
    /// Solid angle of each direction's transmission cone (eq. B1, B2'), sr.
    #[serde(with = "bits")]
    pub cone_t: Vec<f64>,
    /// Projected solid angle of each ring (eq. B3), sr.
    #[serde(with = "bits")]
    pub ring: Vec<f64>,
    /// Area of each annulus, length^2.
    #[serde(with = "bits")]
    pub annulus: Vec<f64>,
    /// Grid depth bins, overflow included (0: no grid; [`crate::McGrid`]).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub grid_z: usize,
    /// Grid radial bins, overflow included.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub grid_r: usize,
    /// Grid angle bins.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub grid_a: usize,
    /// Planes times directions of the radiance inside ([`crate::options::InsideBins`]).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub inside: usize,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

impl ChannelMeta {
    pub(crate) fn layout(&self) -> Layout {
        Layout {
            layers: self.layers,
            dirs: self.dirs,
            rings: self.rings,
            radial: self.radial,
            grid: crate::grid::GridDims { z: self.grid_z, r: self.grid_r, a: self.grid_a },
            inside: self.inside,
        }
    }
}

/// The raw tallies of one batch of one channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChannelBatch {
    /// Weight sums in the channel's tally layout (bit-exact in JSON).
    #[serde(with = "bits")]
    pub sums: Vec<f64>,
    /// Interactions (scattering or absorption events).
    pub interactions: u64,
    /// Steps (interactions plus interface meetings).
    pub steps: u64,
    /// Photons stopped by the step cap.
    pub capped: u64,
}

/// The raw tallies of one batch (all channels).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BatchRecord {
    /// Batch index in the whole run.
    pub index: u64,
    /// Photons in the batch (per channel).
    pub photons: u64,
    /// One entry per channel.
    pub channels: Vec<ChannelBatch>,
}

/// The partial tally of one shard: enough to recompute means and standard
/// errors exactly. Serialise it with serde (e.g. `serde_json`); `f64` sums are
/// stored as bit patterns so any text format keeps them exact.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Partial {
    /// Always [`PARTIAL_FORMAT`].
    pub format: String,
    /// FNV-1a hash of the scene (hex), to refuse parts of different scenes.
    pub scene_hash: String,
    /// The options that determine the result (threads and progress cleared).
    pub options: McOptions,
    /// This shard's index, `0 <= index < count`.
    pub shard_index: u64,
    /// Number of shards.
    pub shard_count: u64,
    /// Batches in the whole run.
    pub batch_count: u64,
    /// Photons per batch (the last batch may hold fewer).
    pub batch_size: u64,
    /// Channel labels of the scene.
    pub labels: Vec<String>,
    /// Per channel, layout and normalisers.
    pub channels: Vec<ChannelMeta>,
    /// This shard's batches, in index order.
    pub batches: Vec<BatchRecord>,
    /// Tracing wall time of this shard, seconds.
    pub seconds: f64,
    /// FNV-1a 64-bit hash (16 hex digits) of every other field's canonical
    /// JSON ([`Partial::content_checksum`]); verified by [`merge`].
    pub checksum: String,
}

/// A writer that only hashes (FNV-1a 64), for checksums without a copy.
struct FnvWriter(u64);

impl Write for FnvWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        for &b in buf {
            self.0 ^= b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Partial {
    /// The checksum of this part: FNV-1a 64 (Fowler, Noll & Vo) of the JSON
    /// serialisation of every field but `checksum`, in declaration order,
    /// with `seconds` as its bit pattern; 16 hex digits.
    pub fn content_checksum(&self) -> String {
        let mut w = FnvWriter(0xcbf2_9ce4_8422_2325);
        let fields = (
            &self.format,
            &self.scene_hash,
            &self.options,
            self.shard_index,
            self.shard_count,
            self.batch_count,
            self.batch_size,
            &self.labels,
            &self.channels,
            &self.batches,
            self.seconds.to_bits(),
        );
        // Serialising plain data into a hashing writer cannot fail.
        let _ = serde_json::to_writer(&mut w, &fields);
        format!("{:016x}", w.0)
    }

    /// Set [`Partial::checksum`] from the content.
    pub fn seal(mut self) -> Partial {
        self.checksum = self.content_checksum();
        self
    }
}

/// Read one shard file: a regular file of at most `KM_MAX_SHARD_BYTES`
/// (default [`DEFAULT_MAX_SHARD_BYTES`]) holding a [`Partial`] in JSON.
/// Only the parse is done here; [`merge`] checks the content.
///
/// # Errors
/// [`McError::Merge`] naming the file: not a regular file, too large, not
/// readable, not a shard file.
pub fn read_partial(path: &Path) -> Result<Partial, McError> {
    let max = std::env::var("KM_MAX_SHARD_BYTES")
        .ok()
        .and_then(|v| v.trim().parse::<u64>().ok())
        .filter(|&v| v > 0)
        .unwrap_or(DEFAULT_MAX_SHARD_BYTES);
    let shown = path.display();
    let fail = |why: String| McError::Merge(format!("{shown}: {why}"));
    let meta = std::fs::metadata(path).map_err(|e| fail(format!("cannot read: {e}")))?;
    if !meta.is_file() {
        return Err(fail("not a regular file".into()));
    }
    if meta.len() > max {
        return Err(fail(format!(
            "{} bytes, over the limit of {max} bytes (KM_MAX_SHARD_BYTES)",
            meta.len()
        )));
    }
    let f = std::fs::File::open(path).map_err(|e| fail(format!("cannot read: {e}")))?;
    let mut text = String::new();
    f.take(max + 1).read_to_string(&mut text).map_err(|e| fail(format!("cannot read: {e}")))?;
    if text.len() as u64 > max {
        return Err(fail(format!("over the limit of {max} bytes (KM_MAX_SHARD_BYTES)")));
    }
    parse_partial(&text).map_err(|e| fail(e.to_string()))
}

/// Parse the JSON of a [`Partial`] (no content checks; see [`merge`]).
///
/// # Errors
/// [`McError::Merge`] with serde's message when the text is not a shard file.
pub fn parse_partial(text: &str) -> Result<Partial, McError> {
    serde_json::from_str(text).map_err(|e| McError::Merge(format!("not a km shard file: {e}")))
}

/// Read the shard files and merge them ([`read_partial`], [`merge`]);
/// refusals name the file.
///
/// # Errors
/// Those of [`read_partial`] and [`merge`].
pub fn merge_files(paths: &[PathBuf]) -> Result<Solution, McError> {
    let mut parts = Vec::with_capacity(paths.len());
    for p in paths {
        parts.push(read_partial(p)?);
    }
    merge(&parts).map_err(|e| match e {
        McError::Merge(m) => {
            // "part K ..." becomes "part K (FILE) ...".
            let named = paths.iter().enumerate().rev().fold(m, |m, (k, p)| {
                m.replace(
                    &format!("part {} ", k + 1),
                    &format!("part {} ({}) ", k + 1, p.display()),
                )
            });
            McError::Merge(named)
        }
        other => other,
    })
}

/// The batch indices of shard `index` of `count` among `batches` batches.
pub fn shard_batches(batches: u64, index: u64, count: u64) -> std::ops::Range<u64> {
    let lo = (index as u128 * batches as u128 / count as u128) as u64;
    let hi = ((index as u128 + 1) * batches as u128 / count as u128) as u64;
    lo..hi
}

/// Photons in batch `b` of a run.
pub(crate) fn batch_photons(samples: u64, batch_size: u64, b: u64) -> u64 {
    batch_size.min(samples - b * batch_size)
}

/// FNV-1a 64-bit hash (Fowler, Noll & Vo) of a byte string, as 16 hex digits.
pub(crate) fn fnv1a_hex(bytes: &[u8]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    format!("{h:016x}")
}

fn mismatch(what: &str, i: usize) -> McError {
    McError::Merge(format!("part {} differs from part 1 in {what}", i + 1))
}

/// The checks of one part on its own, before anything is allocated from its numbers.
fn check_part(i: usize, p: &Partial, verify_checksum: bool) -> Result<(), McError> {
    let bad = |what: String| {
        McError::Merge(format!(
            "part {} (shard {}/{}) is damaged: {what}",
            i + 1,
            p.shard_index,
            p.shard_count
        ))
    };
    if p.format != PARTIAL_FORMAT {
        return Err(McError::Merge(format!(
            "part {} has format {:?}, expected {PARTIAL_FORMAT:?} (shards of older versions \
             cannot be verified: run them again)",
            i + 1,
            p.format
        )));
    }
    // The checksum guards files; a part that never left the process has none.
    let sum = if verify_checksum { p.content_checksum() } else { p.checksum.clone() };
    if p.checksum != sum {
        return Err(bad(format!("checksum {:?}, content hashes to {sum:?}", p.checksum)));
    }
    p.options.validate().map_err(|e| bad(format!("options: {e}")))?;
    // Batching: the run's own, every shard non-empty.
    if p.batch_size != p.options.effective_batch_size() || p.batch_count != p.options.batch_count()
    {
        return Err(bad(format!(
            "batching {} x {} does not match samples = {}",
            p.batch_count, p.batch_size, p.options.samples
        )));
    }
    if p.batch_count == 0 || p.shard_count == 0 || p.shard_count > p.batch_count {
        return Err(bad(format!(
            "{} shard(s) of a run of {} batch(es): need 1 <= shards <= batches",
            p.shard_count, p.batch_count
        )));
    }
    if p.shard_index >= p.shard_count {
        return Err(McError::Merge(format!(
            "part {} claims shard {} of {}",
            i + 1,
            p.shard_index,
            p.shard_count
        )));
    }
    if !(p.seconds.is_finite() && p.seconds >= 0.0) {
        return Err(bad(format!("seconds = {}", p.seconds)));
    }
    if p.channels.is_empty() || p.labels.len() != p.channels.len() {
        return Err(bad(format!("{} channel(s), {} label(s)", p.channels.len(), p.labels.len())));
    }
    // Layouts: the counts against the vectors actually stored (a count is
    // never used to allocate before it has matched real data).
    for (c, m) in p.channels.iter().enumerate() {
        let lens_ok = m.cone.len() == m.dirs
            && m.cone_t.len() == m.dirs
            && m.ring.len() == m.rings
            && m.annulus.len() == m.radial
            && m.layers >= 1;
        let norms_ok = [&m.cone, &m.cone_t, &m.ring, &m.annulus]
            .iter()
            .all(|v| v.iter().all(|x| x.is_finite() && *x > 0.0));
        let want_grid = p.options.grid.map(|g| g.dims()).unwrap_or_default();
        let want_inside =
            p.options.inside.as_ref().map_or(0, |b| b.depths.len() * b.directions.len());
        let grid_ok = m.layout().grid == want_grid && m.inside == want_inside;
        let len = layout_len(m);
        let stored = p.batches.first().and_then(|b| b.channels.get(c)).map(|cb| cb.sums.len());
        if !lens_ok || !norms_ok || !grid_ok || len.is_none() || len != stored {
            return Err(bad(format!(
                "channel {c}: layout (layers {}, directions {}, rings {}, annuli {}) does not \
                 match the stored vectors",
                m.layers, m.dirs, m.rings, m.radial
            )));
        }
    }
    // The batches of the shard, complete and in order.
    let want = shard_batches(p.batch_count, p.shard_index, p.shard_count);
    if p.batches.len() as u64 != want.end - want.start {
        return Err(bad(format!(
            "{} batch(es) stored, the shard has {}",
            p.batches.len(),
            want.end - want.start
        )));
    }
    let analog = p.options.estimator == crate::options::Estimator::Analog;
    for (b, w) in p.batches.iter().zip(want) {
        let photons = batch_photons(p.options.samples, p.batch_size, w);
        if b.index != w || b.photons != photons || b.channels.len() != p.channels.len() {
            return Err(bad(format!("batch {} is not batch {w} of the run", b.index)));
        }
        for (c, (cb, m)) in b.channels.iter().zip(&p.channels).enumerate() {
            check_batch(cb, m, photons, analog, p.options.max_steps_per_photon)
                .map_err(|why| bad(format!("batch {w}, channel {c}: {why}")))?;
        }
    }
    Ok(())
}

/// Length of a channel's vector of sums, `None` on overflow.
fn layout_len(m: &ChannelMeta) -> Option<usize> {
    let two = |x: usize| x.checked_mul(2);
    8usize
        .checked_add(m.layers)?
        .checked_add(two(m.dirs)?)?
        .checked_add(two(m.rings)?)?
        .checked_add(m.radial)?
        .checked_add(
            crate::grid::GridDims { z: m.grid_z, r: m.grid_r, a: m.grid_a }.checked_len()?,
        )?
        .checked_add(m.inside)
}

/// One batch of one channel: finite sums, non-negative escapes, balance (eq. S1).
fn check_batch(
    cb: &ChannelBatch,
    m: &ChannelMeta,
    photons: u64,
    analog: bool,
    max_steps: u64,
) -> Result<(), String> {
    let l = m.layout();
    if cb.sums.len() != l.len() {
        return Err(format!("{} sums, the layout has {}", cb.sums.len(), l.len()));
    }
    if let Some(k) = cb.sums.iter().position(|x| !x.is_finite()) {
        return Err(format!("sum {k} is {}", cb.sums[k]));
    }
    let n = photons as f64;
    // Rounding of n additions of weights <= 1 (eq. S1's margin).
    let eps = 1e-9 * n + 1e-12;
    let s = &cb.sums;
    // Escaping and lost weight, and every bin, are sums of positive weights.
    let mut positive: Vec<usize> =
        vec![Layout::R, Layout::R_SPEC, Layout::T, Layout::T_DIRECT, Layout::LOST];
    positive.push(Layout::RD_OVERFLOW);
    // ... except the grid's absorption bins, which hold the roulette's
    // signed bookings (those come last).
    let end = if l.grid.z > 0 { l.grid().a_z } else { l.len() };
    positive.extend(l.brdf(0)..end);
    if l.grid.z > 0 {
        // The radiance inside comes after the grid.
        positive.extend(l.inside(0)..l.len());
    }
    if let Some(&k) = positive.iter().find(|&&k| s[k] < 0.0) {
        return Err(format!("sum {k} = {} is negative", s[k]));
    }
    let (r, t, a, lost) = (s[Layout::R], s[Layout::T], s[Layout::A], s[Layout::LOST]);
    if s[Layout::R_SPEC] > r + eps || s[Layout::T_DIRECT] > t + eps {
        return Err("a specular or direct part exceeds its total".into());
    }
    // Analog absorption is a count of whole photons, >= 0. With survival
    // biasing a won roulette raises a weight from below the threshold to
    // threshold / survival, and the gain is booked as negative absorption (so
    // that eq. S1 holds photon by photon): a batch's absorbed weight can be
    // slightly negative (-9e-4 of 20 photons was seen at grazing incidence on
    // a weakly absorbing Fresnel slab), so only its balance is checked.
    if analog && a < -eps {
        return Err(format!("absorbed weight {a} is negative (analog estimator)"));
    }
    if (r + t + a + lost - n).abs() > eps {
        return Err(format!(
            "R + T + A + lost = {r} + {t} + {a} + {lost} = {}, not the batch's {photons} \
             photons (eq. S1)",
            r + t + a + lost
        ));
    }
    let steps_max = photons.saturating_mul(max_steps);
    if cb.capped > photons || cb.steps > steps_max || cb.interactions > cb.steps {
        return Err(format!(
            "counters (interactions {}, steps {}, capped {}) impossible for {photons} photons",
            cb.interactions, cb.steps, cb.capped
        ));
    }
    Ok(())
}

/// Check that `parts` are the complete set of shards of one run.
fn validate(parts: &[Partial], verify_checksum: bool) -> Result<(), McError> {
    let Some(p0) = parts.first() else {
        return Err(McError::Merge("no parts given".into()));
    };
    for (i, p) in parts.iter().enumerate() {
        check_part(i, p, verify_checksum)?;
        if p.scene_hash != p0.scene_hash {
            return Err(mismatch("the scene (hash)", i));
        }
        if p.options.seed != p0.options.seed {
            return Err(mismatch(&format!("seed ({} vs {})", p.options.seed, p0.options.seed), i));
        }
        if p.options.samples != p0.options.samples {
            return Err(mismatch(
                &format!("samples ({} vs {})", p.options.samples, p0.options.samples),
                i,
            ));
        }
        if p.options != p0.options {
            return Err(mismatch("options (estimator, bins, batch size, caps)", i));
        }
        if p.shard_count != p0.shard_count {
            return Err(mismatch(
                &format!("shard count ({} vs {})", p.shard_count, p0.shard_count),
                i,
            ));
        }
        if (p.batch_count, p.batch_size) != (p0.batch_count, p0.batch_size) {
            return Err(mismatch("batching", i));
        }
        if p.labels != p0.labels || p.channels != p0.channels {
            return Err(mismatch("channels", i));
        }
    }
    if parts.len() as u64 > p0.shard_count {
        return Err(McError::Merge(format!(
            "{} parts given for a run of {} shard(s)",
            parts.len(),
            p0.shard_count
        )));
    }
    let mut seen = BTreeSet::new();
    for p in parts {
        if !seen.insert(p.shard_index) {
            return Err(McError::Merge(format!(
                "shard {}/{} given twice",
                p.shard_index, p.shard_count
            )));
        }
    }
    let missing: Vec<String> =
        (0..p0.shard_count).filter(|i| !seen.contains(i)).map(|i| i.to_string()).collect();
    if !missing.is_empty() {
        return Err(McError::Merge(format!(
            "missing shard(s) {} of {} (0-based)",
            missing.join(", "),
            p0.shard_count
        )));
    }
    Ok(())
}

/// Per channel batch statistics, plus the totals of the counters.
pub(crate) struct Merged {
    pub stats: Vec<BatchStats>,
    pub interactions: Vec<u64>,
    pub steps: Vec<u64>,
    pub capped: Vec<u64>,
}

/// Accumulate all batches in index order (the one code path of single runs and merges).
pub(crate) fn accumulate(parts: &[Partial]) -> Result<Merged, McError> {
    accumulate_with(parts, true)
}

/// [`accumulate`] of parts traced in this process (not read from files):
/// every check but the checksum, which only guards a file's content
/// (hashing the JSON of every batch sum cost 7 % of a gridded run).
pub(crate) fn accumulate_in_memory(parts: &[Partial]) -> Result<Merged, McError> {
    accumulate_with(parts, false)
}

fn accumulate_with(parts: &[Partial], verify_checksum: bool) -> Result<Merged, McError> {
    validate(parts, verify_checksum)?;
    let p0 = &parts[0];
    let mut order: Vec<&Partial> = parts.iter().collect();
    order.sort_by_key(|p| p.shard_index);
    let nch = p0.channels.len();
    let mut m = Merged {
        stats: p0.channels.iter().map(|c| BatchStats::new(c.layout().len())).collect(),
        interactions: vec![0; nch],
        steps: vec![0; nch],
        capped: vec![0; nch],
    };
    for p in order {
        for b in &p.batches {
            for (c, cb) in b.channels.iter().enumerate() {
                m.stats[c].push(b.photons, &cb.sums);
                m.interactions[c] = m.interactions[c].saturating_add(cb.interactions);
                m.steps[c] = m.steps[c].saturating_add(cb.steps);
                m.capped[c] = m.capped[c].saturating_add(cb.capped);
            }
        }
    }
    Ok(m)
}

/// Combine the shards of a run into its [`Solution`], bit-identical to a
/// single run with the same options (except `seconds`, the sum of the shards').
///
/// # Errors
/// [`McError::Merge`] when the parts are empty, of different scenes, seeds,
/// sample counts or options, duplicated, incomplete, or tampered with.
pub fn merge(parts: &[Partial]) -> Result<Solution, McError> {
    let m = accumulate(parts)?;
    Ok(build_solution(parts, &m))
}

/// `f(idx(k)) / norm[k]` for `k < n` (`norm` 1 where it has no entry): a
/// tally's bins per direction, layer, ring or annulus, divided by their
/// solid angle or area.
fn per(idx: &dyn Fn(usize) -> usize, n: usize, norm: &[f64], f: &dyn Fn(usize) -> f64) -> Vec<f64> {
    (0..n).map(|k| f(idx(k)) / norm.get(k).copied().unwrap_or(1.0)).collect()
}

/// One channel's values and standard errors from its merged batch statistics.
fn channel_result(s: &BatchStats, l: &Layout, meta: &ChannelMeta) -> ChannelResult {
    let mean = |j: usize| s.mean(j);
    // A number the same in every batch to 9 digits (the mirror reflection
    // of a smooth top surface) has a standard error of rounding noise: 0.
    let se = |j: usize| {
        let e = s.stderr(j);
        if e <= crate::EXACT_RELATIVE_STDERR * s.mean(j).abs() { 0.0 } else { e }
    };
    let ones = vec![1.0; l.layers];
    let err = km_core::Uncertainty {
        reflectance: Some(se(Layout::R)),
        reflectance_specular: Some(se(Layout::R_SPEC)),
        transmittance: Some(se(Layout::T)),
        transmittance_direct: Some(se(Layout::T_DIRECT)),
        absorptance: Some(se(Layout::A)),
        absorptance_layers: Some(per(&|k| l.a_layer(k), l.layers, &ones, &se)),
        brdf: Some(per(&|k| l.brdf(k), l.dirs, &meta.cone, &se)),
        btdf: Some(per(&|k| l.btdf(k), l.dirs, &meta.cone_t, &se)),
        ..Default::default()
    };
    ChannelResult {
        reflectance: mean(Layout::R),
        reflectance_specular: mean(Layout::R_SPEC),
        transmittance: mean(Layout::T),
        transmittance_direct: mean(Layout::T_DIRECT),
        absorptance: mean(Layout::A),
        brdf: per(&|k| l.brdf(k), l.dirs, &meta.cone, &mean),
        btdf: per(&|k| l.btdf(k), l.dirs, &meta.cone_t, &mean),
        stderr: Some(err),
        absorptance_layers: Some(per(&|k| l.a_layer(k), l.layers, &ones, &mean)),
        // The cones the BRDF/BTDF values are means over (eq. B1, B2').
        cones: (l.dirs > 0).then(|| km_core::solution::Cones {
            brdf: meta.cone.iter().map(|&w| crate::bins::cone_half_angle_deg(w)).collect(),
            btdf: meta.cone_t.iter().map(|&w| crate::bins::cone_half_angle_deg(w)).collect(),
        }),
        ..Default::default()
    }
}

/// Turn merged statistics into the contract [`Solution`].
pub(crate) fn build_solution(parts: &[Partial], m: &Merged) -> Solution {
    let p0 = &parts[0];
    let seconds: f64 = {
        let mut v: Vec<&Partial> = parts.iter().collect();
        v.sort_by_key(|p| p.shard_index);
        v.iter().map(|p| p.seconds).sum()
    };
    let mut channels = Vec::new();
    let mut lost = Vec::new();
    let mut a_sub = Vec::new();
    let mut rings_r = Vec::new();
    let mut rings_t = Vec::new();
    let mut rings_r_se = Vec::new();
    let mut rings_t_se = Vec::new();
    let mut radial = Vec::new();
    let mut radial_se = Vec::new();
    for (c, meta) in p0.channels.iter().enumerate() {
        let s = &m.stats[c];
        let l = meta.layout();
        let mean = |j: usize| s.mean(j);
        let se = |j: usize| s.stderr(j);
        channels.push(channel_result(s, &l, meta));
        lost.push(mean(Layout::LOST));
        a_sub.push(mean(Layout::A_SUB));
        rings_r.push(per(&|k| l.ring_r(k), l.rings, &meta.ring, &mean));
        rings_t.push(per(&|k| l.ring_t(k), l.rings, &meta.ring, &mean));
        rings_r_se.push(per(&|k| l.ring_r(k), l.rings, &meta.ring, &se));
        rings_t_se.push(per(&|k| l.ring_t(k), l.rings, &meta.ring, &se));
        radial.push(per(&|k| l.radial(k), l.radial, &meta.annulus, &mean));
        radial_se.push(per(&|k| l.radial(k), l.radial, &meta.annulus, &se));
    }
    let o = &p0.options;
    let mc = km_core::solution::McDiagnostics {
        estimator: o.estimator.name(),
        samples: o.samples,
        seed: o.seed,
        batch_size: p0.batch_size,
        batches: p0.batch_count,
        bin_half_angle_deg: o.bin_half_angle_deg,
        max_steps_per_photon: o.max_steps_per_photon,
        interactions: m.interactions.clone(),
        steps: m.steps.clone(),
        capped_photons: m.capped.clone(),
        lost_weight: lost,
        absorptance_substrate: a_sub,
        rings: o.ring_mu_edges.as_ref().map(|e| km_core::solution::McRings {
            mu_edges: e.clone(),
            brdf: rings_r,
            btdf: rings_t,
            brdf_stderr: rings_r_se,
            btdf_stderr: rings_t_se,
        }),
        radial: o.radial.map(|r| km_core::solution::McRadial {
            dr: r.dr,
            r: (0..r.count).map(|i| (i as f64 + 0.5) * r.dr).collect(),
            rd: radial,
            rd_stderr: radial_se,
        }),
    };
    Solution {
        method: "mc".into(),
        channels,
        labels: p0.labels.clone(),
        seconds,
        diagnostics: km_core::solution::Diagnostics {
            method: km_core::solution::MethodDiagnostics::MonteCarlo(Box::new(mc)),
            ..Default::default()
        },
        ..Default::default()
    }
}

/// Write `bytes` to `path` atomically, by [`km_core::atomic_file::write_atomic`]:
/// a temporary file created exclusively beside the target, flushed, renamed
/// over it; targets that are not regular files (devices, FIFOs, directories,
/// symbolic links) are refused, and the temporary file is removed on errors
/// and on SIGINT/SIGTERM.
///
/// # Errors
/// [`McError::Io`] naming the path.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), McError> {
    km_core::atomic_file::write_atomic(path, bytes)
        .map_err(|source| McError::Io { path: path.display().to_string(), source })
}
