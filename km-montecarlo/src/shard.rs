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

use std::collections::BTreeSet;
use std::io::Write;
use std::path::Path;

use km_core::{ChannelResult, Solution};
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value, json};

use crate::error::McError;
use crate::options::McOptions;
use crate::tally::{BatchStats, Layout};

/// Format tag of [`Partial`] files.
pub const PARTIAL_FORMAT: &str = "km-montecarlo-partial-1";

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
}

impl ChannelMeta {
    pub(crate) fn layout(&self) -> Layout {
        Layout { layers: self.layers, dirs: self.dirs, rings: self.rings, radial: self.radial }
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

/// Check that `parts` are the complete set of shards of one run.
fn validate(parts: &[Partial]) -> Result<(), McError> {
    let Some(p0) = parts.first() else {
        return Err(McError::Merge("no parts given".into()));
    };
    for (i, p) in parts.iter().enumerate() {
        if p.format != PARTIAL_FORMAT {
            return Err(McError::Merge(format!(
                "part {} has format {:?}, expected {PARTIAL_FORMAT:?}",
                i + 1,
                p.format
            )));
        }
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
        if p.shard_index >= p.shard_count {
            return Err(McError::Merge(format!(
                "part {} claims shard {} of {}",
                i + 1,
                p.shard_index,
                p.shard_count
            )));
        }
        // The batches must be exactly those of the shard, complete.
        let want = shard_batches(p.batch_count, p.shard_index, p.shard_count);
        let ok = p.batches.len() as u64 == want.end - want.start
            && p.batches.iter().zip(want).all(|(b, w)| {
                b.index == w
                    && b.photons == batch_photons(p.options.samples, p.batch_size, w)
                    && b.channels.len() == p.channels.len()
                    && b.channels
                        .iter()
                        .zip(&p.channels)
                        .all(|(c, m)| c.sums.len() == m.layout().len())
            });
        if !ok {
            return Err(McError::Merge(format!(
                "part {} (shard {}/{}) does not hold its batches intact",
                i + 1,
                p.shard_index,
                p.shard_count
            )));
        }
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
    validate(parts)?;
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
                m.interactions[c] += cb.interactions;
                m.steps[c] += cb.steps;
                m.capped[c] += cb.capped;
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

/// JSON number or null (NaN standard errors of one-batch runs).
fn num(x: f64) -> Value {
    serde_json::Number::from_f64(x).map(Value::Number).unwrap_or(Value::Null)
}

fn nums(v: impl IntoIterator<Item = f64>) -> Value {
    Value::Array(v.into_iter().map(num).collect())
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
        let per = |idx: &dyn Fn(usize) -> usize,
                   n: usize,
                   norm: &[f64],
                   f: &dyn Fn(usize) -> f64| {
            (0..n).map(|k| f(idx(k)) / norm.get(k).copied().unwrap_or(1.0)).collect::<Vec<f64>>()
        };
        let mean = |j: usize| s.mean(j);
        let se = |j: usize| s.stderr(j);
        let ones = vec![1.0; l.layers];
        let brdf = per(&|k| l.brdf(k), l.dirs, &meta.cone, &mean);
        let btdf = per(&|k| l.btdf(k), l.dirs, &meta.cone_t, &mean);
        let layers = per(&|k| l.a_layer(k), l.layers, &ones, &mean);
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
        channels.push(ChannelResult {
            reflectance: mean(Layout::R),
            reflectance_specular: mean(Layout::R_SPEC),
            transmittance: mean(Layout::T),
            transmittance_direct: mean(Layout::T_DIRECT),
            absorptance: mean(Layout::A),
            brdf,
            btdf,
            stderr: Some(err),
            error_estimate: None,
            absorptance_layers: Some(layers),
        });
        lost.push(mean(Layout::LOST));
        a_sub.push(mean(Layout::A_SUB));
        rings_r.push(nums(per(&|k| l.ring_r(k), l.rings, &meta.ring, &mean)));
        rings_t.push(nums(per(&|k| l.ring_t(k), l.rings, &meta.ring, &mean)));
        rings_r_se.push(nums(per(&|k| l.ring_r(k), l.rings, &meta.ring, &se)));
        rings_t_se.push(nums(per(&|k| l.ring_t(k), l.rings, &meta.ring, &se)));
        radial.push(nums(per(&|k| l.radial(k), l.radial, &meta.annulus, &mean)));
        radial_se.push(nums(per(&|k| l.radial(k), l.radial, &meta.annulus, &se)));
    }
    let o = &p0.options;
    let one = channels.len() == 1;
    let pick = |v: Vec<Value>| if one { v[0].clone() } else { Value::Array(v) };
    let photons = o.samples as f64;
    let mut mc = Map::new();
    mc.insert("estimator".into(), json!(o.estimator.name()));
    mc.insert("samples".into(), json!(o.samples));
    mc.insert("seed".into(), json!(o.seed));
    mc.insert("batch_size".into(), json!(p0.batch_size));
    mc.insert("batches".into(), json!(p0.batch_count));
    mc.insert("bin_half_angle_deg".into(), json!(o.bin_half_angle_deg));
    mc.insert("max_steps_per_photon".into(), json!(o.max_steps_per_photon));
    mc.insert("interactions".into(), pick(m.interactions.iter().map(|&x| json!(x)).collect()));
    mc.insert(
        "interactions_per_photon".into(),
        pick(m.interactions.iter().map(|&x| num(x as f64 / photons)).collect()),
    );
    mc.insert("steps".into(), pick(m.steps.iter().map(|&x| json!(x)).collect()));
    mc.insert("capped_photons".into(), pick(m.capped.iter().map(|&x| json!(x)).collect()));
    mc.insert("lost_weight".into(), pick(lost.into_iter().map(num).collect()));
    mc.insert("absorptance_substrate".into(), pick(a_sub.into_iter().map(num).collect()));
    if let Some(e) = &o.ring_mu_edges {
        mc.insert(
            "rings".into(),
            json!({
                "mu_edges": e,
                "brdf": pick(rings_r), "btdf": pick(rings_t),
                "stderr": { "brdf": pick(rings_r_se), "btdf": pick(rings_t_se) },
            }),
        );
    }
    if let Some(r) = o.radial {
        let mid: Vec<f64> = (0..r.count).map(|i| (i as f64 + 0.5) * r.dr).collect();
        mc.insert(
            "radial".into(),
            json!({ "dr": r.dr, "r": mid, "rd": pick(radial), "stderr": pick(radial_se) }),
        );
    }
    let mut extra = Map::new();
    extra.insert("mc".into(), Value::Object(mc));
    Solution {
        method: "mc".into(),
        channels,
        labels: p0.labels.clone(),
        seconds,
        extra,
        ..Default::default()
    }
}

/// Write `bytes` to `path` atomically: into a temporary file in the same
/// directory, flushed to disk, then renamed over `path` (POSIX rename is
/// atomic), so an interrupted writer leaves either the old file or the new
/// one, never a truncated one.
///
/// # Errors
/// [`McError::Io`] naming the path.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), McError> {
    let io = |source| McError::Io { path: path.display().to_string(), source };
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = dir.join(format!(".{name}.tmp.{}", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.map_err(io)
}
