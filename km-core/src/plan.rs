//! The planner: what a scene and its question call for, and what each method
//! may therefore skip.
//!
//! A [`Plan`] is derived from a [`MonoScene`] (one spectral channel) and the
//! outputs asked for. It lists the physical effects present, the
//! simplifications taken (each under a stable name in [`Plan::skipped`], with
//! a reason in [`Plan::reasons`]), and per-layer and per-method decisions the
//! solvers obey. `all_effects = true` turns every simplification off, for
//! comparison.
//!
//! Stable names of simplifications (other tools rely on them):
//!
//! | name | meaning |
//! |---|---|
//! | `interface` | a boundary whose two sides have the same index is no interface |
//! | `scattering` | a layer that only absorbs is attenuation in closed form, no eigen-solve |
//! | `azimuth` | only the azimuth-independent Fourier order is needed |
//! | `transmission` | a layer so thick that nothing measurable gets through is a half-space |
//! | `angular-tallies` | Monte Carlo without angular bins (no directions asked) |
//! | `substrate` | the substrate cannot be reached (a half-space or opaque layer above it) |
//! | `duplicate-channels` | spectral channels with identical coefficients are solved once |
//!
//! The `transmission` rule (eq. PL1): light crossing a layer of optical
//! thickness `tau` decays at least like `exp(-k tau)` where `k` is the
//! smallest decay constant of the transport equation in the layer. The
//! diffusion (similarity) estimate `k_d = sqrt(3 (1 - omega)(1 - omega g))`
//! approaches the exact value from above only as `omega -> 1`, and `k <= 1`;
//! we take the safe half `k_s = min(1, k_d) / 2` and treat the layer as a
//! half-space when `exp(-2 k_s tau) < 1e-14` (the light has to cross twice to
//! come back). The bound on the neglected reflectance is reported with the
//! reason. Conservative layers (`omega = 1`) are never cut.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::fmt;
use std::str::FromStr;

use crate::scene::{Light, MonoScene, Scene, Substrate};

/// A simplification the planner may take (see the table above for the
/// stable names returned by [`Simplification::name`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Simplification {
    /// A boundary between equal indices is no interface.
    Interface,
    /// A layer that only absorbs is attenuation in closed form.
    Scattering,
    /// Only the azimuth-independent Fourier order is needed.
    Azimuth,
    /// A layer too thick to transmit anything measurable is a half-space (eq. PL1).
    Transmission,
    /// Monte Carlo without angular bins.
    AngularTallies,
    /// The substrate cannot be reached.
    Substrate,
    /// Spectral channels with identical coefficients are solved once.
    DuplicateChannels,
}

impl Simplification {
    /// Every simplification, in the order of the table above.
    pub const ALL: [Simplification; 7] = [
        Simplification::Interface,
        Simplification::Scattering,
        Simplification::Azimuth,
        Simplification::Transmission,
        Simplification::AngularTallies,
        Simplification::Substrate,
        Simplification::DuplicateChannels,
    ];

    /// The stable name (used in JSON and by other tools).
    ///
    /// ```
    /// use km_core::plan::Simplification;
    /// assert_eq!(Simplification::AngularTallies.name(), "angular-tallies");
    /// assert_eq!("azimuth".parse::<Simplification>(), Ok(Simplification::Azimuth));
    /// ```
    pub fn name(self) -> &'static str {
        match self {
            Simplification::Interface => "interface",
            Simplification::Scattering => "scattering",
            Simplification::Azimuth => "azimuth",
            Simplification::Transmission => "transmission",
            Simplification::AngularTallies => "angular-tallies",
            Simplification::Substrate => "substrate",
            Simplification::DuplicateChannels => "duplicate-channels",
        }
    }
}

impl fmt::Display for Simplification {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Simplification {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Simplification::ALL
            .into_iter()
            .find(|x| x.name() == s)
            .ok_or_else(|| format!("no simplification is called `{s}`"))
    }
}

impl PartialEq<&str> for Simplification {
    fn eq(&self, other: &&str) -> bool {
        self.name() == *other
    }
}

/// The simplifications that concern each method (the planner's per-method
/// rules), by method name: `km`, `multiflux`, `mc`, `dipole`.
pub fn relevant_to(method: &str) -> &'static [Simplification] {
    use Simplification::*;
    match method {
        "km" => &[Interface, Substrate, DuplicateChannels],
        "multiflux" => {
            &[Interface, Scattering, Azimuth, Transmission, Substrate, DuplicateChannels]
        }
        "mc" => &[Interface, AngularTallies, Substrate, DuplicateChannels],
        _ => &[DuplicateChannels],
    }
}

/// Relative size below which the light returning from beneath a layer is
/// neglected by the `transmission` rule (eq. PL1).
pub const TRANSMISSION_CUTOFF: f64 = 1e-14;

/// What the user asks for, beyond the totals that are always computed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Request {
    /// BRDF / BTDF values at the scene's output directions.
    pub directions: bool,
    /// The internal light field at some depths.
    pub internal_field: bool,
    /// The radially resolved reflectance of a pencil beam.
    pub radial_profile: bool,
}

impl Request {
    /// What a scene file asks for by itself (directions when `[output]` has any).
    pub fn from_scene(scene: &MonoScene) -> Request {
        Request { directions: !scene.directions_deg().is_empty(), ..Request::default() }
    }
}

/// The decisions about one layer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LayerPlan {
    /// There is a Fresnel interface at the top of this layer (index differs from above).
    pub interface_above: bool,
    /// The layer scatters (an eigen-solve or a random walk is needed).
    pub scatters: bool,
    /// The layer is treated as a half-space (its own thickness, or the `transmission` rule).
    pub half_space: bool,
    /// When the `transmission` rule applies: the bound on the neglected reflectance.
    pub cutoff_bound: Option<f64>,
}

/// What a scene calls for, and what may be skipped.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// Physical effects present, as short phrases (`"interface"`, `"total-internal-reflection"`, ...).
    /// Fixed phrases are borrowed, not allocated: a plan is drawn up on every solve.
    pub effects: Vec<Cow<'static, str>>,
    /// The simplifications taken.
    pub skipped: Vec<Simplification>,
    /// Why each simplification was taken (fixed texts borrowed, as `effects`).
    pub reasons: BTreeMap<Simplification, Cow<'static, str>>,
    /// One entry per layer, top first.
    pub layers: Vec<LayerPlan>,
    /// How many layers take part (those below a half-space do not).
    pub active_layers: usize,
    /// Whether the substrate is reached.
    pub substrate_reached: bool,
    /// Only the azimuth-independent Fourier order is needed.
    pub azimuth_independent: bool,
    /// Monte Carlo needs angular bins.
    pub angular_tallies: bool,
    /// The planner was switched off.
    pub all_effects: bool,
}

impl Plan {
    /// The plan for one channel and one request.
    ///
    /// ```
    /// use km_core::{Scene, plan::{Plan, Request}};
    /// let s = Scene::from_toml_str("[[layer]]\ntau = 1\nalbedo = 0.5\n").unwrap();
    /// let p = Plan::new(&s.channels()[0], Request::default(), false);
    /// assert!(p.skips("interface"));
    /// assert!(p.skips(km_core::plan::Simplification::Azimuth));
    /// ```
    pub fn new(scene: &MonoScene, request: Request, all_effects: bool) -> Plan {
        let mut d = Draft::default();
        let mut layers = interfaces(&mut d, scene, all_effects);
        let scattering = scattering(&mut d, scene, all_effects);
        let active = thick_layers(&mut d, scene, &mut layers, all_effects);
        layers.truncate(active);
        let substrate_reached =
            active == scene.layers().len() && layers.last().is_none_or(|l| !l.half_space);
        match scene.substrate() {
            Substrate::Lambertian { .. } if substrate_reached => {
                d.effects.push("lambertian-substrate".into())
            }
            Substrate::Black if substrate_reached => d.effects.push("black-substrate".into()),
            _ => {}
        }
        if !substrate_reached {
            d.skip(
                Simplification::Substrate,
                format!("no light reaches below layer {active}").into(),
            );
        }

        // Azimuth: isotropic phase functions, diffuse light or totals only need m = 0.
        let isotropic = scene.layers()[..active].iter().all(|l| l.g() == 0.0 || l.sigma_s() == 0.0);
        let diffuse = scene.light() == Light::Diffuse;
        let azimuth_independent =
            !all_effects && (!request.directions || isotropic || diffuse || !scattering);
        if azimuth_independent {
            let why = if !request.directions {
                "only totals are asked: the azimuth-independent Fourier order gives them exactly"
            } else if !scattering {
                "nothing scatters: no azimuthal structure"
            } else if diffuse {
                "diffuse light has no azimuth: only order m = 0 is excited"
            } else {
                "isotropic scattering: the phase function has no azimuthal Fourier orders m > 0"
            };
            d.skip(Simplification::Azimuth, why.into());
        }
        let angular_tallies = all_effects || request.directions;
        if !angular_tallies {
            d.skip(
                Simplification::AngularTallies,
                "no [output] directions: Monte Carlo tallies totals only".into(),
            );
        }
        Plan {
            effects: d.effects,
            skipped: d.skipped,
            reasons: d.reasons,
            layers,
            active_layers: active,
            substrate_reached,
            azimuth_independent,
            angular_tallies,
            all_effects,
        }
    }

    /// Keep only the simplifications that concern `method` (`km`, `multiflux`,
    /// `mc`, `dipole`; [`relevant_to`]): e.g. `angular-tallies` is a Monte
    /// Carlo matter and `azimuth` a Fourier-mode matter.
    pub fn for_method(self, method: &str) -> Plan {
        self.restricted_to(relevant_to(method))
    }

    /// Keep only the simplifications in `relevant`.
    pub fn restricted_to(mut self, relevant: &[Simplification]) -> Plan {
        self.skipped.retain(|s| relevant.contains(s));
        // A reason is kept with its simplification: those kept are the
        // relevant ones among `skipped`.
        let kept = &self.skipped;
        self.reasons.retain(|k, _| kept.contains(k));
        self
    }

    /// Whether the simplification `s` was taken (a [`Simplification`] or its name).
    pub fn skips<S>(&self, s: S) -> bool
    where
        Simplification: PartialEq<S>,
    {
        self.skipped.iter().any(|x| *x == s)
    }

    /// The JSON of the `km solve --json` contract: `{"effects", "skipped", "reasons"}`.
    pub fn to_json(&self) -> serde_json::Value {
        let skipped: Vec<&str> = self.skipped.iter().map(|s| s.name()).collect();
        let reasons: BTreeMap<&str, &str> =
            self.reasons.iter().map(|(k, v)| (k.name(), v.as_ref())).collect();
        serde_json::json!({
            "effects": self.effects,
            "skipped": skipped,
            "reasons": reasons,
        })
    }
}

/// Channels with identical coefficients: for each channel, the index of the
/// first channel equal to it (so a solver computes only the distinct ones).
///
/// ```
/// let s = km_core::Scene::from_toml_str("[[layer]]\ntau = [1, 2, 1]\nalbedo = 0.5\n").unwrap();
/// assert_eq!(km_core::plan::distinct_channels(&s), vec![0, 1, 0]);
/// ```
pub fn distinct_channels(scene: &Scene) -> Vec<usize> {
    // One channel (the common case) is distinct from nothing: no hashing.
    if scene.channels().len() == 1 {
        return vec![0];
    }
    // Hash each channel's numbers by their bit patterns (-0.0 folded onto
    // 0.0, as `==` does), then confirm equality within a bucket: linear time
    // (a pairwise search was quadratic: 10^5 channels took 10 s).
    fn key(c: &MonoScene) -> u64 {
        use std::hash::{Hash, Hasher};
        let mut h = std::collections::hash_map::DefaultHasher::new();
        let mut f = |x: f64| (if x == 0.0 { 0u64 } else { x.to_bits() }).hash(&mut h);
        match c.light() {
            Light::Collimated { theta_deg } => f(theta_deg),
            Light::Diffuse => f(f64::NAN),
        }
        f(c.ambient_n());
        for l in c.layers() {
            for x in [l.sigma_a(), l.sigma_s(), l.thickness(), l.g(), l.n()] {
                f(x);
            }
            f(l.roughness().map_or(0.0, |r| r.alpha()));
        }
        match c.substrate() {
            Substrate::Transparent { n } => f(n),
            Substrate::Lambertian { albedo } => f(-1.0 - albedo),
            Substrate::Black => f(f64::INFINITY),
            Substrate::Conductor { n, k } => {
                f(-10.0 - n);
                f(k);
            }
        }
        f(c.substrate_roughness().map_or(0.0, |r| r.alpha()));
        for d in c.directions_deg() {
            f(d[0]);
            f(d[1]);
        }
        h.finish()
    }
    let mut buckets: std::collections::HashMap<u64, Vec<usize>> =
        std::collections::HashMap::with_capacity(scene.channels().len());
    let mut first = Vec::with_capacity(scene.channels().len());
    for (i, c) in scene.channels().iter().enumerate() {
        let bucket = buckets.entry(key(c)).or_default();
        let j = bucket.iter().copied().find(|&j| scene.channels()[j] == *c).unwrap_or(i);
        if j == i {
            bucket.push(i);
        }
        first.push(j);
    }
    first
}

/// The scene reduced to its distinct channels, and for every channel of the
/// original the index of its representative in the reduced scene.
///
/// ```
/// let s = km_core::Scene::from_toml_str("[[layer]]\ntau = [1, 2, 1]\nalbedo = 0.5\n").unwrap();
/// let (reduced, map) = km_core::plan::reduce_channels(&s);
/// assert_eq!(reduced.channels().len(), 2);
/// assert_eq!(map, vec![0, 1, 0]);
/// ```
pub fn reduce_channels(scene: &Scene) -> (Scene, Vec<usize>) {
    let first = distinct_channels(scene);
    let mut keep = Vec::new();
    let mut map = Vec::with_capacity(first.len());
    for (i, &f) in first.iter().enumerate() {
        if f == i {
            keep.push(i);
        }
        // `keep` is increasing: the rank of `f` by binary search (a linear search was quadratic).
        map.push(keep.partition_point(|&k| k < f));
    }
    let reduced = scene.select(&keep);
    (reduced, map)
}

/// Expand a solution of [`reduce_channels`]' reduced scene back to every
/// channel of the original (`labels` are the original's).
pub fn expand_channels(
    mut solution: crate::Solution,
    map: &[usize],
    labels: &[String],
) -> crate::Solution {
    let channels = map.iter().filter_map(|&j| solution.channels.get(j).cloned()).collect();
    solution.channels = channels;
    solution.labels = labels.to_vec();
    solution
}

/// The plan of a whole scene: the union over channels, plus `duplicate-channels`.
pub fn plan_scene(scene: &Scene, request: Request, all_effects: bool) -> Plan {
    // A scene has at least one channel (its constructor's invariant).
    let (first, rest) = scene.split_first();
    let mut p = Plan::new(first, request, all_effects);
    let plans = rest.iter().map(|c| Plan::new(c, request, all_effects));
    for q in plans {
        for e in q.effects {
            if !p.effects.contains(&e) {
                p.effects.push(e);
            }
        }
        // A simplification holds for the scene only if it holds in every channel.
        p.skipped.retain(|s| q.skipped.contains(s));
        p.azimuth_independent &= q.azimuth_independent;
        p.angular_tallies |= q.angular_tallies;
    }
    p.reasons.retain(|k, _| p.skipped.contains(k));
    let first = distinct_channels(scene);
    let distinct = first.iter().enumerate().filter(|(i, j)| i == *j).count();
    if distinct < scene.channels().len() && !all_effects {
        p.skipped.push(Simplification::DuplicateChannels);
        p.reasons.insert(
            Simplification::DuplicateChannels,
            format!(
                "{} of {} channels are distinct: each is solved once",
                distinct,
                scene.channels().len()
            )
            .into(),
        );
    }
    p
}

/// What a plan collects while it is drawn up: the effects present, the
/// work skipped and why (the first reason given for each).
#[derive(Default)]
struct Draft {
    effects: Vec<Cow<'static, str>>,
    skipped: Vec<Simplification>,
    reasons: BTreeMap<Simplification, Cow<'static, str>>,
}

impl Draft {
    fn skip(&mut self, name: Simplification, reason: Cow<'static, str>) {
        if !self.skipped.contains(&name) {
            self.skipped.push(name);
        }
        self.reasons.entry(name).or_insert(reason);
    }
}

/// Interfaces wherever the index changes, top to bottom (and total internal
/// reflection where light can meet a less dense medium): one [`LayerPlan`]
/// per layer.
fn interfaces(d: &mut Draft, scene: &MonoScene, all_effects: bool) -> Vec<LayerPlan> {
    let mut layers = Vec::with_capacity(scene.layers().len());
    let mut n_above = scene.ambient_n();
    let mut any_interface = false;
    let mut tir = false;
    // "indices match at: top of layer 1, ..." written into one string as the
    // matches are found.
    let mut matched = String::new();
    let mut matched_at = |layer: Option<usize>| {
        matched.push_str(if matched.is_empty() { "indices match at: " } else { ", " });
        match layer {
            Some(i) => {
                use fmt::Write;
                // Writing to a `String` cannot fail.
                let _ = write!(matched, "top of layer {i}");
            }
            None => matched.push_str("bottom of the stack"),
        }
    };
    for (i, l) in scene.layers().iter().enumerate() {
        let iface = l.n() != n_above || all_effects;
        if l.n() != n_above {
            any_interface = true;
            // Light inside the denser medium can be totally reflected.
            tir |= l.n() > scene.ambient_n() || l.n() > n_above;
        } else {
            matched_at(Some(i + 1));
        }
        layers.push(LayerPlan {
            interface_above: iface,
            scatters: l.sigma_s() > 0.0 || all_effects,
            half_space: l.is_half_space(),
            cutoff_bound: None,
        });
        n_above = l.n();
    }
    if let Substrate::Transparent { n } = scene.substrate() {
        if n != n_above {
            any_interface = true;
            tir |= n_above > n;
        } else {
            matched_at(None);
        }
    }
    if any_interface {
        d.effects.push("interface".into());
    }
    if tir {
        d.effects.push("total-internal-reflection".into());
    }
    if !matched.is_empty() && !all_effects {
        d.skip(Simplification::Interface, matched.into());
    }
    layers
}

/// Scattering and anisotropy; layers that only absorb are attenuated in
/// closed form. Returns whether any layer scatters.
fn scattering(d: &mut Draft, scene: &MonoScene, all_effects: bool) -> bool {
    let scattering = scene.layers().iter().any(|l| l.sigma_s() > 0.0);
    if scattering {
        d.effects.push("scattering".into());
    }
    if scene.layers().iter().any(|l| l.sigma_s() > 0.0 && l.g() != 0.0) {
        d.effects.push("anisotropy".into());
    }
    let absorbers: Vec<String> = (0..scene.layers().len())
        .filter(|&i| scene.layers()[i].sigma_s() == 0.0)
        .map(|i| format!("layer {}", i + 1))
        .collect();
    if !absorbers.is_empty() && !all_effects {
        d.skip(
            Simplification::Scattering,
            format!("{} only absorb: attenuation in closed form", absorbers.join(", ")).into(),
        );
    }
    scattering
}

/// Thick layers: the transmission rule (eq. PL1), top down; nothing below a
/// half-space takes part. Returns the number of layers that do.
fn thick_layers(
    d: &mut Draft,
    scene: &MonoScene,
    layers: &mut [LayerPlan],
    all_effects: bool,
) -> usize {
    let own_half_space = scene.layers().iter().position(|l| l.is_half_space());
    if !all_effects && let Some((i, bound)) = transmission_cut(scene) {
        let l = &scene.layers()[i];
        layers[i].half_space = true;
        layers[i].cutoff_bound = Some(bound);
        d.skip(
            Simplification::Transmission,
            format!(
                "layer {} (tau = {:.4e}, albedo = {:.6}) is treated as a half-space: \
                 light returning from below is < {:.1e} of the incident",
                i + 1,
                l.tau(),
                l.albedo(),
                bound
            )
            .into(),
        );
        return i + 1;
    }
    own_half_space.map_or(scene.layers().len(), |i| i + 1)
}

/// The `transmission` rule alone (eq. PL1 of docs/planner.md): the first
/// layer, above any half-space, so thick that less than
/// [`TRANSMISSION_CUTOFF`] of the incident light returns from below it, and
/// that bound; `None` when no layer is. What [`Plan::new`] records as the
/// `transmission` simplification, without the plan's descriptions (the
/// solvers ask it on every solve).
///
/// ```
/// let s = km_core::Scene::from_toml_str("[[layer]]\ntau = 1e4\nalbedo = 0.5\n").unwrap();
/// let (i, bound) = km_core::plan::transmission_cut(&s.channels()[0]).unwrap();
/// assert_eq!(i, 0);
/// assert!(bound < km_core::plan::TRANSMISSION_CUTOFF);
/// ```
pub fn transmission_cut(scene: &MonoScene) -> Option<(usize, f64)> {
    for (i, l) in scene.layers().iter().enumerate() {
        if l.is_half_space() {
            return None;
        }
        let omega = l.albedo();
        let k_d = (3.0 * (1.0 - omega) * (1.0 - omega * l.g())).max(0.0).sqrt();
        let k_s = 0.5 * k_d.min(1.0);
        let bound = (-2.0 * k_s * l.tau()).exp();
        if k_s > 0.0 && bound < TRANSMISSION_CUTOFF {
            return Some((i, bound));
        }
    }
    None
}
