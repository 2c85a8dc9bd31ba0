//! Helpers shared by the recipes: distributions of the direction-set
//! solver cut along the plane of incidence, and their polar charts.

use km_multiflux::direction_set::{Distribution, StackResponse};

use crate::data::{Csv, num};
use km_plot::chart::{PolarChart, PolarCurve, PolarSpike, format_number};

/// The nodes of a distribution nearest to the plane of incidence: for each
/// ring (polar angle), the node of azimuth nearest 0 (back towards the
/// source) and nearest 180 (forward). Returns `(psi, value, theta, phi)`
/// sorted by `psi` (see [`km_plot::chart::PolarCurve`]); transmitted
/// directions use `psi` in `(90, 270)` so the curve is continuous through
/// the downward normal.
pub fn plane_cut(
    d: &Distribution,
    reflected: bool,
    node_values: bool,
) -> Vec<(f64, f64, f64, f64)> {
    let vals = if node_values { &d.node_value } else { &d.value };
    // Group by ring: equal theta within 1e-9 degrees.
    let mut rings: Vec<(f64, Option<usize>, Option<usize>)> = Vec::new();
    for (i, &t) in d.theta_deg.iter().enumerate() {
        let c = d.phi_deg[i].to_radians().cos();
        let k = match rings.iter().position(|r| (r.0 - t).abs() < 1e-9) {
            Some(k) => k,
            None => {
                rings.push((t, None, None));
                rings.len() - 1
            }
        };
        let cos_of = |j: usize| d.phi_deg[j].to_radians().cos();
        // Back side: largest cos(phi); forward: smallest.
        if rings[k].1.is_none_or(|j| c > cos_of(j)) {
            rings[k].1 = Some(i);
        }
        if rings[k].2.is_none_or(|j| c < cos_of(j)) {
            rings[k].2 = Some(i);
        }
    }
    let mut out = Vec::new();
    for (t, back, fwd) in rings {
        for (j, forward) in [(back, false), (fwd, true)] {
            let Some(j) = j else { continue };
            let psi = match (reflected, forward) {
                (true, true) => t,
                (true, false) => -t,
                (false, true) => 180.0 - t,
                (false, false) => 180.0 + t,
            };
            out.push((psi, vals[j], t, d.phi_deg[j]));
        }
    }
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    out.dedup_by(|a, b| (a.0 - b.0).abs() < 1e-9);
    out
}

/// A polar chart of a response: smooth BRDF above, smooth BTDF below,
/// delta parts as labelled spikes (length: the delta fraction, in the
/// chart's radial units, clipped).
pub fn response_chart(
    title: &str,
    theta_deg: f64,
    curves: &[(&str, &StackResponse, bool)],
) -> PolarChart {
    let mut chart = PolarChart {
        title: title.into(),
        incidence_deg: Some(theta_deg),
        r_label: "BRDF above / BTDF below the surface, 1/sr (spikes: delta fractions)".into(),
        surface: true,
        ..Default::default()
    };
    for (k, (label, r, dashed)) in curves.iter().enumerate() {
        // A side with no smooth part (e.g. a bare interface: deltas only)
        // gets no curve and no legend entry.
        let drawn = |v: &[(f64, f64)]| v.iter().any(|p| p.1 > 0.0);
        let up: Vec<(f64, f64)> =
            plane_cut(&r.reflected, true, false).iter().map(|p| (p.0, p.1)).collect();
        if drawn(&up) {
            chart.curves.push(PolarCurve {
                label: format!("{label} (R)"),
                points: up,
                colour: 2 * k,
                dashed: *dashed,
            });
        }
        if let Some(t) = &r.transmitted {
            let down: Vec<(f64, f64)> =
                plane_cut(t, false, false).iter().map(|p| (p.0, p.1)).collect();
            if drawn(&down) {
                chart.curves.push(PolarCurve {
                    label: format!("{label} (T)"),
                    points: down,
                    colour: 2 * k + 1,
                    dashed: *dashed,
                });
            }
        }
        if k == 0 {
            if r.reflectance_specular > 0.0 {
                chart.spikes.push(PolarSpike {
                    psi_deg: theta_deg,
                    length: f64::INFINITY,
                    label: format!("mirror {}", format_number(r.reflectance_specular)),
                });
            }
            if r.transmittance_direct > 0.0 {
                // Refracted beam direction below: from the transmitted node with the largest delta.
                let psi = r
                    .transmitted
                    .as_ref()
                    .and_then(|t| {
                        let delta: Vec<f64> =
                            t.node_value.iter().zip(&t.value).map(|(a, b)| a - b).collect();
                        let j = (0..delta.len()).max_by(|&a, &b| delta[a].total_cmp(&delta[b]))?;
                        Some(180.0 - t.theta_deg[j])
                    })
                    .unwrap_or(180.0 - theta_deg);
                chart.spikes.push(PolarSpike {
                    psi_deg: psi,
                    length: f64::INFINITY,
                    label: format!("beam {}", format_number(r.transmittance_direct)),
                });
            }
        }
    }
    chart
}

/// Add the plane cuts of a response to a CSV with columns
/// `case, side, psi_deg, theta_deg, phi_deg, value`.
pub fn response_csv(csv: &mut Csv, case: &str, r: &StackResponse) {
    for (p, side) in plane_cut(&r.reflected, true, false).iter().map(|p| (p, "R")) {
        csv.push(vec![case.into(), side.into(), num(p.0), num(p.2), num(p.3), num(p.1)]);
    }
    if let Some(t) = &r.transmitted {
        for p in plane_cut(t, false, false) {
            csv.push(vec![case.into(), "T".into(), num(p.0), num(p.2), num(p.3), num(p.1)]);
        }
    }
}

/// A new CSV for [`response_csv`].
pub fn response_csv_new() -> Csv {
    Csv::new(&["case", "side", "psi_deg", "theta_deg", "phi_deg", "value_per_sr"])
}

/// The spread of repeated wall times of one measurement, seconds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spread {
    /// Fastest run.
    pub min: f64,
    /// Median run (the mean of the two middle runs for an even count).
    pub median: f64,
    /// Slowest run.
    pub max: f64,
    /// Number of runs.
    pub runs: usize,
}

impl Spread {
    /// The spread of `times` (non-finite entries ignored; NaN for none).
    pub fn of(times: &[f64]) -> Spread {
        let mut t: Vec<f64> = times.iter().copied().filter(|v| v.is_finite()).collect();
        t.sort_by(f64::total_cmp);
        let n = t.len();
        if n == 0 {
            return Spread { min: f64::NAN, median: f64::NAN, max: f64::NAN, runs: 0 };
        }
        let median = if n % 2 == 1 { t[n / 2] } else { 0.5 * (t[n / 2 - 1] + t[n / 2]) };
        Spread { min: t[0], median, max: t[n - 1], runs: n }
    }

    /// `median s (min to max s, N runs)`.
    pub fn text(&self) -> String {
        format!(
            "{} s ({} to {} s, {} runs)",
            format_number(self.median),
            format_number(self.min),
            format_number(self.max),
            self.runs
        )
    }

    /// The ratio `self / other` of medians, with its extreme range
    /// `(self.min / other.max, self.max / other.min)`.
    pub fn ratio(&self, other: &Spread) -> (f64, f64, f64) {
        (self.median / other.median, self.min / other.max, self.max / other.min)
    }
}

/// A speed-up `(median, low, high)` as `median x (low to high)`.
pub fn ratio_text(r: (f64, f64, f64)) -> String {
    let f = |v: f64| if v >= 100.0 { format!("{v:.0}") } else { format!("{v:.2}") };
    format!("{}x ({} to {})", f(r.0), f(r.1), f(r.2))
}

/// Solve `repeats` times; the last solution and the spread of the solver's
/// own wall times (`Solution::seconds`).
///
/// # Errors
/// Solver errors.
pub fn timed_spread(
    method: crate::methods::Method,
    scene: &km_core::Scene,
    repeats: usize,
) -> anyhow::Result<(km_core::Solution, Spread)> {
    let mut times = Vec::new();
    let mut sol = crate::methods::solve(method, scene)?;
    times.push(sol.seconds);
    for _ in 1..repeats.max(1) {
        sol = crate::methods::solve(method, scene)?;
        times.push(sol.seconds);
    }
    Ok((sol, Spread::of(&times)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spreads_and_ratios() {
        let s = Spread::of(&[3.0, 1.0, f64::NAN, 2.0, 10.0]);
        assert_eq!((s.min, s.median, s.max, s.runs), (1.0, 2.5, 10.0, 4));
        let r = Spread { min: 4.0, median: 6.0, max: 8.0, runs: 3 }.ratio(&Spread {
            min: 1.0,
            median: 2.0,
            max: 4.0,
            runs: 3,
        });
        assert_eq!(r, (3.0, 1.0, 8.0));
        assert_eq!(ratio_text(r), "3.00x (1.00 to 8.00)");
        assert_eq!(Spread::of(&[]).runs, 0);
    }

    #[test]
    fn plane_cut_picks_the_nodes_nearest_the_plane() {
        // Two rings (10 and 40 degrees) of four azimuths; the value encodes the node.
        let d = Distribution {
            theta_deg: vec![10.0, 10.0, 10.0, 10.0, 40.0, 40.0, 40.0, 40.0],
            phi_deg: vec![0.0, 90.0, 180.0, 270.0, 10.0, 100.0, 190.0, 280.0],
            weight: vec![1.0; 8],
            mu: vec![1.0; 8],
            value: (0..8).map(f64::from).collect(),
            node_value: vec![0.0; 8],
        };
        let up = plane_cut(&d, true, false);
        // Back side (phi near 0) at -theta, forward (phi near 180) at +theta, sorted.
        let got: Vec<(f64, f64)> = up.iter().map(|p| (p.0, p.1)).collect();
        assert_eq!(got, vec![(-40.0, 4.0), (-10.0, 0.0), (10.0, 2.0), (40.0, 6.0)]);
        // Transmitted: forward at 180 - theta, back at 180 + theta.
        let down: Vec<f64> = plane_cut(&d, false, false).iter().map(|p| p.0).collect();
        assert_eq!(down, vec![140.0, 170.0, 190.0, 220.0]);
    }
}
