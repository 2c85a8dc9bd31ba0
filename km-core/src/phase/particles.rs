//! The phase function of a layer's particles by Mie theory (docs/mie.md):
//! the scattering-weighted mean of the populations' Legendre series
//! (eq. M15), with what each population contributes, for reports.

use super::table::LegendreSeries;
use crate::error::CoreError;
use crate::mie::{ParticleOptics, Particles};

/// One population's share of a layer's optics at one wavelength: its
/// parameters and [`ParticleOptics`] without the moments.
#[derive(Debug, Clone, PartialEq)]
pub struct Population {
    /// The particles as given (index, volume fraction, sizes).
    pub particles: Particles,
    /// Host index and vacuum wavelength (nm) they were computed for.
    pub host_n: f64,
    /// Vacuum wavelength, nm.
    pub wavelength_nm: f64,
    /// The Mie results (in a [`ParticlePhase`] the `moments` field is
    /// emptied: the phase holds the mixture's).
    pub optics: ParticleOptics,
}

/// The phase function of one or more particle populations (eq. M15).
#[derive(Debug, Clone, PartialEq)]
pub struct ParticlePhase {
    series: LegendreSeries,
    populations: Vec<Population>,
}

impl ParticlePhase {
    /// The mixture of populations: moments weighted by each population's
    /// `sigma_s` (eq. M15). A mixture that scatters nothing is refused (the
    /// caller gives such a layer no phase function).
    ///
    /// # Errors
    /// No population, or a total `sigma_s` of 0, or moments out of range
    /// (cannot happen for Mie moments; checked as any Legendre series).
    pub fn new(pops: Vec<Population>) -> Result<ParticlePhase, CoreError> {
        let total: f64 = pops.iter().map(|p| p.optics.sigma_s).sum();
        if total.is_nan() || total <= 0.0 {
            return Err(CoreError::invalid(
                "particles sigma_s",
                total,
                "the particles scatter nothing",
            ));
        }
        let len = pops.iter().map(|p| p.optics.moments.len()).max().unwrap_or(1);
        let mut chi = vec![0.0; len];
        for p in &pops {
            let w = p.optics.sigma_s / total;
            for (c, m) in chi.iter_mut().zip(p.optics.moments.iter()) {
                *c += w * m;
            }
        }
        // chi_0 = 1 by construction; rounding may leave |chi_l| a hair above 1.
        let from_1: Vec<f64> = chi.iter().skip(1).map(|c| c.clamp(-1.0, 1.0)).collect();
        let series = LegendreSeries::new(&from_1)?;
        let populations = pops
            .into_iter()
            .map(|mut p| {
                p.optics.moments = Vec::new();
                p
            })
            .collect();
        Ok(ParticlePhase { series, populations })
    }

    /// The mixture's Legendre series.
    pub fn series(&self) -> &LegendreSeries {
        &self.series
    }

    /// The populations, in the order given.
    pub fn populations(&self) -> &[Population] {
        &self.populations
    }
}
