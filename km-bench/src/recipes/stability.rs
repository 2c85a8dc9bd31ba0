//! Stability maps: every method over (optical thickness 1e-6..1e6, albedo
//! 0..1) and over (g, incidence angle), with the energy-balance error and
//! the deviation from the reference at each cell, and a count of NaN,
//! negative and above-one answers.

use km_core::{Solution, Substrate};

use crate::context::{Ctx, Size};
use crate::data::{Csv, num};
use crate::methods::{self, Method};
use crate::report::{Section, Table};
use crate::scenes::slab;
use km_plot::chart::{HeatMap, format_number};

/// Bottom of the colour scale of the error maps: the rounding level of
/// `R + T + A - 1` in f64. One ulp of 1 is 2.2e-16 (machine epsilon); the
/// sum of four rounded terms of order 1 carries a few of them, so 1e-15
/// (about 4.5 ulp of 1) is the level below which a difference is rounding
/// noise. Cells at or below it share the darkest colour.
pub const BALANCE_FLOOR: f64 = 1e-15;

/// Monte Carlo's cap of steps per photon in the maps.
const STEP_CAP: u64 = 10_000;

/// The outcome of one cell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cell {
    /// Total reflectance.
    pub r: f64,
    /// Total transmittance.
    pub t: f64,
    /// Energy-balance error: `|R + T + A - 1|` plus every excursion of
    /// `R`, `T`, `A` below 0 or of `R + T` above 1.
    pub balance: f64,
    /// Any of `R`, `T`, `A` is NaN or infinite.
    pub non_finite: bool,
    /// Any of `R`, `T`, `A` is below `-1e-12` (round-off allowance).
    pub negative: bool,
    /// `R + T` exceeds `1 + 1e-12`.
    pub above_one: bool,
    /// Monte Carlo photons stopped by the step cap (0 for other methods):
    /// their weight is lost, so it shows as an energy-balance error.
    pub capped: u64,
}

/// Check a solution's first channel (energy balance, docs/benchmarks.md).
pub fn check(sol: &Solution) -> Option<Cell> {
    let c = sol.channels.first()?;
    let (r, t, a) = (c.reflectance, c.transmittance, c.absorptance);
    let non_finite = !(r.is_finite() && t.is_finite() && a.is_finite());
    // Round-off allowance: a few ulps of 1 over a long computation.
    let eps = 1e-12;
    let negative = r < -eps || t < -eps || a < -eps;
    let above_one = r + t > 1.0 + eps;
    let balance = (r + t + a - 1.0).abs()
        + (-r).max(0.0)
        + (-t).max(0.0)
        + (-a).max(0.0)
        + (r + t - 1.0).max(0.0);
    let capped = match &sol.diagnostics.method {
        km_core::solution::MethodDiagnostics::MonteCarlo(mc) => {
            mc.capped_photons.first().copied().unwrap_or(0)
        }
        _ => 0,
    };
    Some(Cell { r, t, balance, non_finite, negative, above_one, capped })
}

/// A two-parameter family of scenes.
pub struct Grid {
    /// Short name (file stems).
    pub name: &'static str,
    /// x axis label.
    pub x_label: &'static str,
    /// y axis label.
    pub y_label: &'static str,
    /// x values.
    pub x: Vec<f64>,
    /// y values.
    pub y: Vec<f64>,
    /// Logarithmic x.
    pub x_log: bool,
    /// The scene at (x, y).
    pub scene: fn(f64, f64) -> anyhow::Result<km_core::Scene>,
}

/// Optical thickness (log) × albedo, isotropic, index-matched, 30 degrees.
pub fn tau_albedo_grid(size: Size) -> Grid {
    let decades: Vec<f64> = match size {
        Size::Tiny => vec![-6.0, -2.0, 0.0, 2.0, 6.0],
        _ => (-6..=6).map(f64::from).collect(),
    };
    let albedo = match size {
        Size::Tiny => vec![0.0, 0.5, 0.99, 1.0],
        _ => vec![0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.99, 0.9999, 0.999999, 1.0],
    };
    Grid {
        name: "tau-albedo",
        x_label: "optical thickness tau",
        y_label: "albedo",
        x: decades.iter().map(|d| 10f64.powf(*d)).collect(),
        y: albedo,
        x_log: true,
        scene: |tau, albedo| {
            slab(tau, albedo, 0.0, 1.0, 30.0, Substrate::Transparent { n: 1.0 }, vec![])
        },
    }
}

/// g × incidence angle, tau = 1, albedo 0.9, n = 1.5 (total internal reflection inside).
pub fn g_angle_grid(size: Size) -> Grid {
    let g = match size {
        Size::Tiny => vec![-0.9, 0.0, 0.9],
        _ => vec![-0.9, -0.5, 0.0, 0.5, 0.9, 0.99],
    };
    let theta = match size {
        Size::Tiny => vec![0.0, 60.0, 89.0],
        _ => vec![0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 85.0, 89.0],
    };
    Grid {
        name: "g-angle",
        x_label: "incidence angle (deg)",
        y_label: "g",
        x: theta,
        y: g,
        x_log: false,
        scene: |theta, g| slab(1.0, 0.9, g, 1.5, theta, Substrate::Transparent { n: 1.0 }, vec![]),
    }
}

/// Albedo × g for a half-space of index 1.3 at normal incidence (the dipole's domain).
pub fn half_space_grid(size: Size) -> Grid {
    let albedo = match size {
        Size::Tiny => vec![0.1, 0.9, 1.0],
        _ => vec![0.01, 0.1, 0.3, 0.5, 0.7, 0.9, 0.99, 0.999, 1.0],
    };
    let g = match size {
        Size::Tiny => vec![-0.5, 0.0, 0.9],
        _ => vec![-0.9, -0.5, 0.0, 0.5, 0.9, 0.99],
    };
    Grid {
        name: "halfspace-albedo-g",
        x_label: "albedo",
        y_label: "g",
        x: albedo,
        y: g,
        x_log: false,
        scene: |albedo, g| {
            slab(f64::INFINITY, albedo, g, 1.3, 0.0, Substrate::Transparent { n: 1.0 }, vec![])
        },
    }
}

/// The counts over one map.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Counts {
    /// Cells.
    pub cells: usize,
    /// Cells the method refused with an error.
    pub refused: usize,
    /// Cells with a NaN or infinite answer.
    pub non_finite: usize,
    /// Cells with a negative `R`, `T` or `A`.
    pub negative: usize,
    /// Cells with `R + T > 1`.
    pub above_one: usize,
    /// Largest energy-balance error.
    pub max_balance: f64,
    /// Largest `|R - R_ref|` (NaN without a reference).
    pub max_deviation: f64,
}

impl Counts {
    /// Count one solved cell, store its balance error and its deviation from
    /// the reference `r_ref`; returns its status word.
    fn record(
        &mut self,
        c: &Cell,
        r_ref: Option<f64>,
        balance: &mut Option<f64>,
        deviation: &mut Option<f64>,
    ) -> &'static str {
        self.non_finite += c.non_finite as usize;
        self.negative += c.negative as usize;
        self.above_one += c.above_one as usize;
        let bal = if c.non_finite { f64::NAN } else { c.balance };
        *balance = Some(bal);
        if bal.is_finite() {
            self.max_balance = self.max_balance.max(bal);
        }
        if let Some(rr) = r_ref {
            let d = (c.r - rr).abs();
            *deviation = Some(d);
            if d.is_finite() {
                self.max_deviation =
                    if self.max_deviation.is_nan() { d } else { self.max_deviation.max(d) };
            }
        }
        if c.non_finite {
            "nan"
        } else if c.negative {
            "negative"
        } else if c.above_one {
            "above-one"
        } else {
            "ok"
        }
    }
}

/// Evaluate `method` over `grid`, draw the maps and write the CSV; returns the counts.
///
/// # Errors
/// Drawing or file errors (solver refusals are part of the result).
pub fn map(
    ctx: &Ctx,
    method: Method,
    reference: Option<Method>,
    grid: &Grid,
) -> anyhow::Result<(Counts, Vec<String>)> {
    let mut counts = Counts { max_deviation: f64::NAN, ..Default::default() };
    let mut balance = vec![vec![None; grid.x.len()]; grid.y.len()];
    let mut deviation = vec![vec![None; grid.x.len()]; grid.y.len()];
    let mut capped = vec![vec![false; grid.x.len()]; grid.y.len()];
    let mut csv = Csv::new(&[
        grid.x_label,
        grid.y_label,
        "R",
        "T",
        "balance_error",
        "R_reference",
        "deviation",
        "capped_photons",
        "status",
    ]);
    csv.comment(format!("stability map of {method} over {}", grid.name));
    csv.comment(format!(
        "reference: {}",
        reference.map(|m| m.to_string()).unwrap_or_else(|| "none".into())
    ));
    for (iy, &y) in grid.y.iter().enumerate() {
        for (ix, &x) in grid.x.iter().enumerate() {
            counts.cells += 1;
            let scene = (grid.scene)(x, y)?;
            // Monte Carlo: 10^4 steps per photon and 2 10^7 per cell at most (refusal beyond).
            let cell = methods::solve_bounded(method, &scene, STEP_CAP, 20_000_000)
                .ok()
                .and_then(|s| check(&s));
            let r_ref = reference
                .and_then(|m| methods::solve(m, &scene).ok())
                .and_then(|s| s.channels.first().map(|c| c.reflectance));
            let status = match cell {
                None => {
                    counts.refused += 1;
                    "refused"
                }
                Some(c) => {
                    let (bal, dev) = (&mut balance[iy][ix], &mut deviation[iy][ix]);
                    counts.record(&c, r_ref, bal, dev)
                }
            };
            let dev = deviation[iy][ix].unwrap_or(f64::NAN);
            let n_capped = cell.map_or(0, |c| c.capped);
            capped[iy][ix] = n_capped > 0;
            csv.push(vec![
                num(x),
                num(y),
                num(cell.map_or(f64::NAN, |c| c.r)),
                num(cell.map_or(f64::NAN, |c| c.t)),
                num(balance[iy][ix].unwrap_or(f64::NAN)),
                num(r_ref.unwrap_or(f64::NAN)),
                num(dev),
                n_capped.to_string(),
                status.into(),
            ]);
        }
    }
    let stem = format!("stability-{}-{}", method.family(), grid.name);
    ctx.csv(&stem, &mut csv)?;
    let mut stems = Vec::new();
    let hm = HeatMap {
        title: format!("{method}: energy-balance error"),
        x_label: grid.x_label.into(),
        y_label: grid.y_label.into(),
        x: grid.x.clone(),
        y: grid.y.clone(),
        x_log: grid.x_log,
        z: balance,
        z_label: format!("|R+T+A-1| + violations (floor {BALANCE_FLOOR:.0e})"),
        z_log: true,
        z_floor: BALANCE_FLOOR,
        marked: capped,
        mark_note: format!(
            "photons stopped at the cap of {STEP_CAP:.0e} steps; their lost weight is the error"
        ),
    };
    ctx.chart(&format!("{stem}-balance"), &hm)?;
    stems.push(format!("{stem}-balance"));
    if reference.is_some() {
        let hm = HeatMap {
            title: format!("{method}: |R - R_ref|"),
            z: deviation,
            z_label: format!("|R - R_ref| (floor {BALANCE_FLOOR:.0e})"),
            ..hm
        };
        ctx.chart(&format!("{stem}-deviation"), &hm)?;
        stems.push(format!("{stem}-deviation"));
    }
    Ok((counts, stems))
}

/// The stability section: every available method over its grids.
///
/// # Errors
/// Drawing or file errors.
pub fn recipe(ctx: &mut Ctx) -> anyhow::Result<Section> {
    let mut sec = Section::new("Stability maps");
    sec.text(
        "Each method is run over a grid of scenes spanning its hard cases: optical thickness \
         from 1e-6 to 1e6 against albedo from 0 to 1 (isotropic, index-matched, light at 30 \
         degrees), and Henyey-Greenstein g against the incidence angle up to 89 degrees (tau = 1, \
         albedo 0.9, n = 1.5, so light is trapped by total internal reflection). The dipole, which \
         only treats half-spaces, is mapped over albedo and g instead. The energy-balance error \
         is |R + T + A - 1| plus any excursion of R, T, A below 0 or of R + T above 1; a cell the \
         method refused with an error is grey, a NaN would be magenta.",
    );
    let mut table = Table::new(&[
        "method",
        "grid",
        "cells",
        "refused",
        "NaN",
        "negative",
        "R+T>1",
        "max balance error",
        "max |R-R_ref|",
    ]);
    let reference = methods::reference();
    let mut plans: Vec<(Method, Grid)> = Vec::new();
    for m in methods::stability_methods(ctx.size) {
        if m.family() == "dipole" {
            plans.push((m, half_space_grid(ctx.size)));
        } else {
            plans.push((m, tau_albedo_grid(ctx.size)));
            plans.push((m, g_angle_grid(ctx.size)));
        }
    }
    let mut bad = 0;
    let mut cells = 0;
    for (m, grid) in &plans {
        let reference = reference.filter(|r| r != m);
        let (c, stems) = map(ctx, *m, reference, grid)?;
        bad += c.non_finite + c.negative + c.above_one;
        cells += c.cells;
        let data = format!("stability-{}-{}", m.family(), grid.name);
        for s in stems {
            sec.figure_data(
                &s,
                format!(
                    "{m} over {}: {}",
                    grid.name,
                    if s.ends_with("balance") {
                        "energy-balance error"
                    } else {
                        "deviation from the reference"
                    }
                ),
                &data,
            );
        }
        table.push(vec![
            m.to_string(),
            grid.name.into(),
            c.cells.to_string(),
            c.refused.to_string(),
            c.non_finite.to_string(),
            c.negative.to_string(),
            c.above_one.to_string(),
            format_number(c.max_balance),
            if c.max_deviation.is_nan() {
                "no reference".into()
            } else {
                format_number(c.max_deviation)
            },
        ]);
    }
    sec.text(format!(
        "Counts over all maps: {cells} cells, {bad} with a NaN, a negative value or R + T > 1. \
         The reference of the deviation maps is {}.",
        reference.map(|r| r.to_string()).unwrap_or_else(|| "not available in this build".into())
    ));
    sec.table(table);
    ctx.headline = format!("{cells} cells, {bad} NaN/negative/>1");
    Ok(sec)
}
