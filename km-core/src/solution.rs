//! What a solve returns, and its JSON form (the `km solve --json` contract of
//! docs/cli.md, `"format": 2`).
//!
//! A [`Solution`] holds one [`ChannelResult`] per spectral channel. Its JSON
//! has the contract's keys; for a one-channel scene each is a number (or a
//! list of numbers for `brdf`/`btdf`), for several channels each becomes a
//! list over channels and `"channels"` gives their labels (`km::solve` puts a
//! spectral scene's wavelengths there, as numbers). The uncertainties
//! ([`Uncertainty`]: `stderr`, `error_estimate`) take the same shape key by
//! key: `d["stderr"]["reflectance"]` is a number for one channel and a list
//! over channels for several.

use std::collections::BTreeMap;

use serde_json::{Map, Value, json};

use crate::plan::Plan;

pub mod diagnostics;

pub use diagnostics::{
    Diagnostics, DipoleDiagnostics, DirectionSetDiagnostics, McDiagnostics, McRadial, McRings,
    MethodDiagnostics, MultifluxDiagnostics, RepeatedTiming,
};

/// Version of the JSON layout written by [`Solution::to_json`] (key `"format"`).
pub const JSON_FORMAT: u32 = 2;

/// Uncertainties of one channel's numbers, key by key (standard errors of a
/// Monte Carlo run, or the estimated errors of an accuracy target). A key
/// left `None` has no uncertainty attached.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Uncertainty {
    /// Of the total reflectance.
    pub reflectance: Option<f64>,
    /// Of the specular (delta) part of the reflectance.
    pub reflectance_specular: Option<f64>,
    /// Of the total transmittance.
    pub transmittance: Option<f64>,
    /// Of the unscattered (delta) part of the transmittance.
    pub transmittance_direct: Option<f64>,
    /// Of the absorptance.
    pub absorptance: Option<f64>,
    /// Of each layer's absorbed fraction, top first.
    pub absorptance_layers: Option<Vec<f64>>,
    /// Of each BRDF value, one per output direction.
    pub brdf: Option<Vec<f64>>,
    /// Of each BTDF value, one per output direction.
    pub btdf: Option<Vec<f64>>,
    /// The largest over the BRDF values.
    pub brdf_max: Option<f64>,
    /// The largest over the BTDF values.
    pub btdf_max: Option<f64>,
}

/// One entry of an [`Uncertainty`]: a number or a list of numbers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum UncertaintyValue<'a> {
    /// One number (a total).
    Number(f64),
    /// One number per output direction or per layer.
    List(&'a [f64]),
}

impl Uncertainty {
    /// The entries present, under their JSON keys, in a fixed order.
    pub fn entries(&self) -> Vec<(&'static str, UncertaintyValue<'_>)> {
        use UncertaintyValue::{List, Number};
        let mut v = Vec::new();
        for (k, x) in [
            ("reflectance", self.reflectance),
            ("reflectance_specular", self.reflectance_specular),
            ("transmittance", self.transmittance),
            ("transmittance_direct", self.transmittance_direct),
            ("absorptance", self.absorptance),
            ("brdf_max", self.brdf_max),
            ("btdf_max", self.btdf_max),
        ] {
            if let Some(x) = x {
                v.push((k, Number(x)));
            }
        }
        for (k, x) in [
            ("absorptance_layers", &self.absorptance_layers),
            ("brdf", &self.brdf),
            ("btdf", &self.btdf),
        ] {
            if let Some(x) = x {
                v.push((k, List(x)));
            }
        }
        v
    }

    /// The number under `key` (`"reflectance"`, `"brdf_max"`, ...), if present.
    ///
    /// ```
    /// let u = km_core::Uncertainty { reflectance: Some(1e-3), ..Default::default() };
    /// assert_eq!(u.get("reflectance"), Some(1e-3));
    /// assert_eq!(u.get("transmittance"), None);
    /// ```
    pub fn get(&self, key: &str) -> Option<f64> {
        self.entries().into_iter().find_map(|(k, v)| match v {
            UncertaintyValue::Number(x) if k == key => Some(x),
            _ => None,
        })
    }

    /// The list under `key` (`"brdf"`, `"btdf"`, `"absorptance_layers"`), if present.
    pub fn get_list(&self, key: &str) -> Option<&[f64]> {
        match key {
            "brdf" => self.brdf.as_deref(),
            "btdf" => self.btdf.as_deref(),
            "absorptance_layers" => self.absorptance_layers.as_deref(),
            _ => None,
        }
    }

    /// The largest number over every entry (lists included); 0 when empty.
    pub fn max(&self) -> f64 {
        self.entries()
            .into_iter()
            .flat_map(|(_, v)| match v {
                UncertaintyValue::Number(x) => vec![x],
                UncertaintyValue::List(l) => l.to_vec(),
            })
            .fold(0.0, f64::max)
    }
}

/// The answer of one method for one spectral channel.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ChannelResult {
    /// Total reflectance, specular part included.
    pub reflectance: f64,
    /// The mirror (delta) part of the reflectance.
    pub reflectance_specular: f64,
    /// Total transmittance, unscattered part included.
    pub transmittance: f64,
    /// The unscattered (delta) part of the transmittance.
    pub transmittance_direct: f64,
    /// Absorbed fraction `1 - R - T`, or as tallied.
    pub absorptance: f64,
    /// Smooth BRDF (1/sr) at the scene's output directions (empty when not computed).
    pub brdf: Vec<f64>,
    /// Smooth BTDF (1/sr) at the scene's output directions (empty when not computed).
    pub btdf: Vec<f64>,
    /// Standard errors (Monte Carlo).
    pub stderr: Option<Uncertainty>,
    /// Estimated errors (an accuracy target was given).
    pub error_estimate: Option<Uncertainty>,
    /// How far a model (two-flux, dipole) is from the radiative transfer
    /// answer, estimated by a cheap multi-flux solve of the same scene
    /// (docs/two-flux.md §14; JSON `model_error_estimate`).
    pub model_error_estimate: Option<Uncertainty>,
    /// Absorbed fraction per layer, top first, when the method provides it.
    pub absorptance_layers: Option<Vec<f64>>,
    /// Half-angles (degrees) of the cones the BRDF/BTDF values are averages
    /// over (Monte Carlo bins, cone-averaged multi-flux; JSON `cone_half_angle_deg`).
    pub cones: Option<Cones>,
}

/// The half-angles of the cones around each output direction over which
/// BRDF and BTDF values are solid-angle means (docs/montecarlo.md eq. B1–B2').
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Cones {
    /// Per output direction, reflection side, degrees.
    pub brdf: Vec<f64>,
    /// Per output direction, transmission side, degrees.
    pub btdf: Vec<f64>,
}

/// How an accuracy target was met (key `"tolerance"` of the JSON).
#[derive(Debug, Clone, PartialEq)]
pub struct AccuracyReport {
    /// The target `tol`.
    pub target: f64,
    /// Whether every bounded number met it (always true in a returned solution
    /// of `km::solve`; an unreachable target is an error).
    pub reached: bool,
    /// The number that needed the most work, e.g. `"reflectance"`,
    /// `"brdf[2]"`, with the channel label when there are several.
    pub limited_by: String,
    /// The error estimate of that number.
    pub estimate: f64,
    /// The rule, in words, with the equation it follows.
    pub rule: String,
    /// The work chosen, by name (`streams`, `check_streams`, or `samples`, `pilot_samples`).
    pub work: Vec<(String, u64)>,
}

impl AccuracyReport {
    fn to_json(&self) -> Value {
        let mut m = Map::new();
        m.insert("target".into(), json!(self.target));
        m.insert("reached".into(), json!(self.reached));
        m.insert("limited_by".into(), json!(self.limited_by));
        m.insert("estimate".into(), num(self.estimate));
        m.insert("rule".into(), json!(self.rule));
        for (k, v) in &self.work {
            m.insert(k.clone(), json!(v));
        }
        Value::Object(m)
    }
}

/// The depth-resolved field of a solve whose scene asks for `[output]
/// depths` (docs/field.md): per channel, one value per depth. The same
/// quantities as `km field`, from the solve itself.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DepthOutput {
    /// The depths, in the scene's length unit, as asked.
    pub depths: Vec<f64>,
    /// Per channel, the fluence rate `phi(z)` per unit incident irradiance (eq. D1).
    pub fluence: Vec<Vec<f64>>,
    /// Per channel, the absorbed power per unit depth `A(z)` (1/length).
    pub absorbed: Vec<Vec<f64>>,
    /// Per channel, the net downward flux `F(z)`.
    pub net_flux: Vec<Vec<f64>>,
    /// Monte Carlo: the standard errors of `fluence`, `absorbed`, `net_flux`, in that order.
    pub stderr: Option<[Vec<Vec<f64>>; 3]>,
    /// The radiance at the scene's `[output] inside_directions_deg` and the
    /// depths (docs/field.md §2a, §4a, §6), when the scene asks for it and the
    /// method gives it (multi-flux, Monte Carlo): what `km field` gives.
    pub radiance: Option<InsideField>,
}

/// The radiance inside the stack at the field's depths and some directions
/// (docs/field.md §2a, §4a): `km field`'s, and a solve's
/// ([`DepthOutput::radiance`]).
#[derive(Debug, Clone, PartialEq)]
pub struct InsideField {
    /// The directions `[theta, phi]`, degrees: `theta` from the downward
    /// normal (`< 90` down-going, `> 90` up-going), `phi = 180` the side
    /// towards which the beam travels.
    pub directions: Vec<[f64; 2]>,
    /// `radiance[c][k][j]`: channel `c`, depth `k`, direction `j`; the
    /// diffuse radiance per unit incident irradiance (1/sr), the collimated
    /// beams apart.
    pub radiance: Vec<Vec<Vec<f64>>>,
    /// Their standard errors (Monte Carlo).
    pub stderr: Option<Vec<Vec<Vec<f64>>>>,
    /// Per channel and depth, the down-going and up-going collimated beams'
    /// irradiance on a horizontal plane (multi-flux): the light not yet
    /// scattered where the single-scattering correction puts the forward
    /// peak into `radiance`, else delta-M scaled (docs/field.md §2a).
    pub beams: Option<[Vec<Vec<f64>>; 2]>,
    /// The Monte Carlo cone half-angle of each direction, degrees (its
    /// resolution: the values are cone averages).
    pub cone_half_angle_deg: Option<Vec<f64>>,
}

impl InsideField {
    /// The JSON object of the key `radiance` of `km field --json` and `km
    /// solve --json` (docs/cli.md): `directions`, `values` (depth x
    /// direction for one channel, a list of those per channel for several),
    /// `stderr` (Monte Carlo, the same shape), `beam_down`, `beam_up` (a
    /// value per depth, a list per channel for several; multi-flux) and
    /// `cone_half_angle_deg` (a value per direction; Monte Carlo).
    pub fn to_json(&self) -> Value {
        let one = self.radiance.len() == 1;
        let shape = |v: &Vec<Vec<f64>>| {
            if one { nums(&v[0]) } else { Value::Array(v.iter().map(|r| nums(r)).collect()) }
        };
        let shape3 = |v: &Vec<Vec<Vec<f64>>>| {
            let per = |c: &Vec<Vec<f64>>| Value::Array(c.iter().map(|r| nums(r)).collect());
            if one { per(&v[0]) } else { Value::Array(v.iter().map(per).collect()) }
        };
        let mut o = Map::new();
        o.insert("directions".into(), json!(self.directions));
        o.insert("values".into(), shape3(&self.radiance));
        if let Some(se) = &self.stderr {
            o.insert("stderr".into(), shape3(se));
        }
        if let Some([d, u]) = &self.beams {
            o.insert("beam_down".into(), shape(d));
            o.insert("beam_up".into(), shape(u));
        }
        if let Some(c) = &self.cone_half_angle_deg {
            o.insert("cone_half_angle_deg".into(), nums(c));
        }
        Value::Object(o)
    }
}

/// The JSON keys of a [`DepthOutput`] in the order of its `stderr` array.
pub const DEPTH_KEYS: [&str; 3] = ["fluence", "absorbed", "net_flux"];

impl DepthOutput {
    fn values(&self) -> [&Vec<Vec<f64>>; 3] {
        [&self.fluence, &self.absorbed, &self.net_flux]
    }
}

/// The answer of one method for a whole scene.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Solution {
    /// Method name (`km`, `multiflux`, `mc`, `dipole`).
    pub method: String,
    /// One result per channel.
    pub channels: Vec<ChannelResult>,
    /// Channel labels.
    pub labels: Vec<String>,
    /// The solver's own wall time, seconds (no process start, no parsing).
    pub seconds: f64,
    /// The output directions `[theta, phi]` (degrees) of `brdf`/`btdf`, when
    /// the caller attached them (`km::solve` does).
    pub directions: Vec<[f64; 2]>,
    /// Remarks on how the answer was obtained (approximations made, work cut), in words.
    pub notes: Vec<String>,
    /// The plan obeyed, when the caller attached it (`km::solve` does).
    pub plan: Option<Plan>,
    /// How an accuracy target was met, when one was given.
    pub accuracy: Option<AccuracyReport>,
    /// Method-specific settings and diagnostics (e.g. `streams`, `mc`), typed;
    /// merged into the JSON by [`Solution::to_json`].
    pub diagnostics: Diagnostics,
    /// The field at the scene's `[output] depths`, when it asks for them and
    /// the method gives one (`km::solve` attaches it).
    pub field: Option<DepthOutput>,
}

impl Solution {
    /// The contract JSON (docs/cli.md; the schema is docs/solve.schema.json).
    pub fn to_json(&self) -> Value {
        let mut out = Map::new();
        out.insert("format".into(), json!(JSON_FORMAT));
        out.insert("method".into(), json!(self.method));
        let one = self.channels.len() == 1;
        let pick = |f: &dyn Fn(&ChannelResult) -> Value| -> Value {
            if one {
                f(&self.channels[0])
            } else {
                Value::Array(self.channels.iter().map(f).collect())
            }
        };
        out.insert("reflectance".into(), pick(&|c| num(c.reflectance)));
        out.insert("reflectance_specular".into(), pick(&|c| num(c.reflectance_specular)));
        out.insert("transmittance".into(), pick(&|c| num(c.transmittance)));
        out.insert("transmittance_direct".into(), pick(&|c| num(c.transmittance_direct)));
        out.insert("absorptance".into(), pick(&|c| num(c.absorptance)));
        if self.channels.iter().any(|c| !c.brdf.is_empty() || !c.btdf.is_empty()) {
            out.insert("brdf".into(), pick(&|c| nums(&c.brdf)));
            out.insert("btdf".into(), pick(&|c| nums(&c.btdf)));
            if !self.directions.is_empty() {
                out.insert("directions".into(), json!(self.directions));
            }
        }
        if self.channels.iter().any(|c| c.absorptance_layers.is_some()) {
            out.insert(
                "absorptance_layers".into(),
                pick(&|c| c.absorptance_layers.as_deref().map(nums).unwrap_or(Value::Null)),
            );
        }
        type Get = fn(&ChannelResult) -> Option<&Uncertainty>;
        let uncertainties: [(&str, Get); 3] = [
            ("stderr", |c| c.stderr.as_ref()),
            ("error_estimate", |c| c.error_estimate.as_ref()),
            ("model_error_estimate", |c| c.model_error_estimate.as_ref()),
        ];
        for (key, get) in uncertainties {
            if self.channels.iter().any(|c| get(c).is_some()) {
                let per: Vec<Option<&Uncertainty>> = self.channels.iter().map(get).collect();
                out.insert(key.into(), uncertainty_json(&per));
            }
        }
        if let Some(f) = &self.field {
            let rows = |v: &Vec<Vec<f64>>| {
                if v.len() == 1 {
                    nums(&v[0])
                } else {
                    Value::Array(v.iter().map(|r| nums(r)).collect())
                }
            };
            out.insert("depths".into(), nums(&f.depths));
            for (k, v) in DEPTH_KEYS.iter().zip(f.values()) {
                out.insert((*k).into(), rows(v));
            }
            if let Some(se) = &f.stderr {
                let slot = out.entry("stderr").or_insert_with(|| Value::Object(Map::new()));
                if let Value::Object(m) = slot {
                    for (k, v) in DEPTH_KEYS.iter().zip(se) {
                        m.insert((*k).into(), rows(v));
                    }
                }
            }
            if let Some(r) = &f.radiance {
                out.insert("radiance".into(), r.to_json());
            }
        }
        if self.channels.iter().any(|c| c.cones.is_some()) {
            let side = |brdf: bool| {
                pick(&|c: &ChannelResult| match &c.cones {
                    Some(k) => nums(if brdf { &k.brdf } else { &k.btdf }),
                    None => Value::Null,
                })
            };
            out.insert(
                "cone_half_angle_deg".into(),
                json!({ "brdf": side(true), "btdf": side(false) }),
            );
        }
        if !one {
            out.insert("channels".into(), json!(self.labels));
        }
        out.insert("seconds".into(), json!(self.seconds));
        out.extend(self.diagnostics.to_json());
        out.insert("notes".into(), json!(self.notes));
        if let Some(p) = &self.plan {
            out.insert("plan".into(), p.to_json());
        }
        if let Some(a) = &self.accuracy {
            out.insert("tolerance".into(), a.to_json());
        }
        Value::Object(out)
    }
}

/// `{key: value}` for one channel, `{key: [value per channel]}` for several
/// (`null` where a channel lacks the key).
fn uncertainty_json(per: &[Option<&Uncertainty>]) -> Value {
    let mut keys: BTreeMap<&'static str, Vec<Value>> = BTreeMap::new();
    for (c, u) in per.iter().enumerate() {
        for (k, v) in u.map(Uncertainty::entries).unwrap_or_default() {
            let slot = keys.entry(k).or_insert_with(|| vec![Value::Null; per.len()]);
            slot[c] = match v {
                UncertaintyValue::Number(x) => num(x),
                UncertaintyValue::List(l) => nums(l),
            };
        }
    }
    let one = per.len() == 1;
    Value::Object(
        keys.into_iter()
            .map(|(k, mut v)| {
                let v = if one { v.remove(0) } else { Value::Array(v) };
                (k.to_string(), v)
            })
            .collect(),
    )
}

/// JSON number; non-finite values (never expected) become null rather than invalid JSON.
fn num(x: f64) -> Value {
    serde_json::Number::from_f64(x).map(Value::Number).unwrap_or(Value::Null)
}

fn nums(x: &[f64]) -> Value {
    Value::Array(x.iter().copied().map(num).collect())
}
