//! The parser's phase functions (`phase = { kind = ... }`) and particles
//! (`particles = { radius_um, n, k, volume_fraction, distribution }`) of a
//! layer (docs/scene-file.md, docs/phase.md, docs/mie.md).
//!
//! Both tables are read from their TOML values: every key is checked (an
//! unknown one is an error naming it), every number may be a scalar or a
//! per-channel list, and errors carry the line of the table.

use std::sync::Arc;

use toml::{Spanned, Value};

use super::{Coef, Parser};
use crate::error::CoreError;
use crate::mie::{Complex, ParticleOptics, Particles, SizeDistribution, particle_optics};
use crate::phase::{
    Anisotropy, LegendreSeries, ParticlePhase, Phase, PhaseTable, Population, Rayleigh,
    ReynoldsMcCormick, TwoTermHg,
};

/// A phase function as the file gives it, per channel.
pub(in crate::scene) enum PhaseSpec {
    /// `kind = "isotropic"`.
    Isotropic,
    /// `g` alone, or `kind = "hg"`.
    Hg { g: Coef },
    /// `kind = "two-term-hg"`.
    TwoTerm { g1: Coef, g2: Coef, weight: Coef },
    /// `kind = "rayleigh"` (depolarisation default 0).
    Rayleigh { rho: Coef },
    /// `kind = "reynolds-mccormick"`.
    ReynoldsMcCormick { g: Coef, alpha: Coef },
    /// `kind = "legendre"`: one list for all channels, or one per channel.
    Legendre { key: String, line: Option<usize>, moments: Vec<Vec<f64>>, count: Coef },
    /// `kind = "table"`: cosines (from `cos_theta` or `theta_deg`) and `p`
    /// (one list, or one per channel).
    Table { key: String, line: Option<usize>, cos: Vec<f64>, p: Vec<Vec<f64>>, count: Coef },
}

/// One particle population as the file gives it.
pub(in crate::scene) struct ParticleSpec {
    key: String,
    line: Option<usize>,
    n: Coef,
    k: Coef,
    volume_fraction: Coef,
    sizes: SizeSpec,
}

/// The sizes of a population.
enum SizeSpec {
    Mono { radius_um: Coef },
    LogNormal { median_um: Coef, sigma: Coef },
}

/// The keys a table may hold, to refuse any other.
fn only(
    key: &str,
    line: Option<usize>,
    t: &toml::Table,
    allowed: &[&str],
) -> Result<(), CoreError> {
    if let Some(k) = t.keys().find(|k| !allowed.contains(&k.as_str())) {
        return Err(CoreError::scene(
            format!("{key}.{k}"),
            line,
            format!("unknown key (expected one of: {})", allowed.join(", ")),
        ));
    }
    Ok(())
}

impl Parser {
    /// A scalar or list from a value inside a table (the table's line).
    fn coef_in(&self, key: &str, line: Option<usize>, v: &Value) -> Result<Coef, CoreError> {
        let values = match v {
            Value::Array(items) => {
                if items.is_empty() {
                    return Err(CoreError::scene(key, line, "an empty list has no value"));
                }
                items.iter().map(|x| self.number(key, line, x)).collect::<Result<Vec<_>, _>>()?
            }
            other => vec![self.number(key, line, other)?],
        };
        Ok(Coef { key: key.into(), line, values })
    }

    /// A required number (or per-channel list) of a table.
    fn need(
        &self,
        t: &toml::Table,
        key: &str,
        name: &str,
        line: Option<usize>,
    ) -> Result<Coef, CoreError> {
        let k = format!("{key}.{name}");
        match t.get(name) {
            Some(v) => self.coef_in(&k, line, v),
            None => Err(CoreError::scene(k, line, "missing")),
        }
    }

    /// One list of numbers, or one list per channel (a list of lists).
    fn lists(&self, key: &str, line: Option<usize>, v: &Value) -> Result<Vec<Vec<f64>>, CoreError> {
        let Value::Array(items) = v else {
            return Err(CoreError::scene(
                key,
                line,
                "expected a list of numbers (or one list per channel)",
            ));
        };
        if items.is_empty() {
            return Err(CoreError::scene(key, line, "an empty list has no value"));
        }
        if items.iter().all(|x| matches!(x, Value::Array(_))) {
            items
                .iter()
                .map(|x| match x {
                    Value::Array(inner) => {
                        inner.iter().map(|y| self.number(key, line, y)).collect()
                    }
                    _ => unreachable!("checked above"),
                })
                .collect()
        } else {
            Ok(vec![
                items.iter().map(|x| self.number(key, line, x)).collect::<Result<Vec<_>, _>>()?,
            ])
        }
    }

    /// `layer[i].phase`: a table with `kind` and the kind's keys.
    pub(super) fn phase_spec(&self, i: usize, v: &Spanned<Value>) -> Result<PhaseSpec, CoreError> {
        let key = format!("layer[{}].phase", i + 1);
        let line = self.line(v.span());
        let Value::Table(t) = v.get_ref() else {
            return Err(CoreError::scene(
                key,
                line,
                "expected a table, e.g. phase = { kind = \"rayleigh\" }",
            ));
        };
        let kind = match t.get("kind") {
            Some(Value::String(s)) => s.as_str(),
            Some(_) => {
                return Err(CoreError::scene(format!("{key}.kind"), line, "expected a string"));
            }
            None => return Err(CoreError::scene(format!("{key}.kind"), line, "missing")),
        };
        let spec = match kind {
            "isotropic" => {
                only(&key, line, t, &["kind"])?;
                PhaseSpec::Isotropic
            }
            "hg" => {
                only(&key, line, t, &["kind", "g"])?;
                PhaseSpec::Hg { g: self.need(t, &key, "g", line)? }
            }
            "two-term-hg" => {
                only(&key, line, t, &["kind", "g1", "g2", "weight"])?;
                PhaseSpec::TwoTerm {
                    g1: self.need(t, &key, "g1", line)?,
                    g2: self.need(t, &key, "g2", line)?,
                    weight: self.need(t, &key, "weight", line)?,
                }
            }
            "rayleigh" => {
                only(&key, line, t, &["kind", "depolarisation"])?;
                let rho = match t.get("depolarisation") {
                    Some(v) => self.coef_in(&format!("{key}.depolarisation"), line, v)?,
                    None => Coef::constant(&format!("{key}.depolarisation"), 0.0),
                };
                PhaseSpec::Rayleigh { rho }
            }
            "reynolds-mccormick" => {
                only(&key, line, t, &["kind", "g", "alpha"])?;
                PhaseSpec::ReynoldsMcCormick {
                    g: self.need(t, &key, "g", line)?,
                    alpha: self.need(t, &key, "alpha", line)?,
                }
            }
            "legendre" => {
                only(&key, line, t, &["kind", "moments"])?;
                let k = format!("{key}.moments");
                let v =
                    t.get("moments").ok_or_else(|| CoreError::scene(k.clone(), line, "missing"))?;
                let moments = self.lists(&k, line, v)?;
                let count = Coef { key: k.clone(), line, values: vec![0.0; moments.len()] };
                PhaseSpec::Legendre { key: k, line, moments, count }
            }
            "table" => self.table_spec(&key, line, t)?,
            other => {
                return Err(CoreError::scene(
                    format!("{key}.kind"),
                    line,
                    format!(
                        "unknown kind \"{other}\" (expected \"isotropic\", \"hg\", \"two-term-hg\", \
                         \"rayleigh\", \"reynolds-mccormick\", \"legendre\" or \"table\")"
                    ),
                ));
            }
        };
        Ok(spec)
    }

    /// `kind = "table"`: `cos_theta` or `theta_deg`, and `p`.
    fn table_spec(
        &self,
        key: &str,
        line: Option<usize>,
        t: &toml::Table,
    ) -> Result<PhaseSpec, CoreError> {
        only(key, line, t, &["kind", "cos_theta", "theta_deg", "p"])?;
        let cos = match (t.get("cos_theta"), t.get("theta_deg")) {
            (Some(_), Some(_)) => {
                return Err(CoreError::scene(
                    format!("{key}.theta_deg"),
                    line,
                    "give either cos_theta or theta_deg, not both",
                ));
            }
            (Some(v), None) => self.single_list(&format!("{key}.cos_theta"), line, v)?,
            (None, Some(v)) => {
                let th = self.single_list(&format!("{key}.theta_deg"), line, v)?;
                if let Some(x) = th.iter().find(|x| !(0.0..=180.0).contains(*x)) {
                    return Err(CoreError::scene(
                        format!("{key}.theta_deg"),
                        line,
                        format!("{x} must lie in [0, 180] degrees"),
                    ));
                }
                th.iter().map(|x| x.to_radians().cos()).collect()
            }
            (None, None) => {
                return Err(CoreError::scene(
                    format!("{key}.cos_theta"),
                    line,
                    "a table needs cos_theta (or theta_deg) and p",
                ));
            }
        };
        let k = format!("{key}.p");
        let v = t.get("p").ok_or_else(|| CoreError::scene(k.clone(), line, "missing"))?;
        let p = self.lists(&k, line, v)?;
        let count = Coef { key: k.clone(), line, values: vec![0.0; p.len()] };
        Ok(PhaseSpec::Table { key: k, line, cos, p, count })
    }

    /// A list of numbers (not per channel).
    fn single_list(
        &self,
        key: &str,
        line: Option<usize>,
        v: &Value,
    ) -> Result<Vec<f64>, CoreError> {
        let l = self.lists(key, line, v)?;
        if l.len() != 1 {
            return Err(CoreError::scene(key, line, "expected one list of numbers"));
        }
        Ok(l.into_iter().next().unwrap_or_default())
    }

    /// `layer[i].particles`: one table or a list of tables.
    pub(super) fn particle_specs(
        &self,
        i: usize,
        v: &Spanned<Value>,
    ) -> Result<Vec<ParticleSpec>, CoreError> {
        let key = format!("layer[{}].particles", i + 1);
        let line = self.line(v.span());
        match v.get_ref() {
            Value::Table(t) => Ok(vec![self.particle_spec(&key, line, t)?]),
            Value::Array(items) if !items.is_empty() => items
                .iter()
                .enumerate()
                .map(|(j, x)| match x {
                    Value::Table(t) => self.particle_spec(&format!("{key}[{}]", j + 1), line, t),
                    _ => {
                        Err(CoreError::scene(key.clone(), line, "expected a table per population"))
                    }
                })
                .collect(),
            _ => Err(CoreError::scene(
                key,
                line,
                "expected a table { radius_um, n, k, volume_fraction } or a list of them",
            )),
        }
    }

    fn particle_spec(
        &self,
        key: &str,
        line: Option<usize>,
        t: &toml::Table,
    ) -> Result<ParticleSpec, CoreError> {
        only(key, line, t, &["radius_um", "n", "k", "volume_fraction", "distribution"])?;
        let n = self.need(t, key, "n", line)?;
        let k = match t.get("k") {
            Some(v) => self.coef_in(&format!("{key}.k"), line, v)?,
            None => Coef::constant(&format!("{key}.k"), 0.0),
        };
        let volume_fraction = self.need(t, key, "volume_fraction", line)?;
        let sizes = match t.get("distribution") {
            None => SizeSpec::Mono { radius_um: self.need(t, key, "radius_um", line)? },
            Some(Value::String(s)) if s == "mono" => {
                SizeSpec::Mono { radius_um: self.need(t, key, "radius_um", line)? }
            }
            Some(Value::Table(d)) => self.lognormal_spec(key, line, t, d)?,
            Some(_) => {
                return Err(CoreError::scene(
                    format!("{key}.distribution"),
                    line,
                    "expected \"mono\" or { lognormal = { median_um, sigma } }",
                ));
            }
        };
        let spec = ParticleSpec { key: key.into(), line, n, k, volume_fraction, sizes };
        spec.check()?;
        Ok(spec)
    }

    /// `distribution = { lognormal = { median_um, sigma | gsd } }`.
    fn lognormal_spec(
        &self,
        key: &str,
        line: Option<usize>,
        t: &toml::Table,
        d: &toml::Table,
    ) -> Result<SizeSpec, CoreError> {
        let dk = format!("{key}.distribution");
        only(&dk, line, d, &["lognormal"])?;
        let Some(Value::Table(ln)) = d.get("lognormal") else {
            return Err(CoreError::scene(
                dk,
                line,
                "expected { lognormal = { median_um, sigma } }",
            ));
        };
        if t.contains_key("radius_um") {
            return Err(CoreError::scene(
                format!("{key}.radius_um"),
                line,
                "a lognormal population takes its median radius in distribution.lognormal.median_um",
            ));
        }
        let lk = format!("{dk}.lognormal");
        only(&lk, line, ln, &["median_um", "sigma", "gsd"])?;
        let median_um = self.need(ln, &lk, "median_um", line)?;
        let sigma = match (ln.get("sigma"), ln.get("gsd")) {
            (Some(v), None) => self.coef_in(&format!("{lk}.sigma"), line, v)?,
            (None, Some(v)) => {
                // The geometric standard deviation: sigma = ln(gsd).
                let mut c = self.coef_in(&format!("{lk}.gsd"), line, v)?;
                if let Some(x) = c.values.iter().find(|x| !(**x > 1.0 && x.is_finite())) {
                    return Err(CoreError::scene(c.key, line, format!("{x}: gsd must be > 1")));
                }
                c.values.iter_mut().for_each(|x| *x = x.ln());
                c
            }
            _ => {
                return Err(CoreError::scene(
                    format!("{lk}.sigma"),
                    line,
                    "give sigma (the standard deviation of ln r) or gsd (exp(sigma)), one of them",
                ));
            }
        };
        Ok(SizeSpec::LogNormal { median_um, sigma })
    }
}

impl PhaseSpec {
    /// The per-channel values of the spec, for the channel count.
    pub(in crate::scene) fn coefs(&self) -> Vec<&Coef> {
        match self {
            PhaseSpec::Isotropic => vec![],
            PhaseSpec::Hg { g } => vec![g],
            PhaseSpec::TwoTerm { g1, g2, weight } => vec![g1, g2, weight],
            PhaseSpec::Rayleigh { rho } => vec![rho],
            PhaseSpec::ReynoldsMcCormick { g, alpha } => vec![g, alpha],
            PhaseSpec::Legendre { count, .. } | PhaseSpec::Table { count, .. } => vec![count],
        }
    }

    /// The phase function of channel `ch`.
    pub(in crate::scene) fn build(&self, ch: usize) -> Result<Phase, CoreError> {
        let at = |c: &Coef| c.at(ch);
        let named = |c: &Coef, e: CoreError| CoreError::scene(c.key.clone(), c.line, e.to_string());
        Ok(match self {
            PhaseSpec::Isotropic => Phase::Isotropic,
            PhaseSpec::Hg { g } => {
                Phase::from_anisotropy(Anisotropy::new(at(g)).map_err(|e| named(g, e))?)
            }
            PhaseSpec::TwoTerm { g1, g2, weight } => Phase::TwoTermHg(
                TwoTermHg::new(at(g1), at(g2), at(weight)).map_err(|e| named(weight, e))?,
            ),
            PhaseSpec::Rayleigh { rho } => {
                Phase::Rayleigh(Rayleigh::new(at(rho)).map_err(|e| named(rho, e))?)
            }
            PhaseSpec::ReynoldsMcCormick { g, alpha } => Phase::ReynoldsMcCormick(Arc::new(
                ReynoldsMcCormick::new(at(g), at(alpha)).map_err(|e| named(alpha, e))?,
            )),
            PhaseSpec::Legendre { key, line, moments, .. } => {
                let m = &moments[ch.min(moments.len() - 1)];
                let s = LegendreSeries::new(m)
                    .map_err(|e| CoreError::scene(key.clone(), *line, e.to_string()))?;
                Phase::Legendre(Arc::new(s))
            }
            PhaseSpec::Table { key, line, cos, p, .. } => {
                let pv = &p[ch.min(p.len() - 1)];
                let t = PhaseTable::new(cos, pv)
                    .map_err(|e| CoreError::scene(key.clone(), *line, e.to_string()))?;
                Phase::Table(Arc::new(t))
            }
        })
    }
}

impl ParticleSpec {
    /// The per-channel values, for the channel count.
    pub(in crate::scene) fn coefs(&self) -> Vec<&Coef> {
        let mut v = vec![&self.n, &self.k, &self.volume_fraction];
        match &self.sizes {
            SizeSpec::Mono { radius_um } => v.push(radius_um),
            SizeSpec::LogNormal { median_um, sigma } => v.extend([median_um, sigma]),
        }
        v
    }

    /// Every value in its domain (so the per-channel Mie call fails only on
    /// the size parameter).
    fn check(&self) -> Result<(), CoreError> {
        let each = |c: &Coef, ok: &dyn Fn(f64) -> bool, what: &str| -> Result<(), CoreError> {
            match c.values.iter().find(|x| !ok(**x)) {
                Some(x) => Err(CoreError::scene(c.key.clone(), c.line, format!("{x}: {what}"))),
                None => Ok(()),
            }
        };
        let positive = |x: f64| x.is_finite() && x > 0.0;
        each(&self.n, &positive, "the particles' index must be finite and > 0")?;
        each(&self.k, &|x| x.is_finite() && x >= 0.0, "k must be finite and >= 0")?;
        each(&self.volume_fraction, &|x| x > 0.0 && x < 1.0, "must lie in (0, 1)")?;
        match &self.sizes {
            SizeSpec::Mono { radius_um } => each(radius_um, &positive, "must be finite and > 0"),
            SizeSpec::LogNormal { median_um, sigma } => {
                each(median_um, &positive, "must be finite and > 0")?;
                each(sigma, &|x| positive(x) && x <= 2.0, "sigma (of ln r) must lie in (0, 2]")
            }
        }
    }

    /// The population at channel `ch`, and its optics in a host of index
    /// `host_n` at `wavelength_nm`.
    fn population(
        &self,
        ch: usize,
        host_n: f64,
        wavelength_nm: f64,
    ) -> Result<Population, CoreError> {
        let distribution = match &self.sizes {
            SizeSpec::Mono { radius_um } => SizeDistribution::Mono { radius_um: radius_um.at(ch) },
            SizeSpec::LogNormal { median_um, sigma } => {
                SizeDistribution::LogNormal { median_um: median_um.at(ch), sigma: sigma.at(ch) }
            }
        };
        let particles = Particles {
            index: Complex::new(self.n.at(ch), self.k.at(ch)),
            volume_fraction: self.volume_fraction.at(ch),
            distribution,
        };
        let optics: ParticleOptics = particle_optics(&particles, host_n, wavelength_nm)
            .map_err(|e| CoreError::scene(self.key.clone(), self.line, e.to_string()))?;
        Ok(Population { particles, host_n, wavelength_nm, optics })
    }
}

/// The particles of a layer at channel `ch`: `(sigma_s, sigma_a of the
/// particles, their volume fraction, the phase function)`, lengths in
/// micrometres (eq. M14, M15 of docs/mie.md).
pub(in crate::scene) fn particle_layer(
    specs: &[ParticleSpec],
    ch: usize,
    host_n: f64,
    wavelength_nm: Option<f64>,
) -> Result<(f64, f64, f64, Phase), CoreError> {
    let Some(wl) = wavelength_nm else {
        let s = &specs[0];
        return Err(CoreError::scene(
            s.key.clone(),
            s.line,
            "Mie theory needs the wavelength: give [spectrum] wavelengths_nm",
        ));
    };
    let pops: Vec<Population> =
        specs.iter().map(|s| s.population(ch, host_n, wl)).collect::<Result<_, _>>()?;
    let fv: f64 = pops.iter().map(|p| p.particles.volume_fraction).sum();
    if fv >= 1.0 {
        let s = &specs[0];
        return Err(CoreError::scene(
            s.key.clone(),
            s.line,
            format!("the volume fractions add up to {fv}: they must stay below 1"),
        ));
    }
    let sigma_s: f64 = pops.iter().map(|p| p.optics.sigma_s).sum();
    let sigma_a: f64 = pops.iter().map(|p| p.optics.sigma_a).sum();
    let phase = if sigma_s > 0.0 {
        let s = &specs[0];
        Phase::Particles(Arc::new(
            ParticlePhase::new(pops)
                .map_err(|e| CoreError::scene(s.key.clone(), s.line, e.to_string()))?,
        ))
    } else {
        Phase::Isotropic
    };
    Ok((sigma_s, sigma_a, fv, phase))
}
