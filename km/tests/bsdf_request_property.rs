//! The budgets of a BSDF table request (docs/limits.md §1: the grid limits
//! of `km::bsdf_file::check_grid` and the work of the operators, eq. W2,
//! both scaled by the request's budget factor), over random grids, through
//! `km::bsdf_file::bsdf_file` as `km bsdf` calls it: every request either
//! completes, with the table it asked for and within a time bound, or is
//! refused before any work naming the grid list at fault or the work —
//! never a panic, never unbounded work.
//!
//! The sizes are random (theta_i and theta_o 1 to 400 angles, phi 1 to
//! 4000 azimuths, 1 to 3 channels, so up to 1.9 10^9 table values), and so
//! are the budget factor (10^-3 to 10^-1.5, so that a completed table has at
//! most 1.3 10^5 values and 3 10^8 work units: well under a second), the
//! streams (2 to 8 per hemisphere) and, one time in eight, an azimuth
//! beyond one turn (refused whatever the sizes). Whether a grid is over its
//! limits is computed here from the sizes, independently of the check.
//!
//! Before eq. W2 a table of 372 incidence angles in 3 channels at a
//! hundredth of the grid budget ran for 3.2 s, and at budget 1 the grid
//! limits let through 2.6 10^5 incidence angles, each a beam carried through
//! every operator (work as the cube of their number: 800 angles took 6.3 s).

use std::time::Instant;

use km::Scene;
use km::bsdf::BsdfError;
use km::bsdf_file::{BsdfFormat, BsdfRequest, MAX_PAIRS, MAX_PHI_DEG, MAX_TABLE_VALUES, bsdf_file};
use km_multiflux::MultifluxError;
use km_multiflux::budget::{DEFAULT_MAX_WORK, estimate_bsdf};
use proptest::prelude::*;

/// One request: channels, theta_i, theta_o, phi counts, streams per
/// hemisphere, budget factor, an azimuth out of range.
type Case = (usize, usize, usize, usize, usize, f64, bool);

fn case() -> impl Strategy<Value = Case> {
    // Counts n^(u^2)-like (u uniform): small grids, which complete, more
    // often than huge ones, which must be refused.
    let count =
        |max: f64| (0.0f64..1.0).prop_map(move |u| max.powf(u * u).round().max(1.0) as usize);
    (1usize..=3, count(400.0), count(400.0), count(4000.0), 1usize..=4, -3.0f64..-1.5, 0u8..8)
        .prop_map(|(c, ni, no, np, s, b, far)| (c, ni, no, np, 2 * s, 10f64.powf(b), far == 0))
}

/// `n` polar angles evenly in [0, 85] degrees.
fn polar(n: usize) -> Vec<f64> {
    (0..n).map(|k| 85.0 * k as f64 / n.max(2) as f64).collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn a_bsdf_table_completes_within_its_budget_or_is_refused_up_front(
        (channels, ni, no, np, streams, budget, far) in case()
    ) {
        let taus: Vec<String> = (0..channels).map(|c| format!("{}", 0.5 + c as f64)).collect();
        let text = format!("[[layer]]\ntau = [{}]\nalbedo = 0.9\ng = 0.5\nn = 1.3\n", taus.join(", "));
        let scene = Scene::from_toml_str(&text).unwrap();
        let mut phi: Vec<f64> = (0..np).map(|k| 360.0 * k as f64 / np as f64 - 180.0).collect();
        if far {
            phi[np / 2] = 2.0 * MAX_PHI_DEG;
        }
        let request = BsdfRequest {
            theta_i: polar(ni),
            theta_o: polar(no),
            phi,
            from_below: false,
            streams: Some(streams),
            fourier_tol: None,
            format: BsdfFormat::Npz,
            budget,
            channel_mix: None,
        };
        // Eq. L5: angle pairs and table values against their budgets.
        let pairs = (channels * ni * no) as f64;
        let values = pairs * np as f64;
        let over_pairs = pairs > MAX_PAIRS as f64 * budget;
        let over_values = values > MAX_TABLE_VALUES as f64 * budget;
        let over_grid = far || over_pairs || over_values;
        let t = Instant::now();
        let out = bsdf_file(&scene, "case.toml", &text, &request, true);
        let secs = t.elapsed().as_secs_f64();
        match out {
            Ok(file) => {
                prop_assert!(!over_grid, "{pairs} pairs, {values} values at budget {budget} ran");
                let b = &file.bsdf;
                prop_assert_eq!((b.channels.len(), b.theta_i.len(), b.theta_o.len()),
                    (channels, ni, no));
                prop_assert_eq!(file.phi.len(), np);
                prop_assert!(file.bytes.as_ref().is_some_and(|v| !v.is_empty()));
                let o = km::MultifluxOptions { streams: Some(streams), ..Default::default() };
                let w = estimate_bsdf(&scene, &o, &request.theta_i, &request.theta_o).units;
                prop_assert!(w <= DEFAULT_MAX_WORK * budget, "{w} units ran at budget {budget}");
                // At most 3 10^8 work units: 0.2 to 0.8 s at the 0.7 to
                // 2.6 ns per unit of eq. W1's calibration; 10 s is the guard
                // against unbounded work on a loaded machine.
                prop_assert!(secs < 10.0, "{values} values took {secs} s");
            }
            Err(BsdfError::Input { name, reason }) => {
                // The first rule broken is named: the azimuth's range, then
                // the pairs (theta_o), then the table values (phi).
                let expected = if far || !over_pairs { "phi" } else { "theta_o" };
                prop_assert!(far || over_pairs || over_values,
                    "refused within budget: {name}: {reason}");
                prop_assert_eq!(name, expected, "{}", reason);
                // Before any work: no operator was built.
                prop_assert!(secs < 0.5, "the refusal took {secs} s");
            }
            Err(BsdfError::Solver(MultifluxError::TooExpensive { work, budget: b, .. })) => {
                // A grid within its limits whose operators are over the work
                // budget (eq. W2), refused before they are built.
                prop_assert!(!over_grid, "the grid check came first: {pairs} pairs");
                prop_assert!((b - DEFAULT_MAX_WORK * budget).abs() <= 1e-9 * b, "budget {b}");
                prop_assert!(work > b, "refused at {work} within {b}");
                prop_assert!(secs < 0.5, "the refusal took {secs} s");
            }
            Err(e) => prop_assert!(false, "{pairs} pairs, {values} values: unexpected {e}"),
        }
    }
}
