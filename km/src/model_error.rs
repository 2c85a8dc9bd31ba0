//! How far a closed form is off: `model_error_estimate` of the two-flux
//! (four-flux) and dipole answers (docs/two-flux.md §14, eq. K25).
//!
//! The closed forms are not radiative transfer: their error is a property
//! of the model, not of a setting, and no accuracy target can shrink it.
//! What can be had cheaply is its size. The same scene is solved by the
//! multi-flux solver at [`CHECK_STREAMS`] Gauss nodes per hemisphere (a
//! few microseconds for one layer; no Fourier orders beyond 0 without exit
//! directions), and for every number `x` of the answer
//!
//! ```text
//! e(x) = |x - x_4| + |x_4 - x_2|                                    (K25)
//! ```
//!
//! with `x_N` the multi-flux value at `N` nodes: the distance to the
//! 4-node answer plus that answer's own estimated error (its change from
//! 2 nodes), so that `e` bounds `|x - x_exact|` whenever the 4-node answer
//! is closer to the exact one than the 2-node answer is to it. Measured on
//! the grid of docs/two-flux.md §13 (`km_bench::km_models`): see the note.
//!
//! Every two-flux and dipole answer of [`crate::solve`] carries it (JSON
//! `model_error_estimate`, keyed like `error_estimate`); a note says so
//! when it exceeds 1 % of a total (and 1e-4 of the incident light).

use km_core::{ChannelResult, Scene, Solution, Uncertainty};
use km_multiflux::MultifluxOptions;

use crate::Solver;

/// Gauss nodes per hemisphere of the two multi-flux solves of eq. K25:
/// the check (`x_4`) and the coarser solve that estimates its error (`x_2`).
pub const CHECK_STREAMS: [usize; 2] = [4, 2];

/// The most layers, summed over the channels solved, that the check solves
/// (its work bound: about 25 microseconds per layer and channel for the two
/// solves, so at most about half a second); beyond, a note says it was left
/// out.
pub const MAX_CHECK_LAYERS: usize = 20_000;

/// A note is added when an estimate exceeds this fraction of its total...
pub const NOTE_RELATIVE: f64 = 0.01;
/// ...and this much of the incident light (rounding-level values ignored).
pub const NOTE_ABSOLUTE: f64 = 1e-4;

/// `|x - a| + |a - b|` (eq. K25).
fn bound(x: f64, a: f64, b: f64) -> f64 {
    (x - a).abs() + (a - b).abs()
}

/// Eq. K25 element by element, for lists of equal length (`None` otherwise).
fn bounds(x: &[f64], a: &[f64], b: &[f64]) -> Option<Vec<f64>> {
    (x.len() == a.len() && a.len() == b.len())
        .then(|| x.iter().zip(a).zip(b).map(|((x, a), b)| bound(*x, *a, *b)).collect())
}

/// The estimate of one channel's numbers from the two multi-flux answers.
fn estimate(c: &ChannelResult, a: &ChannelResult, b: &ChannelResult) -> Uncertainty {
    let brdf = (!c.brdf.is_empty()).then(|| bounds(&c.brdf, &a.brdf, &b.brdf)).flatten();
    let btdf = (!c.btdf.is_empty()).then(|| bounds(&c.btdf, &a.btdf, &b.btdf)).flatten();
    let max = |v: &Option<Vec<f64>>| v.as_ref().map(|v| v.iter().copied().fold(0.0, f64::max));
    let layers = match (&c.absorptance_layers, &a.absorptance_layers, &b.absorptance_layers) {
        (Some(x), Some(p), Some(q)) => bounds(x, p, q),
        _ => None,
    };
    Uncertainty {
        reflectance: Some(bound(c.reflectance, a.reflectance, b.reflectance)),
        reflectance_specular: Some(bound(
            c.reflectance_specular,
            a.reflectance_specular,
            b.reflectance_specular,
        )),
        transmittance: Some(bound(c.transmittance, a.transmittance, b.transmittance)),
        transmittance_direct: Some(bound(
            c.transmittance_direct,
            a.transmittance_direct,
            b.transmittance_direct,
        )),
        absorptance: Some(bound(c.absorptance, a.absorptance, b.absorptance)),
        absorptance_layers: layers,
        brdf_max: max(&brdf),
        btdf_max: max(&btdf),
        brdf,
        btdf,
    }
}

/// The multi-flux answer of `scene` at `streams` nodes.
fn check_solve(scene: &Scene, streams: usize) -> Result<Solution, crate::KmError> {
    MultifluxOptions { streams: Some(streams), ..Default::default() }.solve_unplanned(scene)
}

/// Attach `model_error_estimate` (eq. K25) to every channel of `sol`, the
/// answer of a closed form (two-flux, dipole) for `scene` (the same
/// channels, in order), and a note where it exceeds 1 % of a total. When
/// the multi-flux check refuses the scene, a note says why and nothing is
/// attached.
pub(crate) fn attach(sol: &mut Solution, scene: &Scene) {
    let [fine, coarse] = CHECK_STREAMS;
    let layers: usize = scene.channels().iter().map(|c| c.layers().len()).sum();
    if layers > MAX_CHECK_LAYERS {
        sol.notes.push(format!(
            "no model_error_estimate: its multi-flux check would solve {layers} layers over the \
             channels (more than {MAX_CHECK_LAYERS}); solve fewer channels, or compare with \
             --method multiflux"
        ));
        return;
    }
    let checks = check_solve(scene, fine).and_then(|a| Ok((a, check_solve(scene, coarse)?)));
    let (a, b) = match checks {
        Ok(x) => x,
        Err(e) => {
            sol.notes.push(format!(
                "no model_error_estimate: the {fine}-stream multi-flux check cannot solve the \
                 scene ({e})"
            ));
            return;
        }
    };
    let mut worst: Option<(String, f64, f64)> = None;
    let several = sol.channels.len() > 1;
    for (k, c) in sol.channels.iter_mut().enumerate() {
        let (Some(ca), Some(cb)) = (a.channels.get(k), b.channels.get(k)) else { continue };
        let e = estimate(c, ca, cb);
        for (key, x, ex) in [
            ("reflectance", c.reflectance, e.reflectance),
            ("transmittance", c.transmittance, e.transmittance),
        ] {
            let ex = ex.unwrap_or(0.0);
            let relative = ex / x.abs().max(f64::MIN_POSITIVE);
            if ex > NOTE_ABSOLUTE
                && ex > NOTE_RELATIVE * x.abs()
                && worst.as_ref().is_none_or(|w| relative > w.2 / w.1.abs().max(f64::MIN_POSITIVE))
            {
                let label = match sol.labels.get(k) {
                    Some(l) if several => format!("{key} [{l}]"),
                    _ => key.to_string(),
                };
                worst = Some((label, x, ex));
            }
        }
        c.model_error_estimate = Some(e);
    }
    if let Some((what, x, ex)) = worst {
        sol.notes.push(format!(
            "model error: the {} answer may be off by {ex:.2e} in {what} ({:.0} % of {x:.4}; \
             model_error_estimate, eq. K25: against a {fine}-stream multi-flux solve); \
             --method multiflux solves the radiative transfer problem",
            sol.method,
            100.0 * ex / x.abs().max(f64::MIN_POSITIVE),
        ));
    }
}
