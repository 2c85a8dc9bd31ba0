//! One channel's BSDF table from the angular engine ([`crate::engine`]):
//! the beams at the incidence angles, one probe per exit polar angle and
//! side, the markers of the single-scattering correction (eq. B1–B2), and
//! the table's azimuthal stopping rule.

use super::*;
use crate::engine::{ChannelBsdf, Incidence, Prepared, Request, Stop};

/// One channel: returns its BSDF and the far-side index if light leaves there.
pub(super) fn channel(
    scene: &MonoScene,
    theta_i: &[f64],
    theta_o: &[f64],
    opts: &MultifluxOptions,
) -> Result<(ChannelBsdf, Option<f64>), BsdfError> {
    let streams = bsdf_streams(scene, theta_i, opts)?;
    let opts = MultifluxOptions { streams: Some(streams), ..opts.clone() };
    let prep = Prepared::new(scene, &opts, streams);
    let n0 = prep.scene.ambient_n();
    let beams: Vec<f64> = theta_i.iter().map(|t| n0 * t.to_radians().sin()).collect();
    // Fourier orders (as the solver: up to the last non-negligible moment).
    let last = last_moment(&prep.layers).min(opts.max_fourier_order.unwrap_or(usize::MAX));
    let req = Request {
        incidence: Incidence::Beams(&beams),
        theta_o,
        directions: &[],
        o_of: &[],
        stop: Stop::Table,
        last_order: last,
    };
    let (table, _) = prep.respond(&req)?;
    Ok((table, prep.n_sub))
}

/// The stream count: the options', or as `km solve` would choose it for the
/// most demanding incidence of `theta_i`.
fn bsdf_streams(
    scene: &MonoScene,
    theta_i: &[f64],
    opts: &MultifluxOptions,
) -> Result<usize, BsdfError> {
    Ok(match opts.streams {
        Some(_) => resolve_streams(scene, opts)?,
        None => default_bsdf_streams(scene, theta_i),
    })
}
