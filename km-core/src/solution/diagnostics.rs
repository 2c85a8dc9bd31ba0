//! The diagnostics of a [`super::Solution`] as typed values: the settings a
//! method used and what it measured on the way, one type per method, plus
//! what the front end adds (a spectral scene's wavelengths, repeated timing).
//! Converted to JSON only by [`Diagnostics::to_json`], whose keys are the
//! `km solve --json` keys of docs/cli.md.
//!
//! Per-channel values are held as one entry per solved channel; in JSON they
//! are a number for one channel and a list for several (as the values are).

use serde_json::{Map, Value, json};

use crate::two_flux::{KmMapping, KmModel};

/// What a solve reports beside its values (the method's own part and the
/// front end's).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Diagnostics {
    /// The method's settings and measurements.
    pub method: MethodDiagnostics,
    /// A spectral scene's wavelengths, nm (JSON `channels`, numbers).
    pub wavelengths_nm: Option<Vec<f64>>,
    /// The timing of a solve repeated in one process.
    pub repeated: Option<RepeatedTiming>,
}

/// A solve repeated `repeat` times (JSON `repeat`, `seconds_best`, `seconds_median`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RepeatedTiming {
    /// Number of calls.
    pub repeat: u32,
    /// The least solver time over the calls, seconds.
    pub seconds_best: f64,
    /// The median solver time over the calls, seconds.
    pub seconds_median: f64,
}

/// One method's diagnostics.
#[derive(Debug, Clone, Default, PartialEq)]
pub enum MethodDiagnostics {
    /// None reported.
    #[default]
    None,
    /// Two-flux Kubelka–Munk: the K, S mapping (JSON `km_mapping`) and the
    /// model (JSON `km_model`).
    TwoFlux {
        /// How K and S came from the scene.
        mapping: KmMapping,
        /// Four-flux or two-flux.
        model: KmModel,
    },
    /// Multi-flux, Fourier–Gauss mode.
    Multiflux(MultifluxDiagnostics),
    /// Multi-flux, direction-set mode (JSON `direction_set`).
    DirectionSet(DirectionSetDiagnostics),
    /// Monte Carlo (JSON `mc`).
    MonteCarlo(Box<McDiagnostics>),
    /// Diffusion dipole.
    Dipole(DipoleDiagnostics),
}

/// What the Fourier–Gauss multi-flux solver used and measured.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MultifluxDiagnostics {
    /// Gauss nodes per hemisphere, the most over channels (JSON `streams`).
    pub streams: usize,
    /// Fourier orders solved, the most over channels (JSON `fourier_orders`).
    pub fourier_orders: usize,
    /// Whether the planner was off (JSON `all_effects`).
    pub all_effects: bool,
    /// The Neumann order of the adding, when truncated (JSON `neumann_order`).
    pub neumann_order: Option<usize>,
    /// The largest bound of the light neglected below a layer solved as a
    /// half-space (JSON `cutoff_bound`, docs/planner.md eq. PL1).
    pub cutoff_bound: Option<f64>,
    /// Size of the conservation fix-up, when non-zero (JSON
    /// `conservation_residual`, docs/multiflux.md eq. 18a).
    pub conservation_residual: Option<f64>,
}

/// What the direction-set solver used.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DirectionSetDiagnostics {
    /// The setting: about this many directions in the medium of lowest index.
    pub directions: usize,
    /// Directions of the ambient set (both hemispheres), per channel.
    pub nodes: Vec<usize>,
}

/// Angular rings of reflected and transmitted light (Monte Carlo, JSON `mc.rings`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct McRings {
    /// Ring edges in `mu`.
    pub mu_edges: Vec<f64>,
    /// Mean BRDF per ring, per channel.
    pub brdf: Vec<Vec<f64>>,
    /// Mean BTDF per ring, per channel.
    pub btdf: Vec<Vec<f64>>,
    /// Standard errors of `brdf`.
    pub brdf_stderr: Vec<Vec<f64>>,
    /// Standard errors of `btdf`.
    pub btdf_stderr: Vec<Vec<f64>>,
}

/// The radial profile tallied by Monte Carlo (JSON `mc.radial`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct McRadial {
    /// Annulus width.
    pub dr: f64,
    /// Annulus mid radii.
    pub r: Vec<f64>,
    /// Rd(r) per annulus, per channel.
    pub rd: Vec<Vec<f64>>,
    /// Standard errors of `rd`.
    pub rd_stderr: Vec<Vec<f64>>,
}

/// The Monte Carlo run's settings and counts (JSON `mc`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct McDiagnostics {
    /// The absorption estimator's name.
    pub estimator: &'static str,
    /// Photons per channel.
    pub samples: u64,
    /// The run's seed.
    pub seed: u64,
    /// Photons per batch.
    pub batch_size: u64,
    /// Batches.
    pub batches: u64,
    /// Half-angle of the angular bins, degrees.
    pub bin_half_angle_deg: f64,
    /// The cap of steps per photon.
    pub max_steps_per_photon: u64,
    /// Scattering interactions, per channel.
    pub interactions: Vec<u64>,
    /// Steps, per channel.
    pub steps: Vec<u64>,
    /// Photons stopped by the step cap, per channel.
    pub capped_photons: Vec<u64>,
    /// Weight lost to the step cap, per channel.
    pub lost_weight: Vec<f64>,
    /// Absorbed by the substrate, per channel.
    pub absorptance_substrate: Vec<f64>,
    /// Angular rings, when asked for.
    pub rings: Option<McRings>,
    /// Radial profile, when asked for.
    pub radial: Option<McRadial>,
}

/// The diffusion quantities of the dipole.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DipoleDiagnostics {
    /// Which dipole (JSON `dipole_model`).
    pub model: &'static str,
    /// How F_dr was computed (JSON `fdr_model`).
    pub fdr_model: &'static str,
    /// F_dr, per channel (JSON `fdr`).
    pub fdr: Vec<f64>,
    /// The boundary factor A, per channel (JSON `A`).
    pub a: Vec<f64>,
    /// The reduced albedo, per channel (JSON `reduced_albedo`).
    pub reduced_albedo: Vec<f64>,
    /// The dipole's total diffuse reflectance, per channel (JSON `rd_dipole`).
    pub rd_dipole: Vec<f64>,
}

impl Diagnostics {
    /// The JSON entries (docs/cli.md), merged into [`super::Solution::to_json`].
    pub fn to_json(&self) -> Map<String, Value> {
        let mut m = self.method.to_json();
        if let Some(w) = &self.wavelengths_nm {
            m.insert("channels".into(), json!(w));
        }
        if let Some(t) = &self.repeated {
            m.insert("repeat".into(), t.repeat.into());
            m.insert("seconds_best".into(), t.seconds_best.into());
            m.insert("seconds_median".into(), t.seconds_median.into());
        }
        m
    }

    /// The Monte Carlo diagnostics, if the method was Monte Carlo.
    pub fn mc(&self) -> Option<&McDiagnostics> {
        match &self.method {
            MethodDiagnostics::MonteCarlo(m) => Some(m),
            _ => None,
        }
    }

    /// The multi-flux diagnostics, if the method was the Fourier–Gauss multi-flux.
    pub fn multiflux(&self) -> Option<&MultifluxDiagnostics> {
        match &self.method {
            MethodDiagnostics::Multiflux(m) => Some(m),
            _ => None,
        }
    }
}

/// A number for one entry, a list for several.
fn pick(v: Vec<Value>) -> Value {
    if v.len() == 1 { v.into_iter().next().unwrap_or(Value::Null) } else { Value::Array(v) }
}

fn picked<T: Copy + Into<Value>>(v: &[T]) -> Value {
    pick(v.iter().map(|&x| x.into()).collect())
}

fn lists(v: &[Vec<f64>]) -> Value {
    pick(v.iter().map(|l| json!(l)).collect())
}

impl MethodDiagnostics {
    /// The JSON entries of the method's diagnostics.
    pub fn to_json(&self) -> Map<String, Value> {
        let mut m = Map::new();
        match self {
            MethodDiagnostics::None => {}
            MethodDiagnostics::TwoFlux { mapping, model } => {
                m.insert("km_mapping".into(), json!(mapping.name()));
                m.insert("km_model".into(), json!(model.name()));
            }
            MethodDiagnostics::Multiflux(d) => {
                if let Some(b) = d.cutoff_bound {
                    m.insert("cutoff_bound".into(), json!(b));
                }
                if let Some(r) = d.conservation_residual {
                    m.insert("conservation_residual".into(), json!(r));
                }
                m.insert("all_effects".into(), json!(d.all_effects));
                m.insert("streams".into(), json!(d.streams));
                m.insert("fourier_orders".into(), json!(d.fourier_orders));
                if let Some(k) = d.neumann_order {
                    m.insert("neumann_order".into(), json!(k));
                }
            }
            MethodDiagnostics::DirectionSet(d) => {
                let nodes: Vec<u64> = d.nodes.iter().map(|&n| n as u64).collect();
                let ds = json!({ "directions": d.directions, "nodes": picked(&nodes) });
                m.insert("direction_set".into(), ds);
            }
            MethodDiagnostics::MonteCarlo(d) => {
                m.insert("mc".into(), Value::Object(mc_json(d)));
            }
            MethodDiagnostics::Dipole(d) => {
                m.insert("dipole_model".into(), json!(d.model));
                m.insert("fdr_model".into(), json!(d.fdr_model));
                m.insert("fdr".into(), picked(&d.fdr));
                m.insert("A".into(), picked(&d.a));
                m.insert("reduced_albedo".into(), picked(&d.reduced_albedo));
                m.insert("rd_dipole".into(), picked(&d.rd_dipole));
            }
        }
        m
    }
}

fn mc_json(d: &McDiagnostics) -> Map<String, Value> {
    let photons = d.samples as f64;
    let mut mc = Map::new();
    mc.insert("estimator".into(), json!(d.estimator));
    mc.insert("samples".into(), json!(d.samples));
    mc.insert("seed".into(), json!(d.seed));
    mc.insert("batch_size".into(), json!(d.batch_size));
    mc.insert("batches".into(), json!(d.batches));
    mc.insert("bin_half_angle_deg".into(), json!(d.bin_half_angle_deg));
    mc.insert("max_steps_per_photon".into(), json!(d.max_steps_per_photon));
    mc.insert("interactions".into(), picked(&d.interactions));
    let per_photon: Vec<f64> = d.interactions.iter().map(|&x| x as f64 / photons).collect();
    mc.insert("interactions_per_photon".into(), picked(&per_photon));
    mc.insert("steps".into(), picked(&d.steps));
    mc.insert("capped_photons".into(), picked(&d.capped_photons));
    mc.insert("lost_weight".into(), picked(&d.lost_weight));
    mc.insert("absorptance_substrate".into(), picked(&d.absorptance_substrate));
    if let Some(r) = &d.rings {
        mc.insert(
            "rings".into(),
            json!({
                "mu_edges": r.mu_edges,
                "brdf": lists(&r.brdf), "btdf": lists(&r.btdf),
                "stderr": { "brdf": lists(&r.brdf_stderr), "btdf": lists(&r.btdf_stderr) },
            }),
        );
    }
    if let Some(r) = &d.radial {
        mc.insert(
            "radial".into(),
            json!({ "dr": r.dr, "r": r.r, "rd": lists(&r.rd), "stderr": lists(&r.rd_stderr) }),
        );
    }
    mc
}
