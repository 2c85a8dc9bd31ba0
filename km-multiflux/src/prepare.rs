//! What every route of a channel starts from: the number of streams, the
//! angular grid of all media, the delta-M scaled layers and the plan's
//! thick-layer cut, and the flux of a node vector. Shared by the solve
//! ([`crate::engine`]), the field ([`crate::field`], [`crate::depth`]) and
//! the BSDF table ([`crate::bsdf`]).

use std::sync::Arc;

use km_core::phase::{Phase, PhaseFunction};
use km_core::{MonoScene, Substrate};

use crate::MultifluxError;
use crate::legendre::delta_m;
use crate::options::{MultifluxOptions, default_streams};
use crate::quadrature::{AngularGrid, MediumNodes};
use crate::stack::Scaled;

/// Delta-M scaling (eq. 4) of every layer at `streams` nodes per hemisphere,
/// keeping the moments of eq. 4b (`2N`, or `3N/2` for a phase function given
/// as data whose peak the `2N` moments do not resolve; `2N` without delta-M
/// or `peak_truncation`).
pub(crate) fn scale_layers(
    scene: &MonoScene,
    opts: &MultifluxOptions,
    streams: usize,
) -> Vec<Scaled> {
    scene
        .layers()
        .iter()
        .map(|l| {
            // Eq. 4b for phase functions given as data only: the analytic
            // kinds (Henyey–Greenstein of any g included) keep `2N`.
            let data =
                matches!(l.phase(), Phase::Legendre(_) | Phase::Table(_) | Phase::Particles(_));
            let n_keep = if opts.delta_m && opts.peak_truncation && data {
                crate::legendre::kept_moments(|i| l.phase().legendre_moment(i), streams)
            } else {
                2 * streams
            };
            let chi: Vec<f64> = (0..=n_keep).map(|i| l.phase().legendre_moment(i)).collect();
            let omega = l.albedo();
            let (chi_s, omega_s, factor) = if opts.delta_m {
                delta_m(&chi, omega, n_keep)
            } else {
                (chi[..n_keep].to_vec(), omega, 1.0)
            };
            let tau = l.tau();
            Scaled {
                tau: tau * factor,
                tau_true: tau,
                omega: omega_s,
                chi: chi_s,
                n: l.n(),
                omega_true: omega,
                phase: l.phase().clone(),
                factor,
                secondary: opts.secondary_correction,
                rough: l.roughness(),
                n_keep,
            }
        })
        .collect()
}

/// `2 pi sum_i w_i mu_i I_i`: the flux of a radiance vector at the nodes.
pub(crate) fn flux(nodes: &MediumNodes, i: &[f64]) -> f64 {
    2.0 * std::f64::consts::PI
        * nodes.mu.iter().zip(&nodes.w).zip(i).map(|((u, w), x)| u * w * x).sum::<f64>()
}

/// The stream count of `opts`, or the scene's default; `1..=512`.
pub(crate) fn resolve_streams(
    scene: &MonoScene,
    opts: &MultifluxOptions,
) -> Result<usize, MultifluxError> {
    let streams = opts.streams.unwrap_or_else(|| default_streams(scene));
    if streams == 0 || streams > 512 {
        return Err(MultifluxError::Option {
            name: "streams",
            value: streams as f64,
            reason: "must lie in 1..=512",
        });
    }
    Ok(streams)
}

/// The media of the stack, top to bottom (ambient, layers, and a transparent
/// substrate unless a half-space hides it), and their Snell-mapped grid.
/// The grid is the one this thread kept for the same media and streams,
/// if any ([`AngularGrid::kept`]).
pub(crate) fn media_grid(scene: &MonoScene, streams: usize) -> (Option<f64>, Arc<AngularGrid>) {
    let half = scene.layers().last().is_some_and(|l| l.is_half_space() && l.tau() > 0.0);
    let n_sub = match scene.substrate() {
        Substrate::Transparent { n } if !half => Some(n),
        _ => None,
    };
    let media =
        std::iter::once(scene.ambient_n()).chain(scene.layers().iter().map(|l| l.n())).chain(n_sub);
    (n_sub, AngularGrid::kept(media, streams))
}

/// The scene as the plan's `transmission` rule leaves it (eq. PL1 of
/// `docs/planner.md`): when a layer is so thick that less than the returned
/// bound of the incident light comes back from below it, the stack is cut
/// there and that layer becomes a half-space. Returns the cut scene (`None`
/// when nothing is cut, or with all effects) and the bound.
pub(crate) fn planned_cutoff(
    scene: &MonoScene,
    opts: &MultifluxOptions,
) -> (Option<MonoScene>, Option<f64>) {
    if opts.all_effects {
        return (None, None);
    }
    let Some((i, bound)) = km_core::plan::transmission_cut(scene) else {
        return (None, None);
    };
    // The plan's layer index is in range, so the cut cannot fail.
    match scene.cut_below(i) {
        Ok(cut) => (Some(cut), Some(bound)),
        Err(_) => (None, None),
    }
}
