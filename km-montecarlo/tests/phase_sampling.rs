//! Chi-square tests of the scattering-cosine samplers of every phase
//! function the tracer meets (`PhaseFunction::sample_cos`, docs/montecarlo.md
//! §2): closed-form inversions (Henyey–Greenstein, two-term HG, Rayleigh,
//! Reynolds–McCormick), the exact inversion of a table's interpolant, and
//! the inverse cumulative table of a Legendre series and of Mie particles
//! (km-core eq. P18). Each sampler draws 10^6 cosines into 60 bins of equal
//! probability under the exact phase function (its cumulative distribution
//! by Gauss quadrature on 40 000 intervals in angle, error < 1e-12); the
//! statistic follows chi^2(59) and the test rejects at p < 1e-4 (fixed
//! seeds: deterministic). The last test shows the statistic sees a wrong
//! sampler.

use std::f64::consts::PI;
use std::sync::Arc;

use km_core::mie::{Complex, Particles, SizeDistribution, particle_optics};
use km_core::phase::{
    LegendreSeries, ParticlePhase, Phase, PhaseFunction, PhaseTable, Population, Rayleigh,
    ReynoldsMcCormick, TwoTermHg,
};
use km_core::quadrature::gauss_legendre;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use statrs::distribution::{ChiSquared, ContinuousCDF};

const BINS: usize = 60;
const DRAWS: usize = 1_000_000;

/// Bin edges in `cos t` of equal probability `1/BINS` under `p`, ascending.
fn edges(p: &Phase) -> Vec<f64> {
    // Cumulative distribution from cos = -1 on intervals uniform in angle
    // (dense where a forward peak is), 8-point Gauss on each.
    let n = 40_000;
    let (x, w) = gauss_legendre(8);
    let mut cos = vec![-1.0];
    let mut cdf = vec![0.0];
    for k in 0..n {
        let (t0, t1) = (PI * (n - k) as f64 / n as f64, PI * (n - k - 1) as f64 / n as f64);
        let (a, b) = (t0.cos(), t1.cos());
        let (h, m) = (0.5 * (b - a), 0.5 * (b + a));
        let mass: f64 = x.iter().zip(&w).map(|(xi, wi)| wi * p.eval(m + h * xi)).sum::<f64>();
        cdf.push(cdf[k] + 2.0 * PI * h * mass);
        cos.push(b);
    }
    let total = cdf[n];
    assert!((total - 1.0).abs() < 1e-9, "{}: normalisation {total}", p.kind());
    (1..BINS)
        .map(|i| {
            let u = i as f64 / BINS as f64 * total;
            let k = cdf.partition_point(|&f| f < u).max(1);
            let t = (u - cdf[k - 1]) / (cdf[k] - cdf[k - 1]);
            cos[k - 1] + t * (cos[k] - cos[k - 1])
        })
        .collect()
}

/// The chi-square p-value of `sampler`'s draws against the bins of `p`.
fn p_value(p: &Phase, sampler: &Phase, seed: u64) -> f64 {
    let e = edges(p);
    let mut counts = [0usize; BINS];
    let mut rng = Pcg64::seed_from_u64(seed);
    for _ in 0..DRAWS {
        let c = sampler.sample_cos(rng.random::<f64>());
        counts[e.partition_point(|&x| x < c)] += 1;
    }
    let expect = DRAWS as f64 / BINS as f64;
    let stat: f64 = counts.iter().map(|&o| (o as f64 - expect).powi(2) / expect).sum();
    1.0 - ChiSquared::new((BINS - 1) as f64).unwrap().cdf(stat)
}

fn mie() -> Phase {
    let particles = Particles {
        index: Complex::new(1.55, 0.001),
        volume_fraction: 0.01,
        distribution: SizeDistribution::Mono { radius_um: 1.0 },
    };
    let optics = particle_optics(&particles, 1.33, 550.0).unwrap();
    let pop = Population { particles, host_n: 1.33, wavelength_nm: 550.0, optics };
    Phase::Particles(Arc::new(ParticlePhase::new(vec![pop]).unwrap()))
}

fn kinds() -> Vec<Phase> {
    let series: Vec<f64> = (1..=120).map(|l| 0.8f64.powi(l)).collect();
    let th = [0.0f64, 5.0, 20.0, 60.0, 100.0, 150.0, 180.0];
    let cos: Vec<f64> = th.iter().map(|t| t.to_radians().cos()).collect();
    vec![
        Phase::henyey_greenstein(0.9).unwrap(),
        Phase::TwoTermHg(TwoTermHg::new(0.9, -0.4, 0.85).unwrap()),
        Phase::Rayleigh(Rayleigh::new(0.0279).unwrap()),
        Phase::ReynoldsMcCormick(Arc::new(ReynoldsMcCormick::new(0.85, 1.2).unwrap())),
        Phase::Legendre(Arc::new(LegendreSeries::new(&series).unwrap())),
        Phase::Table(Arc::new(
            PhaseTable::new(&cos, &[80.0, 40.0, 6.0, 1.0, 0.5, 0.7, 1.2]).unwrap(),
        )),
        mie(),
    ]
}

#[test]
fn every_sampler_passes_chi_square() {
    for (i, p) in kinds().iter().enumerate() {
        let pv = p_value(p, p, 100 + i as u64);
        eprintln!("{}: p = {pv:.3}", p.kind());
        assert!(pv > 1e-4, "{}: chi-square p = {pv:.2e}", p.kind());
    }
}

/// The test can fail: Henyey–Greenstein draws of the two-term function's
/// mean cosine against the two-term bins, and the Mie function's draws
/// against its own bins shifted by a tenth of a degree, are rejected.
#[test]
fn a_wrong_sampler_is_rejected() {
    let tt = Phase::TwoTermHg(TwoTermHg::new(0.9, -0.4, 0.85).unwrap());
    let hg = Phase::henyey_greenstein(tt.g()).unwrap();
    assert!(p_value(&tt, &hg, 7) < 1e-12);
    let narrow = Phase::henyey_greenstein(0.9).unwrap();
    let wide = Phase::henyey_greenstein(0.89).unwrap();
    assert!(p_value(&narrow, &wide, 8) < 1e-6, "g 0.9 vs 0.89 not seen");
}

/// A truncated series that rings negative is refused by the tracer with
/// the layer named, before any photon is traced.
#[test]
fn a_negative_series_is_refused() {
    let s = km_core::Scene::from_toml_str(
        "[[layer]]\ntau = 1\nalbedo = 0.9\nphase = { kind = \"legendre\", moments = [0.95, 0.9, 0.85, 0.8] }\n",
    )
    .unwrap();
    let e =
        km_montecarlo::solve(&s, &km_montecarlo::McOptions { samples: 1000, ..Default::default() })
            .unwrap_err()
            .to_string();
    assert!(e.contains("layer[1].phase") && e.contains("negative"), "{e}");
}
