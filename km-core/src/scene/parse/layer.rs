//! The parser's layers, substrate and output directions.

use toml::{Spanned, Value};

use super::phase::{ParticleSpec, PhaseSpec, particle_layer};
use super::{Coef, Parser, RawLayer, RawSubstrate, check_theta, scaled};
use crate::error::CoreError;
use crate::layer::{Layer, is_refractive_index};
use crate::phase::Anisotropy;
use crate::presets;

impl Parser {
    pub(super) fn layer(
        &self,
        i: usize,
        n_layers: usize,
        l: &RawLayer,
        ambient_n: &Coef,
        scale: f64,
    ) -> Result<LayerCoefs, CoreError> {
        let k = |name: &str| format!("layer[{}].{name}", i + 1);
        let sigma_a = self.opt_coef(&k("sigma_a"), &l.sigma_a)?.map(|c| scaled(c, 1.0 / scale));
        let sigma_s = self.opt_coef(&k("sigma_s"), &l.sigma_s)?.map(|c| scaled(c, 1.0 / scale));
        let thickness = self.opt_coef(&k("thickness"), &l.thickness)?.map(|c| scaled(c, scale));
        let tau = self.opt_coef(&k("tau"), &l.tau)?;
        let albedo = self.opt_coef(&k("albedo"), &l.albedo)?;
        let g_given = self.opt_coef(&k("g"), &l.g)?;
        let g = g_given.clone().unwrap_or(Coef::constant(&k("g"), 0.0));
        let n = self.opt_coef(&k("n"), &l.n)?;
        let is_last = i + 1 == n_layers;
        if let Some(p) = &l.particles {
            let specs = self.particle_specs(i, p)?;
            return self.particle_layer(i, is_last, l, specs, ambient_n);
        }
        let spec = self.layer_phase(i, l)?;

        // The layer's form: preset, (sigma_a, sigma_s, thickness), (tau,
        // albedo) or the tissue keys (parse/tissue.rs).
        let sigma_form = sigma_a.is_some() || sigma_s.is_some();
        let tau_form = tau.is_some() || albedo.is_some();
        let other = if sigma_form {
            Some("sigma_a/sigma_s")
        } else if tau_form {
            Some("tau/albedo")
        } else {
            l.preset.as_ref().map(|_| "preset")
        };
        let n_or_ambient =
            n.clone().unwrap_or(Coef { key: k("n"), line: None, values: ambient_n.values.clone() });
        let (t, gg) = (thickness.clone(), g_given);
        if let Some(mut t) = self.tissue_layer(i, is_last, l, other, t, gg, n_or_ambient, scale)? {
            // (mu_s_prime needs g, which a phase table excludes: refused above.)
            t.phase = spec;
            return Ok(t);
        }
        if let Some(p) = &l.preset {
            self.check_preset_alone(i, l, p, sigma_form, tau_form)?;
            return self.preset_layer(i, is_last, p, thickness, g, n, ambient_n);
        }
        if sigma_form && tau_form {
            let c = tau.as_ref().or(albedo.as_ref()).map(|c| (c.key.clone(), c.line));
            let (key, line) = c.unwrap_or((k("tau"), None));
            return Err(CoreError::scene(
                key,
                line,
                "give either sigma_a, sigma_s, thickness or tau, albedo, not both",
            ));
        }
        let n = n.unwrap_or(Coef { key: k("n"), line: None, values: ambient_n.values.clone() });
        if tau_form {
            let mut lay = self.tau_layer(i, is_last, tau, albedo, thickness.as_ref(), g, n)?;
            lay.phase = spec;
            return Ok(lay);
        }
        let missing = |name: &str| {
            CoreError::scene(
                k(name),
                None,
                "missing: a layer needs sigma_a, sigma_s and thickness (or tau and albedo, or a preset)",
            )
        };
        let sigma_a = sigma_a.ok_or_else(|| missing("sigma_a"))?;
        let sigma_s = sigma_s.ok_or_else(|| missing("sigma_s"))?;
        let thickness = thickness.ok_or_else(|| missing("thickness"))?;
        let mut lay =
            self.finish_layer(i, is_last, Form::Sigma, sigma_a, sigma_s, thickness, g, n)?;
        lay.phase = spec;
        Ok(lay)
    }

    /// Refuses a preset beside the keys it gives (sigma_a, sigma_s or tau,
    /// albedo) or beside a `phase` table.
    fn check_preset_alone(
        &self,
        i: usize,
        l: &RawLayer,
        p: &Spanned<String>,
        sigma_form: bool,
        tau_form: bool,
    ) -> Result<(), CoreError> {
        let k = |name: &str| format!("layer[{}].{name}", i + 1);
        let line = self.line(p.span());
        if sigma_form || tau_form {
            let key = if sigma_form { k("sigma_a") } else { k("tau") };
            return Err(CoreError::scene(
                key,
                line,
                "a preset gives sigma_a and sigma_s: remove them or the preset",
            ));
        }
        if let Some(ph) = &l.phase {
            return Err(CoreError::scene(
                k("phase"),
                self.line(ph.span()),
                "a preset layer takes g only (its sigma_s is sigma_s' / (1 - g))",
            ));
        }
        Ok(())
    }

    /// A layer of the tau form (tau, albedo; no thickness).
    #[allow(clippy::too_many_arguments)]
    fn tau_layer(
        &self,
        i: usize,
        is_last: bool,
        tau: Option<Coef>,
        albedo: Option<Coef>,
        thickness: Option<&Coef>,
        g: Coef,
        n: Coef,
    ) -> Result<LayerCoefs, CoreError> {
        let k = |name: &str| format!("layer[{}].{name}", i + 1);
        if let Some(t) = thickness {
            return Err(CoreError::scene(
                t.key.clone(),
                t.line,
                "the tau form takes no thickness (tau = sigma_t * thickness)",
            ));
        }
        let missing =
            |name: &str| CoreError::scene(k(name), None, "the tau form needs both tau and albedo");
        let tau = tau.ok_or_else(|| missing("tau"))?;
        let albedo = albedo.ok_or_else(|| missing("albedo"))?;
        self.finish_layer(
            i,
            is_last,
            Form::Tau,
            tau,
            albedo,
            Coef::constant(&k("thickness"), 1.0),
            g,
            n,
        )
    }

    /// The layer's `phase` table, refused beside `g` (docs/scene-file.md).
    fn layer_phase(&self, i: usize, l: &RawLayer) -> Result<Option<PhaseSpec>, CoreError> {
        let Some(p) = &l.phase else { return Ok(None) };
        if let Some(g) = &l.g {
            return Err(CoreError::scene(
                format!("layer[{}].g", i + 1),
                self.line(g.span()),
                "give either g (Henyey-Greenstein) or phase = { kind = ... }, not both",
            ));
        }
        Ok(Some(self.phase_spec(i, p)?))
    }

    /// A layer of particles in a host (docs/mie.md): `thickness`, the host's
    /// `sigma_a` (default 0) and `n`; the particles give `sigma_s`, their own
    /// absorption and the phase function per channel (lengths in micrometres).
    fn particle_layer(
        &self,
        i: usize,
        is_last: bool,
        l: &RawLayer,
        specs: Vec<ParticleSpec>,
        ambient_n: &Coef,
    ) -> Result<LayerCoefs, CoreError> {
        let k = |name: &str| format!("layer[{}].{name}", i + 1);
        let clash = [
            ("sigma_s", l.sigma_s.as_ref().map(|v| v.span())),
            ("tau", l.tau.as_ref().map(|v| v.span())),
            ("albedo", l.albedo.as_ref().map(|v| v.span())),
            ("g", l.g.as_ref().map(|v| v.span())),
            ("phase", l.phase.as_ref().map(|v| v.span())),
            ("preset", l.preset.as_ref().map(|v| v.span())),
            ("mu_a", l.mu_a.as_ref().map(|v| v.span())),
            ("mu_s", l.mu_s.as_ref().map(|v| v.span())),
            ("mu_s_prime", l.mu_s_prime.as_ref().map(|v| v.span())),
        ];
        if let Some((name, Some(span))) = clash.iter().find(|c| c.1.is_some()) {
            return Err(CoreError::scene(
                k(name),
                self.line(span.clone()),
                "a layer with particles takes thickness, sigma_a (the host's absorption) and n \
                 only: the particles give sigma_s and the phase function",
            ));
        }
        let sigma_a =
            self.opt_coef(&k("sigma_a"), &l.sigma_a)?.unwrap_or(Coef::constant(&k("sigma_a"), 0.0));
        let thickness = self.opt_coef(&k("thickness"), &l.thickness)?.ok_or_else(|| {
            CoreError::scene(
                k("thickness"),
                None,
                "a layer with particles needs a thickness (micrometres)",
            )
        })?;
        let n = self.opt_coef(&k("n"), &l.n)?;
        let n = n.unwrap_or(Coef { key: k("n"), line: None, values: ambient_n.values.clone() });
        let sigma_s = Coef::constant(&k("particles"), 0.0);
        let g = Coef::constant(&k("g"), 0.0);
        let mut lay =
            self.finish_layer(i, is_last, Form::Sigma, sigma_a, sigma_s, thickness, g, n)?;
        lay.particles = Some(specs);
        Ok(lay)
    }

    /// A layer given by a measured preset (`docs/scene-file.md`): its
    /// `sigma_a`, `sigma_s = sigma_s' / (1 - g)` and index; a half-space when
    /// it is the last layer and has no thickness.
    #[allow(clippy::too_many_arguments)]
    fn preset_layer(
        &self,
        i: usize,
        is_last: bool,
        p: &Spanned<String>,
        thickness: Option<Coef>,
        g: Coef,
        mut n: Option<Coef>,
        ambient_n: &Coef,
    ) -> Result<LayerCoefs, CoreError> {
        let k = |name: &str| format!("layer[{}].{name}", i + 1);
        let line = self.line(p.span());
        let Some(m) = presets::lookup(p.get_ref()) else {
            return Err(CoreError::scene(
                k("preset"),
                line,
                format!(
                    "unknown preset \"{}\" (known: {})",
                    p.get_ref(),
                    presets::names().join(", ")
                ),
            ));
        };
        // sigma_s = sigma_s' / (1 - g): the preset gives the reduced coefficient.
        let mut s = Vec::with_capacity(3);
        for c in 0..3 {
            // A g list of another length is refused later with the list-length rule.
            let gc = g.values[c.min(g.values.len() - 1)];
            s.push(m.sigma_s_prime[c] / (1.0 - gc.clamp(-0.999_999, 0.999_999)));
        }
        if n.is_none() {
            n = Some(Coef { key: k("n"), line, values: vec![m.eta] });
        }
        let thickness = match thickness {
            Some(t) => t,
            None => {
                if !is_last {
                    return Err(CoreError::scene(
                        k("thickness"),
                        line,
                        "a preset layer that is not the last needs a thickness",
                    ));
                }
                Coef { key: k("thickness"), line, values: vec![f64::INFINITY] }
            }
        };
        self.finish_layer(
            i,
            is_last,
            Form::Sigma,
            Coef { key: k("sigma_a"), line, values: m.sigma_a.to_vec() },
            Coef { key: k("sigma_s"), line, values: s },
            thickness,
            g,
            n.unwrap_or(Coef { key: k("n"), line: None, values: ambient_n.values.clone() }),
        )
    }

    #[allow(clippy::too_many_arguments)]
    pub(super) fn finish_layer(
        &self,
        i: usize,
        is_last: bool,
        form: Form,
        a: Coef,
        b: Coef,
        thickness: Coef,
        g: Coef,
        n: Coef,
    ) -> Result<LayerCoefs, CoreError> {
        // Domain checks value by value, so the message names key and line.
        let check = |c: &Coef, ok: &dyn Fn(f64) -> bool, what: &str| -> Result<(), CoreError> {
            for &x in &c.values {
                if !ok(x) {
                    return Err(CoreError::scene(c.key.clone(), c.line, format!("{x}: {what}")));
                }
            }
            Ok(())
        };
        match form {
            Form::Sigma => {
                check(&a, &|x| x.is_finite() && x >= 0.0, "must be finite and >= 0")?;
                check(&b, &|x| x.is_finite() && x >= 0.0, "must be finite and >= 0")?;
                check(&thickness, &|x| x >= 0.0, "must be >= 0 (or \"inf\" for a half-space)")?;
                // sigma_t = sigma_a + sigma_s and tau = sigma_t * thickness must be
                // representable: 1e308 + 1e308 overflows, and the methods then
                // disagree (R = 0 or R = 1) instead of failing.
                let len = a.values.len().max(b.values.len()).max(thickness.values.len());
                // Lists of different lengths are refused later, with their lines.
                let same = [&a, &b, &thickness]
                    .iter()
                    .all(|c| matches!(c.values.len(), 1) || c.values.len() == len);
                for c in (0..len).filter(|_| same) {
                    let (sa, ss, d) = (a.at(c), b.at(c), thickness.at(c));
                    let sigma_t = sa + ss;
                    if !sigma_t.is_finite() {
                        return Err(CoreError::scene(
                            b.key.clone(),
                            b.line,
                            format!(
                                "sigma_a + sigma_s = {sa:e} + {ss:e} overflows (> {:e}); \
                                 rescale the length unit",
                                f64::MAX
                            ),
                        ));
                    }
                    if d.is_finite() && !(sigma_t * d).is_finite() {
                        return Err(CoreError::scene(
                            thickness.key.clone(),
                            thickness.line,
                            format!(
                                "the optical thickness (sigma_a + sigma_s) * thickness = \
                                 {sigma_t:e} * {d:e} overflows; give thickness = \"inf\" for an \
                                 opaque half-space or rescale the length unit"
                            ),
                        ));
                    }
                }
            }
            Form::Tau => {
                check(&a, &|x| x >= 0.0, "must be >= 0 (or \"inf\" for a half-space)")?;
                check(&b, &|x| (0.0..=1.0).contains(&x), "albedo must lie in [0, 1]")?;
            }
        }
        check(&g, &Anisotropy::admits, "|g| must be < 1")?;
        check(&n, &is_refractive_index, "refractive index must be finite and >= 1")?;
        let half = match form {
            Form::Sigma => thickness.values.iter().any(|x| x.is_infinite()),
            Form::Tau => a.values.iter().any(|x| x.is_infinite()),
        };
        if half && !is_last {
            let c = if form == Form::Sigma { &thickness } else { &a };
            return Err(CoreError::scene(
                c.key.clone(),
                c.line,
                "only the last layer may be a half-space (inf)",
            ));
        }
        let _ = i;
        Ok(LayerCoefs { form, a, b, thickness, g, n, phase: None, particles: None })
    }

    pub(super) fn substrate(
        &self,
        s: Option<&RawSubstrate>,
        ambient_n: &Coef,
    ) -> Result<RawSub, CoreError> {
        let Some(s) = s else {
            // Default: a clear half-space of the ambient index.
            return Ok(RawSub::Transparent(Coef {
                key: "substrate.n".into(),
                line: None,
                values: ambient_n.values.clone(),
            }));
        };
        let kind = s.kind.as_ref().map(|k| (k.get_ref().as_str(), self.line(k.span())));
        let unexpected = |c: &Option<Spanned<Value>>, key: &str, kind: &str| match c {
            Some(v) => Err(CoreError::scene(
                key,
                self.line(v.span()),
                format!("a {kind} substrate takes no {}", key.trim_start_matches("substrate.")),
            )),
            None => Ok(()),
        };
        if !matches!(kind, Some(("conductor", _))) {
            let kind_name = kind.map_or("transparent", |k| k.0);
            unexpected(&s.k, "substrate.k", kind_name)?;
            if let Some(m) = &s.metal {
                return Err(CoreError::scene(
                    "substrate.metal",
                    self.line(m.span()),
                    format!("a {kind_name} substrate takes no metal (use kind = \"conductor\")"),
                ));
            }
        }
        match kind {
            None | Some(("transparent", _)) => {
                unexpected(&s.albedo, "substrate.albedo", "transparent")?;
                Ok(RawSub::Transparent(match &s.n {
                    Some(v) => self.coef("substrate.n", v)?,
                    None => Coef {
                        key: "substrate.n".into(),
                        line: None,
                        values: ambient_n.values.clone(),
                    },
                }))
            }
            Some(("lambertian", line)) => {
                unexpected(&s.n, "substrate.n", "lambertian")?;
                match &s.albedo {
                    Some(v) => Ok(RawSub::Lambertian(self.coef("substrate.albedo", v)?)),
                    None => Err(CoreError::scene(
                        "substrate.albedo",
                        line,
                        "a lambertian substrate needs an albedo",
                    )),
                }
            }
            Some(("black", _)) => {
                unexpected(&s.n, "substrate.n", "black")?;
                unexpected(&s.albedo, "substrate.albedo", "black")?;
                Ok(RawSub::Black)
            }
            Some(("conductor", line)) => self.conductor(s, line),
            Some((other, line)) => Err(CoreError::scene(
                "substrate.kind",
                line,
                format!(
                    "unknown kind \"{other}\" (expected \"transparent\", \"lambertian\", \
                     \"black\" or \"conductor\")"
                ),
            )),
        }
    }

    pub(super) fn directions(&self, v: &Spanned<Value>) -> Result<Vec<[f64; 2]>, CoreError> {
        let key = "output.directions_deg";
        let line = self.line(v.span());
        let Value::Array(items) = v.get_ref() else {
            return Err(CoreError::scene(key, line, "expected a list of [theta, phi] pairs"));
        };
        let mut out = Vec::with_capacity(items.len());
        for item in items {
            let pair = match item {
                Value::Array(p) if p.len() == 2 => p,
                _ => {
                    return Err(CoreError::scene(
                        key,
                        line,
                        "each direction is a pair [theta, phi] in degrees",
                    ));
                }
            };
            let theta = self.number(key, line, &pair[0])?;
            let phi = self.number(key, line, &pair[1])?;
            check_theta(key, theta, line)?;
            if !phi.is_finite() {
                return Err(CoreError::scene(key, line, format!("phi = {phi} must be finite")));
            }
            out.push([theta, phi]);
        }
        Ok(out)
    }

    /// `[output] inside_directions_deg`: pairs `[theta, phi]` in degrees,
    /// `theta` in `[0, 180]` from the downward normal but not 90, `phi` finite.
    pub(super) fn inside_directions(&self, v: &Spanned<Value>) -> Result<Vec<[f64; 2]>, CoreError> {
        let key = "output.inside_directions_deg";
        let line = self.line(v.span());
        let Value::Array(items) = v.get_ref() else {
            return Err(CoreError::scene(key, line, "expected a list of [theta, phi] pairs"));
        };
        let mut out = Vec::with_capacity(items.len());
        for item in items {
            let Value::Array(pair) = item else {
                return Err(CoreError::scene(key, line, "each direction is a pair [theta, phi]"));
            };
            if pair.len() != 2 {
                return Err(CoreError::scene(key, line, "each direction is a pair [theta, phi]"));
            }
            let theta = self.number(key, line, &pair[0])?;
            let phi = self.number(key, line, &pair[1])?;
            if !(0.0..=180.0).contains(&theta) || theta == 90.0 {
                return Err(CoreError::scene(
                    key,
                    line,
                    format!(
                        "theta = {theta} must lie in [0, 180] degrees from the downward normal \
                         (< 90 down-going, > 90 up-going) and not be 90"
                    ),
                ));
            }
            if !phi.is_finite() {
                return Err(CoreError::scene(key, line, format!("phi = {phi} must be finite")));
            }
            out.push([theta, phi]);
        }
        if out.len() > 10_000 {
            return Err(CoreError::scene(key, line, "at most 10000 directions"));
        }
        Ok(out)
    }
}

#[derive(Clone, Copy, PartialEq)]
pub(super) enum Form {
    /// a = sigma_a, b = sigma_s
    Sigma,
    /// a = tau, b = albedo
    Tau,
}

pub(super) struct LayerCoefs {
    form: Form,
    pub(super) a: Coef,
    pub(super) b: Coef,
    pub(super) thickness: Coef,
    pub(super) g: Coef,
    pub(super) n: Coef,
    /// A phase function other than `g` (docs/phase.md).
    phase: Option<PhaseSpec>,
    /// Particles by Mie theory (docs/mie.md): they give `sigma_s` and the phase.
    particles: Option<Vec<ParticleSpec>>,
}

impl LayerCoefs {
    /// Every per-channel value of the layer, for the channel count.
    pub(super) fn coefs(&self) -> Vec<&Coef> {
        let mut v = vec![&self.a, &self.b, &self.thickness, &self.g, &self.n];
        if let Some(p) = &self.phase {
            v.extend(p.coefs());
        }
        for s in self.particles.iter().flatten() {
            v.extend(s.coefs());
        }
        v
    }

    /// The layer of channel `ch` (`wavelength_nm` of the channel, needed by particles).
    pub(super) fn build(&self, ch: usize, wavelength_nm: Option<f64>) -> Result<Layer, CoreError> {
        let g = self.g.at(ch);
        let n = self.n.at(ch);
        let at_key =
            |e: CoreError| CoreError::scene(self.a.key.clone(), self.a.line, e.to_string());
        if let Some(specs) = &self.particles {
            // The host fills the volume the particles leave (docs/mie.md eq. M18).
            let (sigma_s, sigma_a, fv, phase) = particle_layer(specs, ch, n, wavelength_nm)?;
            let sa = self.a.at(ch) * (1.0 - fv) + sigma_a;
            return Layer::from_phase(sa, sigma_s, self.thickness.at(ch), phase, n).map_err(at_key);
        }
        if let Some(spec) = &self.phase {
            let phase = spec.build(ch)?;
            let r = match self.form {
                Form::Sigma => {
                    Layer::from_phase(self.a.at(ch), self.b.at(ch), self.thickness.at(ch), phase, n)
                }
                Form::Tau => Layer::from_tau_albedo(self.a.at(ch), self.b.at(ch), 0.0, n)
                    .map(|l| l.with_phase(phase)),
            };
            return r.map_err(at_key);
        }
        let r = match self.form {
            Form::Sigma => Layer::new(self.a.at(ch), self.b.at(ch), self.thickness.at(ch), g, n),
            Form::Tau => Layer::from_tau_albedo(self.a.at(ch), self.b.at(ch), g, n),
        };
        // The checks above make this unreachable, but keep the line in any message.
        r.map_err(|e| CoreError::scene(self.a.key.clone(), self.a.line, e.to_string()))
    }
}

pub(super) enum RawSub {
    Transparent(Coef),
    Lambertian(Coef),
    Black,
    /// A conductor of complex index `n + i k` (per channel).
    Conductor(Coef, Coef),
    /// A named metal (docs/rough.md §5) and the line of its name.
    Metal(String, Option<usize>),
}
