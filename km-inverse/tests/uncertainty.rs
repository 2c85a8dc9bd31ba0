//! The covariance of the fit against Monte Carlo perturbation of the inputs.

use km_inverse::forward::{Optical, Sample};
use km_inverse::slab::{FitOptions, Measurement, Setup, fit, model};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

const STREAMS: usize = 8;

/// Perturb M_R and M_T by Gaussian noise of the stated standard
/// uncertainties, refit, and compare the spread of the answers with the
/// linearised covariance (eq. I8–I10 of docs/inverse.md).
///
/// Tolerances: with N = 200 draws the sample standard deviation has a
/// relative standard error 1/sqrt(2(N-1)) = 5.0 %, a sample correlation
/// (1 - rho^2)/sqrt(N); we allow 3.5 standard errors (17.5 %, and
/// 3.5 (1 - rho^2)/sqrt(N)). The noise (5e-4) is small enough that the
/// curvature of the model changes the spread by well under that.
#[test]
fn covariance_matches_monte_carlo() {
    let set = Setup::new(Sample::new(1.5, 1.4, Some(1.5)).unwrap());
    for truth in
        [Optical { albedo: 0.9, tau: 2.0, g: 0.0 }, Optical { albedo: 0.99, tau: 8.0, g: 0.5 }]
    {
        let m = model(&set, &truth, STREAMS).unwrap();
        let sigma = 5e-4;
        let meas = Measurement {
            sigma_r: Some(sigma),
            sigma_t: Some(sigma),
            ..Measurement::rt(m[0], m[1])
        };
        let opts = FitOptions { g: Some(truth.g), streams: Some(STREAMS) };
        let centre = fit(&set, &meas, &opts).unwrap();
        let u = centre.uncertainty.clone();
        assert!(!u.ill_conditioned, "{:?}", u.reasons);

        let mut rng = rand_pcg::Pcg64::seed_from_u64(20261129);
        let noise = Normal::new(0.0, sigma).unwrap();
        let n = 200;
        let mut draws = Vec::with_capacity(n);
        for _ in 0..n {
            let mm = Measurement {
                m_r: m[0] + noise.sample(&mut rng),
                m_t: m[1] + noise.sample(&mut rng),
                ..meas
            };
            let r = fit(&set, &mm, &opts).unwrap();
            draws.push([r.albedo, r.tau, r.mu_a, r.mu_s_prime]);
        }
        let mean = |k: usize| draws.iter().map(|d| d[k]).sum::<f64>() / n as f64;
        let sd = |k: usize| {
            let m = mean(k);
            (draws.iter().map(|d| (d[k] - m).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        };
        let predicted = [u.albedo, u.tau, u.mu_a, u.mu_s_prime];
        for (k, p) in predicted.iter().enumerate() {
            let ratio = sd(k) / p;
            let tol = 3.5 / (2.0 * (n - 1) as f64).sqrt();
            assert!((ratio - 1.0).abs() < tol, "{truth:?} parameter {k}: MC/linear = {ratio}");
        }
        // Correlation of a and b.
        let (ma, mb) = (mean(0), mean(1));
        let cov = draws.iter().map(|d| (d[0] - ma) * (d[1] - mb)).sum::<f64>() / (n - 1) as f64;
        let rho_mc = cov / (sd(0) * sd(1));
        let rho = u.correlation.iter().find(|(k, _)| k == "albedo_tau").unwrap().1;
        let tol = 3.5 * (1.0 - rho * rho) / (n as f64).sqrt();
        assert!((rho_mc - rho).abs() < tol.max(0.01), "rho MC {rho_mc} vs {rho}");
    }
}

/// The a = 1 edge and a thick slab whose M_T is below the noise are flagged.
#[test]
fn ill_conditioned_cases_are_flagged() {
    let set = Setup::new(Sample::new(1.0, 1.4, None).unwrap());
    let opts = FitOptions { g: Some(0.0), streams: Some(STREAMS) };
    // Nearly conservative thin slab: a within 2 u(a) of 1 at sigma = 1e-3.
    let m = model(&set, &Optical { albedo: 0.9999, tau: 0.5, g: 0.0 }, STREAMS).unwrap();
    let meas =
        Measurement { sigma_r: Some(1e-3), sigma_t: Some(1e-3), ..Measurement::rt(m[0], m[1]) };
    let r = fit(&set, &meas, &opts).unwrap();
    assert!(r.uncertainty.ill_conditioned, "{:?}", r.uncertainty);
    // A thick absorbing slab: M_T ~ 1e-9, far below sigma = 1e-3.
    let m = model(&set, &Optical { albedo: 0.9, tau: 30.0, g: 0.0 }, STREAMS).unwrap();
    let meas =
        Measurement { sigma_r: Some(1e-3), sigma_t: Some(1e-3), ..Measurement::rt(m[0], m[1]) };
    let r = fit(&set, &meas, &opts).unwrap();
    assert!(r.uncertainty.ill_conditioned, "M_T = {}: {:?}", m[1], r.uncertainty);
    // A well-measured slab is not flagged.
    let m = model(&set, &Optical { albedo: 0.9, tau: 2.0, g: 0.0 }, STREAMS).unwrap();
    let r = fit(&set, &Measurement::rt(m[0], m[1]), &opts).unwrap();
    assert!(!r.uncertainty.ill_conditioned, "{:?}", r.uncertainty);
}
