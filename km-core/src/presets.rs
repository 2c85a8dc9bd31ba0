//! Named measured materials usable in scene files (`preset = "marble"`).
//!
//! Values: Jensen, Marschner, Levoy & Hanrahan 2001, "A Practical Model for
//! Subsurface Light Transport", SIGGRAPH 2001, the table of measured reduced
//! scattering `sigma_s'` and absorption `sigma_a` in 1/mm for the R, G, B
//! channels, with the relative index `eta`. A preset layer therefore uses
//! millimetres as its length unit and has three channels. The scene's `g`
//! (default 0) turns `sigma_s'` into `sigma_s = sigma_s' / (1 - g)`.
//!
//! Verification (see `docs/diffusion.md`, "Measured materials"): all twelve
//! rows of `sigma_s'` and `sigma_a` agree digit for digit with the
//! transcription of the same table in pbrt-v3 (`src/core/medium.cpp`). For
//! apple, chicken1, chicken2, cream, potato and spectralon the index
//! `eta = 1.3` could not be checked against a second source (pbrt-v3 does not
//! carry it); for the six others it is confirmed by the table's diffuse
//! reflectance, which the dipole reproduces only with the listed `eta`
//! (marble: 1.5). A scene may override it with the layer's `n`.

/// A measured material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Preset {
    /// Name used in scene files.
    pub name: &'static str,
    /// Reduced scattering coefficient `sigma_s'` (R, G, B), 1/mm.
    pub sigma_s_prime: [f64; 3],
    /// Absorption coefficient `sigma_a` (R, G, B), 1/mm.
    pub sigma_a: [f64; 3],
    /// Relative refractive index.
    pub eta: f64,
}

#[rustfmt::skip]
const TABLE: &[Preset] = &[
    Preset { name: "apple",      sigma_s_prime: [2.29, 2.39, 1.97], sigma_a: [0.0030, 0.0034, 0.046],  eta: 1.3 },
    Preset { name: "chicken1",   sigma_s_prime: [0.15, 0.21, 0.38], sigma_a: [0.015, 0.077, 0.19],    eta: 1.3 },
    Preset { name: "chicken2",   sigma_s_prime: [0.19, 0.25, 0.32], sigma_a: [0.018, 0.088, 0.20],    eta: 1.3 },
    Preset { name: "cream",      sigma_s_prime: [7.38, 5.47, 3.15], sigma_a: [0.0002, 0.0028, 0.0163], eta: 1.3 },
    Preset { name: "ketchup",    sigma_s_prime: [0.18, 0.07, 0.03], sigma_a: [0.061, 0.97, 1.45],     eta: 1.3 },
    Preset { name: "marble",     sigma_s_prime: [2.19, 2.62, 3.00], sigma_a: [0.0021, 0.0041, 0.0071], eta: 1.5 },
    Preset { name: "potato",     sigma_s_prime: [0.68, 0.70, 0.55], sigma_a: [0.0024, 0.0090, 0.12],  eta: 1.3 },
    Preset { name: "skimmilk",   sigma_s_prime: [0.70, 1.22, 1.90], sigma_a: [0.0014, 0.0025, 0.0142], eta: 1.3 },
    Preset { name: "skin1",      sigma_s_prime: [0.74, 0.88, 1.01], sigma_a: [0.032, 0.17, 0.48],     eta: 1.3 },
    Preset { name: "skin2",      sigma_s_prime: [1.09, 1.59, 1.79], sigma_a: [0.013, 0.070, 0.145],   eta: 1.3 },
    Preset { name: "spectralon", sigma_s_prime: [11.6, 20.4, 14.9], sigma_a: [0.00, 0.00, 0.00],      eta: 1.3 },
    Preset { name: "wholemilk",  sigma_s_prime: [2.55, 3.21, 3.77], sigma_a: [0.0011, 0.0024, 0.014],  eta: 1.3 },
];

/// The preset of that name (case-insensitive), if any.
pub fn lookup(name: &str) -> Option<Preset> {
    TABLE.iter().find(|p| p.name.eq_ignore_ascii_case(name.trim())).copied()
}

/// All preset names.
pub fn names() -> Vec<&'static str> {
    TABLE.iter().map(|p| p.name).collect()
}
