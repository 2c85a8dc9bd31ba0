//! Spatially and angularly resolved tallies on MCML's grid (Wang, Jacques &
//! Zheng 1995, §4): depth bins `dz` (and their overflow), radial bins `dr`
//! (and their overflow) and exit-angle bins `da = pi / (2 na)`.
//!
//! What is tallied per photon (docs/montecarlo.md §7, eqs. G1–G9):
//! * `A(r, z)` and `A(z)`: the weight booked as absorbed at each interaction
//!   (implicit capture and the roulette's zero-mean bookings, or the analog
//!   absorption), in the bin of the interaction site; `r` is the distance
//!   from the point where the light enters (the origin).
//! * `phi(z)`: the collision estimator of the fluence, `w / sigma_t` of the
//!   weight `w` arriving at each interaction; laterally integrated and per
//!   unit incident power it is the fluence rate per unit irradiance of a
//!   broad beam (eq. G4).
//! * `Rd(r, a)`, `Tt(r, a)` and their marginals: the weight leaving through
//!   the top (except the specular reflection at the launch) or the bottom,
//!   at the exit radius and the exit polar angle in the outside medium.
//!
//! Bins are half-open, `[i dz, (i + 1) dz)`; a site beyond the last bin goes
//! to an overflow bin (index `nz`, `nr`), which the MCML writer folds into
//! the last bin as MCML does. The angle bins cover `[0, pi/2]` exactly (a
//! grazing exit goes to the last bin).

use serde::{Deserialize, Serialize};

use crate::error::McError;

/// Largest number of bins of any one axis of a [`McGrid`] (`2^20`).
pub const MAX_GRID_AXIS: usize = 1 << 20;

/// An MCML-style grid (docs/montecarlo.md §7).
///
/// ```
/// let g = km_montecarlo::McGrid { dz: 0.01, nz: 40, dr: 0.01, nr: 50, na: 30 };
/// g.validate().unwrap();
/// assert_eq!(g.sums(), 2 * 41 + 2 * 51 + 2 * 30 + 51 * 41 + 2 * 51 * 30);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct McGrid {
    /// Depth bin width, in the scene's length unit (`> 0`).
    pub dz: f64,
    /// Number of depth bins (`>= 1`); one more holds the overflow.
    pub nz: usize,
    /// Radial bin width, in the scene's length unit (`> 0`).
    pub dr: f64,
    /// Number of radial bins (`0`: none, only the overflow bin that holds
    /// everything); one more holds the overflow.
    pub nr: usize,
    /// Number of exit-angle bins of width `pi / (2 na)` (`0`: one bin).
    pub na: usize,
}

/// The bin counts of a grid as stored (overflow bins included).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct GridDims {
    /// Depth bins plus overflow (`0`: no grid).
    pub z: usize,
    /// Radial bins plus overflow.
    pub r: usize,
    /// Angle bins (at least 1).
    pub a: usize,
}

impl GridDims {
    /// Number of sums: `phi(z)`, `A(z)`, `Rd(r)`, `Tt(r)`, `Rd(a)`, `Tt(a)`,
    /// `A(r, z)`, `Rd(r, a)`, `Tt(r, a)`.
    pub fn len(&self) -> usize {
        if self.z == 0 {
            return 0;
        }
        2 * self.z + 2 * self.r + 2 * self.a + self.r * self.z + 2 * self.r * self.a
    }

    /// The same with overflow checks (numbers read from a file).
    pub fn checked_len(&self) -> Option<usize> {
        if self.z == 0 {
            return (self.r == 0 && self.a == 0).then_some(0);
        }
        let two = |x: usize| x.checked_mul(2);
        two(self.z)?
            .checked_add(two(self.r)?)?
            .checked_add(two(self.a)?)?
            .checked_add(self.r.checked_mul(self.z)?)?
            .checked_add(two(self.r.checked_mul(self.a)?)?)
    }
}

impl McGrid {
    /// The stored bin counts.
    pub(crate) fn dims(&self) -> GridDims {
        GridDims { z: self.nz + 1, r: self.nr + 1, a: self.na.max(1) }
    }

    /// Number of `f64` sums per batch and channel the grid adds.
    pub fn sums(&self) -> usize {
        self.dims().len()
    }

    /// Width of an angle bin, `pi / (2 max(na, 1))` radians.
    pub fn da(&self) -> f64 {
        std::f64::consts::FRAC_PI_2 / self.na.max(1) as f64
    }

    /// Check the grid.
    ///
    /// # Errors
    /// [`McError::Option`] naming the field.
    pub fn validate(&self) -> Result<(), McError> {
        let bad = |name, value: String, reason| Err(McError::Option { name, value, reason });
        if !(self.dz.is_finite() && self.dz > 0.0) {
            return bad("grid.dz", self.dz.to_string(), "must be finite and > 0");
        }
        if !(self.dr.is_finite() && self.dr > 0.0) {
            return bad("grid.dr", self.dr.to_string(), "must be finite and > 0");
        }
        if self.nz == 0 {
            return bad("grid.nz", "0".into(), "need at least one depth bin");
        }
        for (name, n) in [("grid.nz", self.nz), ("grid.nr", self.nr), ("grid.na", self.na)] {
            if n > MAX_GRID_AXIS {
                return bad(name, n.to_string(), "more than 2^20 bins on one axis");
            }
        }
        if self.dims().checked_len().is_none_or(|n| n > 1 << 28) {
            return bad(
                "grid",
                format!("{} x {} x {}", self.nz, self.nr, self.na),
                "more than 2^28 sums per batch",
            );
        }
        Ok(())
    }
}

/// Offsets of the grid's sums in a batch's vector (from `base`), in the
/// order `phi(z)`, `Rd(r)`, `Tt(r)`, `Rd(a)`, `Tt(a)`, `Rd(r, a)`,
/// `Tt(r, a)`, `A(z)`, `A(r, z)`: every sum before `A(z)` is a sum of
/// positive weights, the `A` sums hold the roulette's signed bookings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct GridOffsets {
    pub dims: GridDims,
    pub phi_z: usize,
    pub rd_r: usize,
    pub tt_r: usize,
    pub rd_a: usize,
    pub tt_a: usize,
    pub rd_ra: usize,
    pub tt_ra: usize,
    pub a_z: usize,
    pub a_rz: usize,
}

impl GridOffsets {
    pub fn new(base: usize, d: GridDims) -> GridOffsets {
        let phi_z = base;
        let rd_r = phi_z + d.z;
        let tt_r = rd_r + d.r;
        let rd_a = tt_r + d.r;
        let tt_a = rd_a + d.a;
        let rd_ra = tt_a + d.a;
        let tt_ra = rd_ra + d.r * d.a;
        let a_z = tt_ra + d.r * d.a;
        let a_rz = a_z + d.z;
        GridOffsets { dims: d, phi_z, rd_r, tt_r, rd_a, tt_a, rd_ra, tt_ra, a_z, a_rz }
    }
}

/// Per channel, the grid's results: means per photon normalised as MCML
/// normalises them (eqs. G1–G9 of docs/montecarlo.md), each with its
/// standard error (eq. T1). Arrays include the overflow bins (last index of
/// the `z` and `r` axes); 2-D arrays are row-major, `[ir][iz]` and `[ir][ia]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GridResult {
    /// The grid.
    pub grid: McGrid,
    /// Diffuse reflectance: all reflected weight but the launch's specular part.
    pub rd: f64,
    /// Its standard error.
    pub rd_se: f64,
    /// Total transmittance (the direct part included).
    pub tt: f64,
    /// Its standard error.
    pub tt_se: f64,
    /// `A(z)`, absorbed power per unit depth per unit incident power (1/L), `nz + 1` bins.
    pub a_z: Vec<f64>,
    /// Standard errors of `a_z`.
    pub a_z_se: Vec<f64>,
    /// `phi(z)`, laterally integrated fluence per unit incident power (eq. G4), `nz + 1` bins.
    pub phi_z: Vec<f64>,
    /// Standard errors of `phi_z`.
    pub phi_z_se: Vec<f64>,
    /// Net downward flux per unit incident power at the depths `i dz`,
    /// `i = 0..=nz` (eq. G5).
    pub flux_z: Vec<f64>,
    /// Standard errors of `flux_z`.
    pub flux_z_se: Vec<f64>,
    /// `A(r, z)` per unit volume (1/L^3), `(nr + 1) x (nz + 1)`.
    pub a_rz: Vec<f64>,
    /// Standard errors of `a_rz`.
    pub a_rz_se: Vec<f64>,
    /// `Rd(r)` per unit area (1/L^2), `nr + 1` bins.
    pub rd_r: Vec<f64>,
    /// Standard errors of `rd_r`.
    pub rd_r_se: Vec<f64>,
    /// `Tt(r)` per unit area (1/L^2), `nr + 1` bins.
    pub tt_r: Vec<f64>,
    /// Standard errors of `tt_r`.
    pub tt_r_se: Vec<f64>,
    /// `Rd(a)` per unit solid angle (1/sr), `max(na, 1)` bins.
    pub rd_a: Vec<f64>,
    /// Standard errors of `rd_a`.
    pub rd_a_se: Vec<f64>,
    /// `Tt(a)` per unit solid angle (1/sr).
    pub tt_a: Vec<f64>,
    /// Standard errors of `tt_a`.
    pub tt_a_se: Vec<f64>,
    /// `Rd(r, a)` per unit area and solid angle (1/(L^2 sr)), `(nr + 1) x max(na, 1)`.
    pub rd_ra: Vec<f64>,
    /// Standard errors of `rd_ra`.
    pub rd_ra_se: Vec<f64>,
    /// `Tt(r, a)` per unit area and solid angle (1/(L^2 sr)).
    pub tt_ra: Vec<f64>,
    /// Standard errors of `tt_ra`.
    pub tt_ra_se: Vec<f64>,
    /// The bin sums per photon before the division by the bins' sizes,
    /// for writers that fold overflow bins or normalise otherwise (MCML).
    pub raw: GridRaw,
}

/// Grid sums per photon before normalisation (weights per photon), with
/// their standard errors: what a writer needs to fold overflow bins.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct GridRaw {
    /// `A` per depth bin.
    pub a_z: Vec<f64>,
    /// Standard errors.
    pub a_z_se: Vec<f64>,
    /// `sum w / sigma_t` per depth bin.
    pub phi_z: Vec<f64>,
    /// Standard errors.
    pub phi_z_se: Vec<f64>,
    /// `A` per `(r, z)` bin.
    pub a_rz: Vec<f64>,
    /// Standard errors.
    pub a_rz_se: Vec<f64>,
    /// `Rd` per `r` bin.
    pub rd_r: Vec<f64>,
    /// Standard errors.
    pub rd_r_se: Vec<f64>,
    /// `Tt` per `r` bin.
    pub tt_r: Vec<f64>,
    /// Standard errors.
    pub tt_r_se: Vec<f64>,
    /// `Rd` per angle bin.
    pub rd_a: Vec<f64>,
    /// Standard errors.
    pub rd_a_se: Vec<f64>,
    /// `Tt` per angle bin.
    pub tt_a: Vec<f64>,
    /// Standard errors.
    pub tt_a_se: Vec<f64>,
    /// `Rd` per `(r, a)` bin.
    pub rd_ra: Vec<f64>,
    /// Standard errors.
    pub rd_ra_se: Vec<f64>,
    /// `Tt` per `(r, a)` bin.
    pub tt_ra: Vec<f64>,
    /// Standard errors.
    pub tt_ra_se: Vec<f64>,
}

/// Area of radial bin `i` of width `dr`: `pi ((i+1)^2 - i^2) dr^2 = 2 pi (i + 1/2) dr^2` (eq. G6).
pub fn ring_area(i: usize, dr: f64) -> f64 {
    2.0 * std::f64::consts::PI * (i as f64 + 0.5) * dr * dr
}

/// Solid angle of angle bin `i` of width `da`: `2 pi (cos(i da) - cos((i+1) da))` (eq. G7).
pub fn cone_ring_solid_angle(i: usize, da: f64) -> f64 {
    let (a0, a1) = (i as f64 * da, (i + 1) as f64 * da);
    // cos a0 - cos a1 = 2 sin((a0 + a1) / 2) sin((a1 - a0) / 2), without cancellation.
    4.0 * std::f64::consts::PI * (0.5 * (a0 + a1)).sin() * (0.5 * da).sin()
}

/// Projected area times solid angle of bin `(ir, ia)` as MCML uses it,
/// `2 pi (i + 1/2) dr^2 cos(a_j) 4 pi sin(a_j) sin(da / 2)` at the bin's
/// centre angle `a_j = (j + 1/2) da` (eq. G8).
pub fn ra_norm(ir: usize, ia: usize, dr: f64, da: f64) -> f64 {
    let a = (ia as f64 + 0.5) * da;
    ring_area(ir, dr) * 4.0 * std::f64::consts::PI * a.sin() * a.cos() * (0.5 * da).sin()
}

/// Build the grid result of one channel from its batch statistics;
/// `r_index` is the index of the total reflected weight.
pub(crate) fn grid_result(
    s: &crate::stats::BatchStats,
    o: &GridOffsets,
    grid: McGrid,
    r_index: usize,
) -> GridResult {
    let d = o.dims;
    let mean_se = |start: usize, n: usize| -> (Vec<f64>, Vec<f64>) {
        let m = (start..start + n).map(|j| s.mean(j)).collect();
        (m, (start..start + n).map(|j| s.stderr(j)).collect())
    };
    let (a_z, a_z_se) = mean_se(o.a_z, d.z);
    let (phi_z, phi_z_se) = mean_se(o.phi_z, d.z);
    let (a_rz, a_rz_se) = mean_se(o.a_rz, d.r * d.z);
    let (rd_r, rd_r_se) = mean_se(o.rd_r, d.r);
    let (tt_r, tt_r_se) = mean_se(o.tt_r, d.r);
    let (rd_a, rd_a_se) = mean_se(o.rd_a, d.a);
    let (tt_a, tt_a_se) = mean_se(o.tt_a, d.a);
    let (rd_ra, rd_ra_se) = mean_se(o.rd_ra, d.r * d.a);
    let (tt_ra, tt_ra_se) = mean_se(o.tt_ra, d.r * d.a);
    let raw = GridRaw {
        a_z,
        a_z_se,
        phi_z,
        phi_z_se,
        a_rz,
        a_rz_se,
        rd_r,
        rd_r_se,
        tt_r,
        tt_r_se,
        rd_a,
        rd_a_se,
        tt_a,
        tt_a_se,
        rd_ra,
        rd_ra_se,
        tt_ra,
        tt_ra_se,
    };
    // Net flux at the edges z_i = i dz (eq. G5): F(z_i) = 1 - R - sum_{j < i} A_j,
    // per photon of each batch, so that its standard error is that of the
    // batches' values.
    let mut flux = (Vec::with_capacity(d.z), Vec::with_capacity(d.z));
    for i in 0..d.z {
        let (m, e) = s.derived(|b, n| n - b[r_index] - b[o.a_z..o.a_z + i].iter().sum::<f64>());
        flux.0.push(m);
        flux.1.push(e);
    }
    // Rd and Tt: the sums of their radial bins.
    let rd = s.derived(|b, _| b[o.rd_r..o.rd_r + d.r].iter().sum::<f64>());
    let tt = s.derived(|b, _| b[o.tt_r..o.tt_r + d.r].iter().sum::<f64>());
    normalise(grid, raw, [rd.0, rd.1, tt.0, tt.1], flux)
}

/// Divide the raw sums by the bins' sizes (eqs. G1–G8).
fn normalise(
    grid: McGrid,
    raw: GridRaw,
    totals: [f64; 4],
    flux: (Vec<f64>, Vec<f64>),
) -> GridResult {
    let d = grid.dims();
    let (dz, dr, da) = (grid.dz, grid.dr, grid.da());
    let per = |v: &[f64], f: &dyn Fn(usize) -> f64| -> Vec<f64> {
        v.iter().enumerate().map(|(k, x)| x / f(k)).collect()
    };
    let z = |_k: usize| dz;
    let rz = |k: usize| ring_area(k / d.z, dr) * dz;
    let r = |k: usize| ring_area(k, dr);
    let a = |k: usize| cone_ring_solid_angle(k, da);
    let ra = |k: usize| ra_norm(k / d.a, k % d.a, dr, da);
    GridResult {
        grid,
        rd: totals[0],
        rd_se: totals[1],
        tt: totals[2],
        tt_se: totals[3],
        a_z: per(&raw.a_z, &z),
        a_z_se: per(&raw.a_z_se, &z),
        phi_z: per(&raw.phi_z, &z),
        phi_z_se: per(&raw.phi_z_se, &z),
        flux_z: flux.0,
        flux_z_se: flux.1,
        a_rz: per(&raw.a_rz, &rz),
        a_rz_se: per(&raw.a_rz_se, &rz),
        rd_r: per(&raw.rd_r, &r),
        rd_r_se: per(&raw.rd_r_se, &r),
        tt_r: per(&raw.tt_r, &r),
        tt_r_se: per(&raw.tt_r_se, &r),
        rd_a: per(&raw.rd_a, &a),
        rd_a_se: per(&raw.rd_a_se, &a),
        tt_a: per(&raw.tt_a, &a),
        tt_a_se: per(&raw.tt_a_se, &a),
        rd_ra: per(&raw.rd_ra, &ra),
        rd_ra_se: per(&raw.rd_ra_se, &ra),
        tt_ra: per(&raw.tt_ra, &ra),
        tt_ra_se: per(&raw.tt_ra_se, &ra),
        raw,
    }
}

/// The grid as the tracer uses it: offsets and reciprocal bin widths.
#[derive(Debug, Clone, Copy)]
pub(crate) struct GridTally {
    o: GridOffsets,
    inv_dz: f64,
    inv_dr: f64,
    inv_da: f64,
    /// The last depth and radial bins' indices as numbers (the overflow bins).
    z_last: f64,
    r_last: f64,
}

impl GridTally {
    pub fn new(o: GridOffsets, g: &McGrid) -> GridTally {
        GridTally {
            o,
            inv_dz: 1.0 / g.dz,
            inv_dr: 1.0 / g.dr,
            inv_da: 1.0 / g.da(),
            z_last: (o.dims.z - 1) as f64,
            r_last: (o.dims.r - 1) as f64,
        }
    }

    /// Depth bin of `z` (overflow: the last).
    #[inline]
    fn iz(&self, z: f64) -> usize {
        // Clamped as a number first: the conversion of a number in
        // [0, z_last] (or NaN, to 0) to u32 is a single truncation.
        (z * self.inv_dz).min(self.z_last) as u32 as usize
    }

    /// Radial bin of `(x, y)`, `floor(sqrt(x^2 + y^2) / dr)` (overflow: the last).
    #[inline]
    fn ir(&self, x: f64, y: f64) -> usize {
        ((x * x + y * y).sqrt() * self.inv_dr).min(self.r_last) as u32 as usize
    }

    /// An interaction at `(x, y, z)`: `phi` (`w / sigma_t`) and the booked
    /// absorption `a` (eqs. G1, G3, G4). `A(z)` is not booked here: it is
    /// the sum of `A(r, z)` over the rings, formed once per batch by [`Self::fold`].
    #[inline]
    pub fn interaction(&self, sums: &mut [f64], x: f64, y: f64, z: f64, phi: f64, a: f64) {
        let (iz, ir) = (self.iz(z), self.ir(x, y));
        sums[self.o.phi_z + iz] += phi;
        sums[self.o.a_rz + ir * self.o.dims.z + iz] += a;
    }

    /// End of a batch: `A(z)`, bin by bin, as the sum over the rings of
    /// `A(r, z)` (eq. G3 from G4), added to what `sums` holds there.
    pub fn fold(&self, sums: &mut [f64]) {
        let nz = self.o.dims.z;
        for ir in 0..self.o.dims.r {
            let row = self.o.a_rz + ir * nz;
            for iz in 0..nz {
                sums[self.o.a_z + iz] += sums[row + iz];
            }
        }
    }

    /// Weight `w` leaving at `(x, y)` with exit cosine `mu = |u_z|` in the
    /// outside medium, through the top (`top`) or the bottom (eqs. G6–G8).
    #[inline]
    pub fn escape(&self, sums: &mut [f64], w: f64, x: f64, y: f64, mu: f64, top: bool) {
        let d = self.o.dims;
        let ir = self.ir(x, y);
        let ia = ((mu.clamp(0.0, 1.0).acos() * self.inv_da) as usize).min(d.a - 1);
        let (r, a, ra) = if top {
            (self.o.rd_r, self.o.rd_a, self.o.rd_ra)
        } else {
            (self.o.tt_r, self.o.tt_a, self.o.tt_ra)
        };
        sums[r + ir] += w;
        sums[a + ia] += w;
        sums[ra + ir * d.a + ia] += w;
    }
}
