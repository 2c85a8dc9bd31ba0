//! What a solve returns, and its JSON form (the contract of DESIGN.md §5).
//!
//! A [`Solution`] holds one [`ChannelResult`] per spectral channel. Its JSON
//! has the contract's keys; for a one-channel scene each is a number (or a
//! list of numbers for `brdf`/`btdf`), for several channels each becomes a
//! list over channels and `"channels"` gives their labels.

use serde::Serialize;
use serde_json::{Map, Value, json};

/// The answer of one method for one spectral channel.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
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
    /// Standard errors by key (Monte Carlo).
    pub stderr: Option<Map<String, Value>>,
    /// Estimated error by key (an accuracy target was given).
    pub error_estimate: Option<Map<String, Value>>,
    /// Absorbed fraction per layer, top first, when the method provides it.
    pub absorptance_layers: Option<Vec<f64>>,
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
    /// Extra method-specific entries (settings used, notes, plan); merged into the JSON.
    pub extra: Map<String, Value>,
}

impl Solution {
    /// The contract JSON.
    pub fn to_json(&self) -> Value {
        let mut out = Map::new();
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
            out.insert("brdf".into(), pick(&|c| json!(c.brdf)));
            out.insert("btdf".into(), pick(&|c| json!(c.btdf)));
        }
        if self.channels.iter().any(|c| c.absorptance_layers.is_some()) {
            out.insert("absorptance_layers".into(), pick(&|c| json!(c.absorptance_layers)));
        }
        for (key, get) in [
            ("stderr", (|c: &ChannelResult| c.stderr.clone()) as fn(&ChannelResult) -> _),
            ("error_estimate", |c: &ChannelResult| c.error_estimate.clone()),
        ] {
            if self.channels.iter().any(|c| get(c).is_some()) {
                out.insert(key.into(), pick(&|c| get(c).map(Value::Object).unwrap_or(Value::Null)));
            }
        }
        if !one {
            out.insert("channels".into(), json!(self.labels));
        }
        out.insert("seconds".into(), json!(self.seconds));
        for (k, v) in &self.extra {
            out.insert(k.clone(), v.clone());
        }
        Value::Object(out)
    }
}

/// JSON number; non-finite values (never expected) become null rather than invalid JSON.
fn num(x: f64) -> Value {
    serde_json::Number::from_f64(x).map(Value::Number).unwrap_or(Value::Null)
}
