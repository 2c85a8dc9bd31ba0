//! Depth-resolved output of every method from one request (`docs/field.md`):
//! the fluence rate `phi(z)`, the absorbed power density `A(z)` and the net
//! flux `F(z)` at the scene's `[output] depths` (or depths given here), per
//! unit incident irradiance on the surface, and the absorptance of every
//! layer.
//!
//! * multi-flux: exact at any depth from the eigen-solution of the layer
//!   holding it ([`km_multiflux::depth`], eq. D1–D6);
//! * two-flux: closed form ([`km_core::two_flux::depth_profile`], eq. D7–D9);
//! * Monte Carlo: MCML-style depth bins with standard errors, interpolated
//!   at the depths ([`crate::mc_field::mc_depths`]);
//! * the dipole: the diffusion field of its half-space, the pencil beam's
//!   dipole integrated over the plane, with the collimated beam
//!   ([`km_dipole::depth_field`], eq. D24–D27 of `docs/diffusion.md`);
//! * the direction set is refused with the reason.
//!
//! With directions (`[output] inside_directions_deg`, or
//! [`FieldOptions::directions`]) the radiance `I(z, theta, phi)` at those
//! directions and depths as well ([`InsideField`], docs/field.md §2a, §4a):
//! multi-flux exact at any depth ([`km_multiflux::inside`]), Monte Carlo as
//! cone averages with standard errors, from the run of the profiles
//! ([`crate::mc_field::mc_depths_inside`]).

use std::fmt::Write as _;
use std::time::Instant;

use km_core::solution::DepthOutput;
use km_core::two_flux::KmModel;
use km_core::two_flux::KmOptions;
use km_core::{Scene, Solution};
use km_montecarlo::McOptions;
use km_multiflux::MultifluxOptions;
use km_multiflux::depth::DepthField;

use crate::error::{KmError, Reason, Unsupported};
pub use crate::inside::InsideField;
use crate::mc_field::{check_depths, mc_depths, mc_depths_inside};
use crate::{Method, MethodOptions, Solver};

mod request;
pub use request::{FieldRequest, parse_direction};

/// The settings of [`field`]: the method and its options.
#[derive(Debug, Clone, Default)]
pub struct FieldOptions {
    /// The method (`Multiflux` by default).
    pub method: FieldMethod,
    /// Multi-flux settings (streams, delta-M).
    pub multiflux: MultifluxOptions,
    /// Two-flux settings (the K, S mapping; the profile is always the
    /// two-flux model's, whatever `model` says).
    pub km: KmOptions,
    /// Monte Carlo settings (photons, seed, threads).
    pub mc: McOptions,
    /// Monte Carlo depth-bin width (`None`: [`crate::mc_field::mc_depths`]'s default).
    pub dz: Option<f64>,
    /// Dipole settings (the model and its `F_dr`).
    pub dipole: km_dipole::DipoleOptions,
    /// Directions of the radiance inside (`None`: the scene's `[output]
    /// inside_directions_deg`; empty: none).
    pub directions: Option<Vec<[f64; 2]>>,
    /// Monte Carlo cone half-angle of the radiance inside, degrees (`None`:
    /// [`DEFAULT_INSIDE_CONE_DEG`]).
    pub mc_cone_deg: Option<f64>,
}

/// The default Monte Carlo cone half-angle of the radiance inside, degrees.
pub const DEFAULT_INSIDE_CONE_DEG: f64 = 5.0;

/// A method for [`FieldOptions`] (a [`Method`] with a default).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FieldMethod(pub Method);

impl Default for FieldMethod {
    fn default() -> Self {
        FieldMethod(Method::Multiflux)
    }
}

/// Standard errors of a Monte Carlo field (per channel, per depth).
#[derive(Debug, Clone, PartialEq)]
pub struct FieldStderr {
    /// Of the fluence rate.
    pub fluence: Vec<Vec<f64>>,
    /// Of the absorbed power density.
    pub absorbed: Vec<Vec<f64>>,
    /// Of the net flux.
    pub net_flux: Vec<Vec<f64>>,
}

/// The depth-resolved field of a scene by one method: per channel, a value
/// per depth.
#[derive(Debug, Clone, PartialEq)]
pub struct Field {
    /// The method.
    pub method: Method,
    /// A label per channel.
    pub labels: Vec<String>,
    /// The depths, in the layers' length unit from the top surface.
    pub depths: Vec<f64>,
    /// Fluence rate `phi(z)`: 4 pi times the mean radiance, per unit incident irradiance.
    pub fluence: Vec<Vec<f64>>,
    /// Absorbed power per unit depth per unit incident power `A(z)` (1/length).
    pub absorbed: Vec<Vec<f64>>,
    /// Net downward flux `F(z)` per unit incident power.
    pub net_flux: Vec<Vec<f64>>,
    /// Per channel, the fraction of the incident power absorbed in each layer.
    pub absorptance_layers: Vec<Vec<f64>>,
    /// Standard errors (Monte Carlo only).
    pub stderr: Option<FieldStderr>,
    /// The radiance at user directions, when asked.
    pub inside: Option<InsideField>,
    /// The solver's own wall time in seconds.
    pub seconds: f64,
}

/// `phi(z)`, `A(z)` and `F(z)` of `scene` at `depths` (`None`: the scene's
/// `[output] depths`) by `opts.method`.
///
/// # Errors
/// No depth asked for, a depth that is negative, not finite or outside the
/// stack ([`KmError::Option`], or the solver's own error naming it), more
/// than 100,000 depths, a method that gives no depth field
/// ([`Reason::NoDepthField`]), and the solvers' errors.
///
/// ```
/// let s = km_core::Scene::from_toml_str(
///     "[[layer]]\nsigma_a = 1.0\nsigma_s = 0.0\nthickness = 2.0\n\
///      [output]\ndepths = [0.0, 1.0]\n").unwrap();
/// let f = km::field::field(&s, None, &km::field::FieldOptions::default()).unwrap();
/// assert!((f.net_flux[0][1] - (-1.0f64).exp()).abs() < 1e-12);
/// ```
pub fn field(scene: &Scene, depths: Option<&[f64]>, opts: &FieldOptions) -> Result<Field, KmError> {
    let depths = depths.unwrap_or(scene.depths());
    check_depths(depths)?;
    let method = opts.method.0;
    let start = Instant::now();
    let mut f = Field {
        method,
        labels: scene.labels().to_vec(),
        depths: depths.to_vec(),
        fluence: Vec::new(),
        absorbed: Vec::new(),
        net_flux: Vec::new(),
        absorptance_layers: Vec::new(),
        stderr: None,
        inside: None,
        seconds: 0.0,
    };
    let directions = opts.directions.as_deref().unwrap_or(scene.inside_directions());
    match method {
        Method::Multiflux => {
            for mono in scene.channels() {
                let d = DepthField::new(mono, &opts.multiflux)?;
                let p = d.profile(depths)?;
                f.fluence.push(p.fluence);
                f.absorbed.push(p.absorbed);
                f.net_flux.push(p.net_flux);
                f.absorptance_layers.push(d.layer_absorptance());
            }
        }
        Method::Km => {
            for mono in scene.channels() {
                // The two-flux model's profile (the four-flux model's beam
                // inside the layers is not resolved in depth; docs/field.md).
                let two = KmOptions { model: km_core::two_flux::KmModel::TwoFlux, ..opts.km };
                let p = km_core::two_flux::depth_profile(mono, &two, depths)?;
                f.fluence.push(p.fluence);
                f.absorbed.push(p.absorbed);
                f.net_flux.push(p.net_flux);
                f.absorptance_layers.push(p.layer_absorptance);
            }
        }
        Method::Mc => {
            check_in_stack(scene, depths)?;
            let v = if directions.is_empty() {
                mc_depths(scene, depths, opts.dz, &opts.mc)?
            } else {
                // The radiance inside from the same run as the profiles.
                let cone = opts.mc_cone_deg.unwrap_or(DEFAULT_INSIDE_CONE_DEG);
                let (v, inside) =
                    mc_depths_inside(scene, depths, opts.dz, directions, cone, &opts.mc)?;
                f.inside = Some(inside);
                v
            };
            f.absorptance_layers = v
                .bins
                .solution
                .channels
                .iter()
                .map(|c| c.absorptance_layers.clone().unwrap_or_default())
                .collect();
            f.stderr = Some(FieldStderr {
                fluence: v.fluence_se,
                absorbed: v.absorbed_se,
                net_flux: v.net_flux_se,
            });
            (f.fluence, f.absorbed, f.net_flux) = (v.fluence, v.absorbed, v.net_flux);
        }
        Method::Dipole => {
            crate::Solver::supports(&opts.dipole, scene)?;
            let d = km_dipole::depth_field(scene, depths, &opts.dipole)?;
            (f.fluence, f.absorbed, f.net_flux) = (d.fluence, d.absorbed, d.net_flux);
            f.absorptance_layers = d.absorptance_layers;
        }
        Method::DirectionSet => {
            return Err(Unsupported { method, reason: Reason::NoDepthField }.into());
        }
    }
    if !directions.is_empty() && f.inside.is_none() {
        f.inside = Some(inside(scene, depths, directions, opts)?);
    }
    f.seconds = start.elapsed().as_secs_f64();
    Ok(f)
}

/// The radiance at `directions` and `depths` by `opts.method` (multi-flux;
/// Monte Carlo gives it from the run of the profiles, [`field`]'s `Mc`
/// arm; the others refuse with the reason).
fn inside(
    scene: &Scene,
    depths: &[f64],
    directions: &[[f64; 2]],
    opts: &FieldOptions,
) -> Result<InsideField, KmError> {
    match opts.method.0 {
        Method::Multiflux => {
            let (mut radiance, mut down, mut up) = (Vec::new(), Vec::new(), Vec::new());
            for mono in scene.channels() {
                let r = km_multiflux::inside::inside_radiance(
                    mono,
                    &opts.multiflux,
                    depths,
                    directions,
                )?;
                radiance.push(r.radiance);
                down.push(r.beam_down);
                up.push(r.beam_up);
            }
            Ok(InsideField {
                directions: directions.to_vec(),
                radiance,
                stderr: None,
                beams: Some([down, up]),
                cone_half_angle_deg: None,
            })
        }
        m => Err(KmError::Option {
            name: "inside_directions_deg",
            value: m.name().into(),
            reason: "the radiance inside the stack is given by the multiflux and mc methods \
                     (docs/field.md §2a, §4a)",
        }),
    }
}

/// Monte Carlo bins any depth; a depth below the stack (in the substrate)
/// is refused as the other methods refuse it.
fn check_in_stack(scene: &Scene, depths: &[f64]) -> Result<(), KmError> {
    let total: f64 = scene.channels()[0].layers().iter().map(|l| l.thickness()).sum();
    match depths.iter().find(|&&z| z > total) {
        Some(z) => Err(KmError::Option {
            name: "depths",
            value: z.to_string(),
            reason: "every depth must lie in the stack (0 to the sum of the thicknesses)",
        }),
        None => Ok(()),
    }
}

impl Field {
    /// The JSON object of `km field --json` (docs/cli.md): `method`,
    /// `depths`, `fluence`, `absorbed`, `net_flux`, `absorptance_layers` (a
    /// value per depth or layer for one channel, a list per channel for
    /// several), `labels`, `stderr` (Monte Carlo: the same keys and shapes)
    /// and `seconds`.
    pub fn to_json(&self) -> serde_json::Value {
        use serde_json::json;
        let one = self.fluence.len() == 1;
        let shape = |v: &Vec<Vec<f64>>| if one { json!(v[0]) } else { json!(v) };
        let mut out = json!({
            "method": self.method.name(),
            "labels": self.labels,
            "depths": self.depths,
            "fluence": shape(&self.fluence),
            "absorbed": shape(&self.absorbed),
            "net_flux": shape(&self.net_flux),
            "absorptance_layers": shape(&self.absorptance_layers),
            "seconds": self.seconds,
        });
        if let Some(se) = &self.stderr {
            out["stderr"] = json!({
                "fluence": shape(&se.fluence),
                "absorbed": shape(&se.absorbed),
                "net_flux": shape(&se.net_flux),
            });
        }
        if let Some(r) = &self.inside {
            out["radiance"] = r.to_json();
        }
        out
    }

    /// `km field`'s table: the depth table and, when asked, the radiance
    /// inside after a blank line ([`Field::inside_table`]).
    pub fn table(&self) -> String {
        join(depth_table(self), self.inside_table())
    }

    /// `km field --csv`: the depth rows and, when asked, the radiance inside
    /// after a blank line ([`Field::inside_csv`]).
    pub fn csv(&self) -> String {
        join(depth_csv(self), self.inside_csv())
    }

    /// The radiance inside as a text table (`km field`'s table; empty
    /// without one): per channel, a row per depth and direction.
    pub fn inside_table(&self) -> String {
        let Some(r) = &self.inside else { return String::new() };
        let rows: Vec<usize> = (0..self.depths.len()).collect();
        inside_table(r, &self.labels, &self.depths, &rows)
    }

    /// The radiance inside as CSV (`km field --csv`'s second table; empty
    /// without one): `channel,z,theta,phi,radiance` and `radiance_se`
    /// (Monte Carlo), one row per channel, depth and direction.
    pub fn inside_csv(&self) -> String {
        use std::fmt::Write as _;
        let Some(r) = &self.inside else { return String::new() };
        let mut s = String::from("channel,z,theta,phi,radiance");
        if r.stderr.is_some() {
            s += ",radiance_se";
        }
        s += "\n";
        for (c, label) in self.labels.iter().enumerate() {
            for (k, z) in self.depths.iter().enumerate() {
                for (j, d) in r.directions.iter().enumerate() {
                    let _ = write!(s, "{label},{z},{},{},{}", d[0], d[1], r.radiance[c][k][j]);
                    if let Some(e) = &r.stderr {
                        let _ = write!(s, ",{}", e[c][k][j]);
                    }
                    s += "\n";
                }
            }
        }
        s
    }
}

/// The radiance inside as a text table (`km field`'s, and `km solve`'s
/// under its depth table): per channel, a row per depth of `rows` (indices
/// into `depths`) and direction, the collimated beams' irradiance after a
/// depth's rows where there are any.
pub(crate) fn inside_table(
    r: &InsideField,
    labels: &[String],
    depths: &[f64],
    rows: &[usize],
) -> String {
    let mut s = String::from(
        "radiance inside (1/sr per unit incident irradiance; theta from the downward \
         normal, phi = 180 the beam's forward side; collimated beams apart)\n",
    );
    if let Some(c) = &r.cone_half_angle_deg {
        let cones: Vec<String> = c.iter().map(|a| format!("{a:.3}")).collect();
        let _ = writeln!(s, "cone averages, half-angles (degrees): {}", cones.join(", "));
    }
    for (c, label) in labels.iter().enumerate() {
        if labels.len() > 1 {
            let _ = writeln!(s, "channel {label}");
        }
        let _ = writeln!(s, "{:>12} {:>8} {:>8} {:>14}", "z", "theta", "phi", "I");
        for &k in rows {
            let z = depths[k];
            for (j, d) in r.directions.iter().enumerate() {
                let se =
                    r.stderr.as_ref().map_or(String::new(), |e| format!(" ± {:.2e}", e[c][k][j]));
                let _ = writeln!(
                    s,
                    "{z:>12.6} {:>8.3} {:>8.3} {:>14.6e}{se}",
                    d[0], d[1], r.radiance[c][k][j]
                );
            }
            if let Some([dn, up]) = &r.beams
                && (dn[c][k] != 0.0 || up[c][k] != 0.0)
            {
                let _ = writeln!(
                    s,
                    "{z:>12.6} beams: down {:.6e}, up {:.6e} (irradiance)",
                    dn[c][k], up[c][k]
                );
            }
        }
    }
    s
}

/// Two tables, the second (when there is one) after a blank line.
fn join(a: String, b: String) -> String {
    if b.is_empty() { a } else { format!("{a}\n{b}") }
}

/// The depth table of `km field` (per channel, a row per depth, and the
/// absorptance per layer).
fn depth_table(f: &Field) -> String {
    let mut s = format!("method: {}\n", f.method);
    for (c, label) in f.labels.iter().enumerate() {
        if f.labels.len() > 1 {
            let _ = writeln!(s, "channel {label}");
        }
        let _ = writeln!(s, "{:>12} {:>14} {:>14} {:>14}", "z", "phi", "A", "F");
        for (i, z) in f.depths.iter().enumerate() {
            let se = |v: &Vec<Vec<f64>>| format!(" ± {:.2e}", v[c][i]);
            let (ps, as_, ns) =
                f.stderr.as_ref().map_or((String::new(), String::new(), String::new()), |e| {
                    (se(&e.fluence), se(&e.absorbed), se(&e.net_flux))
                });
            let _ = writeln!(
                s,
                "{z:>12.6} {:>14.6e}{ps} {:>14.6e}{as_} {:>14.6e}{ns}",
                f.fluence[c][i], f.absorbed[c][i], f.net_flux[c][i]
            );
        }
        let layers: Vec<String> =
            f.absorptance_layers[c].iter().map(|a| format!("{a:.6}")).collect();
        let _ = writeln!(s, "absorptance per layer: {}", layers.join(", "));
    }
    s
}

/// The depth rows of `km field --csv`: `channel,z,fluence,absorbed,net_flux`
/// and the standard errors (Monte Carlo).
fn depth_csv(f: &Field) -> String {
    let mut s = String::from("channel,z,fluence,absorbed,net_flux");
    if f.stderr.is_some() {
        s += ",fluence_se,absorbed_se,net_flux_se";
    }
    s += "\n";
    for (c, label) in f.labels.iter().enumerate() {
        for (i, z) in f.depths.iter().enumerate() {
            let _ = write!(
                s,
                "{label},{z},{},{},{}",
                f.fluence[c][i], f.absorbed[c][i], f.net_flux[c][i]
            );
            if let Some(e) = &f.stderr {
                let _ = write!(s, ",{},{},{}", e.fluence[c][i], e.absorbed[c][i], e.net_flux[c][i]);
            }
            s += "\n";
        }
    }
    s
}

impl From<Field> for DepthOutput {
    fn from(f: Field) -> DepthOutput {
        DepthOutput {
            depths: f.depths,
            fluence: f.fluence,
            absorbed: f.absorbed,
            net_flux: f.net_flux,
            stderr: f.stderr.map(|s| [s.fluence, s.absorbed, s.net_flux]),
            radiance: f.inside,
        }
    }
}

/// A Monte Carlo solve of `scene` that tallies the field at `depths` in the
/// same run (`km::solve` with `[output] depths`): its answer (the run's
/// totals, the same as without the depth tally for the same seed) and the
/// field, with the run's per-layer absorptance; with `directions` (the
/// scene's `[output] inside_directions_deg`) the radiance inside from the
/// same run as well, over `km field`'s default cone
/// ([`DEFAULT_INSIDE_CONE_DEG`]).
pub(crate) fn mc_solve_with_field(
    scene: &Scene,
    depths: &[f64],
    directions: &[[f64; 2]],
    opts: &McOptions,
) -> Result<(Solution, DepthOutput), KmError> {
    check_depths(depths)?;
    check_in_stack(scene, depths)?;
    let (v, radiance) = if directions.is_empty() {
        (mc_depths(scene, depths, None, opts)?, None)
    } else {
        let (v, r) =
            mc_depths_inside(scene, depths, None, directions, DEFAULT_INSIDE_CONE_DEG, opts)?;
        (v, Some(r))
    };
    let out = DepthOutput {
        depths: v.depths,
        fluence: v.fluence,
        absorbed: v.absorbed,
        net_flux: v.net_flux,
        stderr: Some([v.fluence_se, v.absorbed_se, v.net_flux_se]),
        radiance,
    };
    Ok((v.bins.solution, out))
}

/// Attach the field at the scene's `[output] depths` to a solve's answer
/// `sol` by the same method and settings (the streams an accuracy target
/// chose; the photons and seed of the run), with the per-layer absorptance
/// where the solve had none, and the radiance at the scene's `[output]
/// inside_directions_deg` where the method gives it (multi-flux, Monte
/// Carlo; docs/field.md §6); a method without a depth field or without the
/// radiance adds a note.
pub(crate) fn attach(
    scene: &Scene,
    solver: &MethodOptions,
    sol: &mut Solution,
) -> Result<(), KmError> {
    let chosen = |key: &str| {
        sol.accuracy.as_ref().and_then(|a| a.work.iter().find(|(k, _)| k == key).map(|w| w.1))
    };
    let mut opts = FieldOptions::default();
    match solver {
        MethodOptions::Multiflux(o) => {
            opts.method = FieldMethod(Method::Multiflux);
            opts.multiflux = o.clone();
            if let Some(n) = chosen("streams") {
                opts.multiflux.streams = Some(n as usize);
            }
        }
        MethodOptions::Km(o) => {
            opts.method = FieldMethod(Method::Km);
            opts.km = *o;
            if o.model == KmModel::FourFlux
                && scene.channels().first().is_some_and(|c| c.light().mu0().is_some())
            {
                sol.notes.push(
                    "the depth field is the two-flux model's (the four-flux beam is not resolved \
                     in depth, docs/field.md §3): its net flux at depth 0 is 1 - R of two-flux"
                        .into(),
                );
            }
        }
        MethodOptions::Mc(o) => {
            opts.method = FieldMethod(Method::Mc);
            opts.mc = o.clone();
            if let Some(n) = chosen("samples") {
                opts.mc.samples = n;
            }
            sol.notes.push(format!(
                "the depth field comes from a second run of {} photons with the same seed \
                 (an accuracy target or duplicate channels kept it out of the first)",
                opts.mc.samples
            ));
        }
        MethodOptions::Dipole(o) => {
            opts.method = FieldMethod(Method::Dipole);
            opts.dipole = *o;
            sol.notes.push(
                "the depth field is the dipole's diffusion solution of a broad beam with the \
                 collimated beam (docs/diffusion.md eq. D24-D27): normal incidence's source \
                 depth, the net flux jumps by the source's strength at its depth 1/sigma_t'"
                    .into(),
            );
            // The half-space the solve treated (a top layer the planner's
            // `transmission` rule made one), as the solve treated it.
            if let Some((half, _)) = crate::as_half_space(scene, false) {
                return attach_field(&half, &opts, sol);
            }
        }
        MethodOptions::DirectionSet(_) => {
            sol.notes.push(format!(
                "[output] depths ignored: the {} method gives no depth field (km field \
                 --method multiflux, km or mc)",
                solver.method().name()
            ));
            if !scene.inside_directions().is_empty() {
                sol.notes.push(no_radiance_note(solver.method()));
            }
            return Ok(());
        }
    }
    attach_field(scene, &opts, sol)
}

/// The note of a solve whose method does not give the radiance inside
/// (`km field` refuses it for them, docs/field.md §2a, §4a).
pub(crate) fn no_radiance_note(method: Method) -> String {
    format!(
        "[output] inside_directions_deg ignored: the {} method gives no radiance inside the \
         stack (the multiflux and mc methods do, docs/field.md §2a, §4a)",
        method.name()
    )
}

/// [`attach`]'s last step: the field of `scene` by `opts` into `sol`, with
/// the radiance inside where the method gives it (the scene's directions,
/// `km field`'s default Monte Carlo cone), a note where it does not.
fn attach_field(scene: &Scene, opts: &FieldOptions, sol: &mut Solution) -> Result<(), KmError> {
    let method = opts.method.0;
    let gives_radiance = matches!(method, Method::Multiflux | Method::Mc);
    if !gives_radiance && !scene.inside_directions().is_empty() {
        sol.notes.push(no_radiance_note(method));
    }
    let directions = if gives_radiance { None } else { Some(Vec::new()) };
    let opts = &FieldOptions { directions, ..opts.clone() };
    let f = field(scene, None, opts)?;
    for (c, layers) in sol.channels.iter_mut().zip(&f.absorptance_layers) {
        if c.absorptance_layers.is_none() && !layers.is_empty() {
            c.absorptance_layers = Some(layers.clone());
        }
    }
    sol.field = Some(f.into());
    Ok(())
}
