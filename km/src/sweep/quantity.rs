//! The quantities a sweep varies, typed: one grammar of sweep keys for
//! `km sweep` and Python's `km.solve_many(..., params=...)`, and the edit of
//! a parsed scene at one point (no scene text is written or read again).
//!
//! A key is spelled as the scene file's messages spell it, with 1-based
//! layer numbers: `layer[i].sigma_a | sigma_s | thickness | tau | albedo |
//! g | n | roughness`, `light.theta_deg`, `ambient.n`, `substrate.n | k |
//! albedo | roughness`. A value applies to every channel.

use std::str::FromStr;

use km_core::microfacet::{Distribution, Microfacet};
use km_core::phase::Phase;
use km_core::{CoreError, Layer, Light, MonoScene, Scene, Solution, Substrate};
use rayon::prelude::*;

use crate::{KmError, Options};

/// A quantity of one layer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LayerField {
    /// Absorption coefficient `sigma_a`, 1/length.
    SigmaA,
    /// Scattering coefficient `sigma_s`, 1/length.
    SigmaS,
    /// Geometric thickness (`inf`: a half-space).
    Thickness,
    /// Optical thickness, keeping the albedo and the thickness (the
    /// coefficients scaled); a half-space or a layer of zero thickness
    /// becomes a layer of unit thickness, as `tau` in a scene file.
    Tau,
    /// Single-scattering albedo, keeping `tau` (and the thickness).
    Albedo,
    /// Henyey–Greenstein asymmetry (replacing any phase function).
    G,
    /// Refractive index.
    N,
    /// Roughness `alpha` of the layer's top face (0: smooth), with the
    /// face's distribution (GGX when it was smooth).
    Roughness,
}

impl LayerField {
    /// Every field, in the order of the messages.
    const ALL: [LayerField; 8] = [
        LayerField::SigmaA,
        LayerField::SigmaS,
        LayerField::Thickness,
        LayerField::Tau,
        LayerField::Albedo,
        LayerField::G,
        LayerField::N,
        LayerField::Roughness,
    ];

    /// The scene file's name of the field.
    pub fn name(self) -> &'static str {
        match self {
            LayerField::SigmaA => "sigma_a",
            LayerField::SigmaS => "sigma_s",
            LayerField::Thickness => "thickness",
            LayerField::Tau => "tau",
            LayerField::Albedo => "albedo",
            LayerField::G => "g",
            LayerField::N => "n",
            LayerField::Roughness => "roughness",
        }
    }

    /// `layer` with this field set to `v`, checked as the layer's constructors check.
    fn set(self, l: &Layer, v: f64) -> Result<Layer, CoreError> {
        // `tau` and `albedo` through the scene file's form 2 (unit thickness),
        // the phase function and the face kept.
        let form2 = |tau: f64, albedo: f64| {
            Layer::from_tau_albedo(tau, albedo, l.g(), l.n())
                .map(|x| x.with_phase(l.phase().clone()).with_roughness(l.roughness()))
        };
        let scaled = |tau: f64, albedo: f64| {
            let d = l.thickness();
            if l.is_half_space() || d == 0.0 || tau.is_infinite() {
                return form2(tau, albedo);
            }
            if tau.is_nan() || tau < 0.0 {
                return Err(CoreError::invalid("tau", tau, "must be >= 0 or inf"));
            }
            if !(0.0..=1.0).contains(&albedo) {
                return Err(CoreError::invalid("albedo", albedo, "must lie in [0, 1]"));
            }
            l.with_coefficients(tau * (1.0 - albedo) / d, tau * albedo / d)
        };
        match self {
            LayerField::SigmaA => l.with_coefficients(v, l.sigma_s()),
            LayerField::SigmaS => l.with_coefficients(l.sigma_a(), v),
            LayerField::Thickness => l.with_thickness(v),
            LayerField::Tau => scaled(v, l.albedo()),
            LayerField::Albedo => {
                scaled(if l.is_half_space() { f64::INFINITY } else { l.tau() }, v)
            }
            LayerField::G => Phase::henyey_greenstein(v).map(|p| l.with_phase(p)),
            LayerField::N => l.with_n(v),
            LayerField::Roughness => Ok(l.with_roughness(face(l.roughness(), v)?)),
        }
    }
}

/// A face of roughness `alpha` (0: smooth) with the distribution of `old`
/// (GGX when `old` is smooth).
fn face(old: Option<Microfacet>, alpha: f64) -> Result<Option<Microfacet>, CoreError> {
    if alpha == 0.0 {
        return Ok(None);
    }
    let dist = old.map_or(Distribution::Ggx, |m| m.distribution());
    Microfacet::new(alpha, dist).map(Some)
}

/// One quantity of a scene a sweep varies (a typed sweep key).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// A field of layer `index` (0-based here; 1-based in the key).
    Layer {
        /// Layer index, 0-based, top first.
        index: usize,
        /// Which field.
        field: LayerField,
    },
    /// `light.theta_deg` (collimated light).
    LightTheta,
    /// `ambient.n`.
    AmbientN,
    /// `substrate.n` (transparent substrate, or a conductor's real part).
    SubstrateN,
    /// `substrate.k` (a conductor's imaginary part).
    SubstrateK,
    /// `substrate.albedo` (Lambertian substrate).
    SubstrateAlbedo,
    /// `substrate.roughness` (transparent or conductor substrate).
    SubstrateRoughness,
}

/// The keys of the message of an unknown key.
const EXPECTED: &str = "expected layer[i].sigma_a|sigma_s|thickness|tau|albedo|g|n|roughness, \
                        light.theta_deg, ambient.n, substrate.n|k|albedo|roughness; i from 1";

impl FromStr for Quantity {
    type Err = KmError;

    /// Parse a sweep key (`layer[2].g`, 1-based layer number).
    ///
    /// # Errors
    /// A scene error on the key: `unknown sweep key (expected ...)`.
    fn from_str(key: &str) -> Result<Self, KmError> {
        let bad = || {
            KmError::Scene(CoreError::scene(key, None, format!("unknown sweep key ({EXPECTED})")))
        };
        match key {
            "light.theta_deg" => return Ok(Quantity::LightTheta),
            "ambient.n" => return Ok(Quantity::AmbientN),
            "substrate.n" => return Ok(Quantity::SubstrateN),
            "substrate.k" => return Ok(Quantity::SubstrateK),
            "substrate.albedo" => return Ok(Quantity::SubstrateAlbedo),
            "substrate.roughness" => return Ok(Quantity::SubstrateRoughness),
            _ => {}
        }
        let rest = key.strip_prefix("layer[").ok_or_else(bad)?;
        let (num, name) = rest.split_once("].").ok_or_else(bad)?;
        let number: usize = num.parse().map_err(|_| bad())?;
        let field = LayerField::ALL.into_iter().find(|f| f.name() == name).ok_or_else(bad)?;
        match number {
            0 => Err(bad()),
            _ => Ok(Quantity::Layer { index: number - 1, field }),
        }
    }
}

impl Quantity {
    /// The sweep key (`layer[1].tau`, ...), as parsed.
    ///
    /// ```
    /// let q: km::sweep::Quantity = "layer[2].g".parse().unwrap();
    /// assert_eq!(q.key(), "layer[2].g");
    /// ```
    pub fn key(&self) -> String {
        match *self {
            Quantity::Layer { index, field } => format!("layer[{}].{}", index + 1, field.name()),
            Quantity::LightTheta => "light.theta_deg".into(),
            Quantity::AmbientN => "ambient.n".into(),
            Quantity::SubstrateN => "substrate.n".into(),
            Quantity::SubstrateK => "substrate.k".into(),
            Quantity::SubstrateAlbedo => "substrate.albedo".into(),
            Quantity::SubstrateRoughness => "substrate.roughness".into(),
        }
    }

    /// Channel `c` with this quantity set to `v`.
    fn set(self, c: &MonoScene, v: f64) -> Result<MonoScene, KmError> {
        let key = self.key();
        let refuse = |what: &str| KmError::Scene(CoreError::scene(key.clone(), None, what));
        // A scene error keeps its key (without a line: it is no file's);
        // another (a layer's `invalid g`) is put at the swept key.
        let named = |e: CoreError| {
            KmError::Scene(match e {
                CoreError::Scene { key, message, .. } => {
                    CoreError::Scene { key, line: None, message }
                }
                other => CoreError::scene(key.clone(), None, other.to_string()),
            })
        };
        if v.is_nan() {
            return Err(refuse("NaN is not a value"));
        }
        match (self, c.substrate()) {
            (Quantity::Layer { index, field }, _) => {
                let mut layers = c.layers().to_vec();
                let count = layers.len();
                let l = layers
                    .get_mut(index)
                    .ok_or_else(|| refuse(&format!("the stack has {count} layer(s)")))?;
                *l = field.set(l, v).map_err(named)?;
                c.with_layers(layers).map_err(named)
            }
            (Quantity::LightTheta, _) => match c.light() {
                Light::Collimated { .. } => c.with_light(Light::Collimated { theta_deg: v }),
                Light::Diffuse => return Err(refuse("diffuse light has no angle")),
            }
            .map_err(named),
            (Quantity::AmbientN, _) => c.with_ambient_n(v).map_err(named),
            (Quantity::SubstrateN, Substrate::Transparent { .. }) => {
                c.with_substrate(Substrate::Transparent { n: v }).map_err(named)
            }
            (Quantity::SubstrateN, Substrate::Conductor { k, .. }) => {
                c.with_substrate(Substrate::Conductor { n: v, k }).map_err(named)
            }
            (Quantity::SubstrateN, _) => {
                Err(refuse("only a transparent or conductor substrate has an index"))
            }
            (Quantity::SubstrateK, Substrate::Conductor { n, .. }) => {
                c.with_substrate(Substrate::Conductor { n, k: v }).map_err(named)
            }
            (Quantity::SubstrateK, _) => Err(refuse("only a conductor substrate has a k")),
            (Quantity::SubstrateAlbedo, Substrate::Lambertian { .. }) => {
                c.with_substrate(Substrate::Lambertian { albedo: v }).map_err(named)
            }
            (Quantity::SubstrateAlbedo, _) => {
                Err(refuse("only a lambertian substrate has an albedo"))
            }
            (Quantity::SubstrateRoughness, _) => {
                let f = face(c.substrate_roughness(), v).map_err(named)?;
                c.with_substrate_roughness(f).map_err(named)
            }
        }
    }
}

/// Parse sweep keys ([`Quantity::from_str`]), in order.
///
/// # Errors
/// The first key's error that is no sweep key.
pub fn quantities<S: AsRef<str>>(keys: &[S]) -> Result<Vec<Quantity>, KmError> {
    keys.iter().map(|k| k.as_ref().parse()).collect()
}

/// A copy of `base` with `values` set (each quantity in every channel, in
/// order), checked as a scene's values are checked on construction.
///
/// # Errors
/// A quantity the scene does not have (a layer beyond the stack, the angle of
/// diffuse light, the albedo of a transparent substrate) or a value outside
/// its domain, a scene error naming the key.
///
/// ```
/// use km::sweep::{Quantity, apply};
/// let base = km::Scene::from_toml_str("[[layer]]\ntau = 1.0\nalbedo = 0.9\n").unwrap();
/// let tau: Quantity = "layer[1].tau".parse().unwrap();
/// let s = apply(&base, &[(tau, 2.0)]).unwrap();
/// assert!((s.channels()[0].layers()[0].tau() - 2.0).abs() < 1e-15);
/// assert!((s.channels()[0].layers()[0].albedo() - 0.9).abs() < 1e-15);
/// ```
pub fn apply(base: &Scene, values: &[(Quantity, f64)]) -> Result<Scene, KmError> {
    let mut channels = Vec::with_capacity(base.channels().len());
    for c in base.channels() {
        let mut c = c.clone();
        for &(q, v) in values {
            c = q.set(&c, v)?;
        }
        channels.push(c);
    }
    Ok(base.with_channels(channels)?)
}

/// Solve `base` at every point of `values` (point-major, one value per
/// quantity), each point [`apply`] then [`crate::solve_repeated`] with
/// `repeat`, in parallel on the current rayon pool; the answers in the order
/// of the points. The whole call is one request under one budget
/// (`docs/limits.md` eq. L4, [`crate::request_budget::check_points`], the
/// base scene standing for every point), checked before any point is solved.
///
/// # Errors
/// No quantity, a `values` length that is not a multiple of their number,
/// the budget, or a raised cancel flag at any point ([`KmError::Cancelled`]:
/// a batch cut short is no answer); each point's own error is in its slot.
///
/// ```
/// let base = km::Scene::from_toml_str("[[layer]]\ntau = 1.0\nalbedo = 0.9\n").unwrap();
/// let q = km::sweep::quantities(&["layer[1].g"]).unwrap();
/// let opts = km::Options::new(km::Method::Km);
/// let r = km::sweep::solve_points(&base, &q, &[0.0, 0.5, 1.5], &opts, 1).unwrap();
/// assert!(r[0].is_ok() && r[1].is_ok() && r[2].is_err());
/// ```
pub fn solve_points(
    base: &Scene,
    quantities: &[Quantity],
    values: &[f64],
    options: &Options,
    repeat: u32,
) -> Result<Vec<Result<Solution, KmError>>, KmError> {
    let k = quantities.len();
    if k == 0 || !values.len().is_multiple_of(k) {
        return Err(KmError::Scene(CoreError::scene(
            "params",
            None,
            "need at least one key and one value per key",
        )));
    }
    crate::request_budget::check_points(base, values.len() / k, options, 0.0)?;
    let results: Vec<Result<Solution, KmError>> = values
        .par_chunks(k)
        .map(|row| {
            let pairs: Vec<(Quantity, f64)> =
                quantities.iter().copied().zip(row.iter().copied()).collect();
            apply(base, &pairs).and_then(|s| crate::solve_repeated(&s, options, repeat))
        })
        .collect();
    if results.iter().any(|r| r.as_ref().is_err_and(KmError::is_cancelled)) {
        return Err(KmError::Cancelled);
    }
    Ok(results)
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
    fn keys_round_trip() {
        for key in [
            "layer[3].g",
            "layer[1].sigma_a",
            "layer[12].roughness",
            "light.theta_deg",
            "ambient.n",
            "substrate.albedo",
            "substrate.k",
            "substrate.roughness",
        ] {
            assert_eq!(key.parse::<Quantity>().unwrap().key(), key);
        }
    }

    /// Every malformed key is refused naming itself, in one message.
    #[test]
    fn bad_keys_are_refused_naming_the_key() {
        for key in [
            "layer[0].g",
            "layer[1].gg",
            "layer.g",
            "layer[1]g",
            "layer[x].g",
            "layer[-1].g",
            "layer[1].",
            "ambient",
            "light.kind",
            "Layer[1].g",
            " layer[1].g",
            "",
        ] {
            let e = key.parse::<Quantity>().unwrap_err();
            match &e {
                KmError::Scene(CoreError::Scene { key: k, line: None, message }) => {
                    assert_eq!(k, key);
                    assert!(message.starts_with("unknown sweep key (expected layer[i]"), "{e}");
                }
                other => panic!("{key}: {other:?}"),
            }
        }
        let e = quantities(&["layer[1].g", "substrate.x"]).unwrap_err();
        assert!(e.to_string().contains("substrate.x"), "{e}");
    }

    #[test]
    fn a_swept_scene_equals_the_scene_file_with_that_value() {
        // Independent route: the same values written into the file.
        let q = quantities(&["layer[1].g", "layer[1].tau", "light.theta_deg"]).unwrap();
        let swept = apply(&slab(), &[(q[0], 0.7), (q[1], 3.0), (q[2], 50.0)]).unwrap();
        let file = Scene::from_toml_str(
            "[light]\ntheta_deg = 50.0\n[[layer]]\ntau = 3.0\nalbedo = 0.9\ng = 0.7\nn = 1.5\n\
             [output]\ndirections_deg = [[0.0, 0.0], [40.0, 180.0]]\n",
        )
        .unwrap();
        let (a, b) = (&swept.channels()[0].layers()[0], &file.channels()[0].layers()[0]);
        // sigma_s = tau * albedo is recomputed from the albedo kept, so the two
        // routes agree to rounding (a few ulp), not bit for bit.
        assert!((a.tau() - b.tau()).abs() < 1e-14 && (a.albedo() - b.albedo()).abs() < 1e-14);
        assert_eq!((a.g(), a.thickness()), (b.g(), b.thickness()));
        assert_eq!(swept.channels()[0].light(), file.channels()[0].light());
        let opts = Options::new(crate::Method::Multiflux);
        let (x, y) = (crate::solve(&swept, &opts).unwrap(), crate::solve(&file, &opts).unwrap());
        assert!((x.channels[0].reflectance - y.channels[0].reflectance).abs() < 1e-12);
    }

    /// `tau` keeps a form-1 layer's thickness (so depths keep their meaning)
    /// and its albedo; the faces, phase function and other layers are kept.
    #[test]
    fn tau_keeps_the_thickness_and_the_rest_of_the_scene() {
        let text = "[[layer]]\nsigma_a = 0.5\nsigma_s = 1.5\nthickness = 0.5\nn = 1.4\n\
                    roughness = 0.2\nphase = { kind = \"rayleigh\" }\n\
                    [substrate]\nkind = \"conductor\"\nn = 0.2\nk = 3.0\nroughness = 0.3\n";
        let base = Scene::from_toml_str(text).unwrap();
        let q = quantities(&["layer[1].tau"]).unwrap();
        let s = apply(&base, &[(q[0], 3.0)]).unwrap();
        let (a, b) = (&s.channels()[0].layers()[0], &base.channels()[0].layers()[0]);
        assert_eq!(a.thickness(), 0.5);
        // sigma_t = 3 / 0.5 = 6 split by the albedo 0.75: exact in binary.
        assert_eq!((a.sigma_a(), a.sigma_s()), (1.5, 4.5));
        assert_eq!((a.phase(), a.roughness(), a.n()), (b.phase(), b.roughness(), b.n()));
        let (c, d) = (&s.channels()[0], &base.channels()[0]);
        assert_eq!(
            (c.substrate(), c.substrate_roughness()),
            (d.substrate(), d.substrate_roughness())
        );
        // The substrate's quantities, against the file with those values.
        let q = quantities(&[
            "substrate.n",
            "substrate.k",
            "substrate.roughness",
            "layer[1].roughness",
        ])
        .unwrap();
        let s = apply(&base, &[(q[0], 0.3), (q[1], 2.5), (q[2], 0.0), (q[3], 0.6)]).unwrap();
        let file = text
            .replace("n = 0.2\nk = 3.0\nroughness = 0.3", "n = 0.3\nk = 2.5\nroughness = 0")
            .replace("roughness = 0.2", "roughness = 0.6");
        assert_eq!(s, Scene::from_toml_str(&file).unwrap());
    }

    #[test]
    fn out_of_domain_values_are_refused_with_their_key() {
        let cases = [
            ("layer[1].g", 1.0, "|g| < 1"),
            ("layer[1].albedo", 1.5, "[0, 1]"),
            ("layer[2].tau", 1.0, "1 layer"),
            ("light.theta_deg", 95.0, "[0, 90"),
            ("substrate.albedo", 0.5, "lambertian"),
            ("substrate.k", 0.5, "conductor"),
            ("layer[1].roughness", 1.5, "roughness"),
            ("layer[1].n", f64::NAN, "NaN"),
            ("layer[1].thickness", -1.0, "thickness"),
        ];
        for (key, v, what) in cases {
            let e = apply(&slab(), &[(key.parse().unwrap(), v)]).unwrap_err();
            assert!(e.to_string().contains(what), "{key} = {v}: {e}");
            let KmError::Scene(CoreError::Scene { key: k, .. }) = &e else { panic!("{e:?}") };
            assert_eq!(k, key, "{e}");
        }
    }

    #[test]
    fn points_equal_one_by_one_and_bad_shapes_are_refused() {
        let base = slab();
        let q = quantities(&["layer[1].tau"]).unwrap();
        let values: Vec<f64> = (0..12).map(|i| 0.1 * (i + 1) as f64).collect();
        let opts = Options::new(crate::Method::Multiflux);
        let many = solve_points(&base, &q, &values, &opts, 1).unwrap();
        for (v, r) in values.iter().zip(&many) {
            let one = crate::solve(&apply(&base, &[(q[0], *v)]).unwrap(), &opts).unwrap();
            assert_eq!(r.as_ref().unwrap().channels, one.channels);
        }
        assert!(solve_points(&base, &[], &values, &opts, 1).is_err());
        assert!(solve_points(&base, &[q[0], q[0]], &values[..3], &opts, 1).is_err());
    }
}
