//! Mie theory: light scattering by homogeneous spheres (docs/mie.md).
//!
//! * [`Sphere`]: one sphere of relative index `m` and size parameter `x`;
//!   its coefficients `a_n`, `b_n` by Wiscombe's algorithm (downward
//!   recurrence of the logarithmic derivative `D_n(m x)` started by Lentz's
//!   continued fraction, `psi_n(x)` from the downward ratio, `chi_n(x)`
//!   upward), stable for absorbing spheres and up to `x` =
//!   [`MAX_SIZE_PARAMETER`]; efficiencies `Q_ext`, `Q_sca`, `Q_abs`,
//!   `Q_back`, the asymmetry `g`, the amplitudes `S1`, `S2` and the phase
//!   function.
//! * [`phase_moments`]: the phase function's Legendre moments (DISORT's
//!   `PMOM`, `chi_0 = 1`), exact by Gauss quadrature.
//! * [`particle_optics`]: a population of spheres ([`Particles`]: index,
//!   volume fraction, [`SizeDistribution`] mono or lognormal) in a host of
//!   real index: `sigma_s`, `sigma_a` (1/micrometre) and the moments of the
//!   scattering-weighted phase function, for independent scattering.
//! * [`Complex`]: the complex numbers of the above.
//!
//! # Reference
//! W. J. Wiscombe, "Mie scattering calculations: advances in technique and
//! fast, vector-speed computer codes", NCAR/TN-140+STR (1979, revised 1996);
//! W. J. Wiscombe, "Improved Mie scattering algorithms", Appl. Opt. 19,
//! 1505–1509 (1980); C. F. Bohren & D. R. Huffman, *Absorption and
//! Scattering of Light by Small Particles*, Wiley (1983), ch. 4;
//! W. J. Lentz, Appl. Opt. 15, 668–671 (1976).

mod complex;
mod distribution;
mod moments;
mod sphere;

pub use complex::Complex;
pub use distribution::{
    MAX_AMPLITUDE_WORK, ParticleOptics, Particles, QUADRATURE_TOL, SizeDistribution,
    particle_optics,
};
pub use moments::phase_moments;
pub use sphere::{MAX_MX, MAX_SIZE_PARAMETER, MIN_SIZE_PARAMETER, Sphere, series_orders};
