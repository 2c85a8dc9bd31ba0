//! Rough dielectric faces and conductor floors as layers: the microfacet
//! BSDF of Walter et al. (2007) ([`km_core::microfacet`]) integrated over
//! azimuth (Fourier coefficients) and over the quadrature cells of each
//! medium into the four operators of [`LayerOperators`] per Fourier order
//! (docs/rough.md §3, eq. R10–R16).
//!
//! # Cells
//!
//! Snell's law keeps `s = n sin(theta)`; with `u = s^2`, `n^2 mu dmu = -du/2`
//! on either side, so the flux weight `W_i = 2 n^2 mu_i w_i` of a node is the
//! same in every medium it reaches (eq. Q2 of [`crate::quadrature`]). Node
//! `i` owns the cell `c_i` of `u` of width `W_i` (the cells tile `[0, n^2]`
//! in the order of `u`; segment boundaries, where total reflection starts,
//! are cell boundaries). For light arriving in cell `j` of side `X` and
//! leaving in cell `i` of side `Y` (`F^m` the azimuthal coefficients, eq. R6):
//!
//! ```text
//!   O_ij = 1 / (2 n_X^2 W_i)  integral_{c_i} integral_{c_j} F^m(u <- u') du du'        (R10)
//! ```
//!
//! the outgoing radiance averaged over the cell (flux-weighted) for a radiance
//! constant over the incoming cell. With `Q_ij = integral integral F / n_Y^2`,
//! reciprocity (`f_t / n_o^2` symmetric) makes `Q` symmetric across the whole
//! face (both sides, both directions), and energy is the column sum
//! `sum_i Q_ij = 2 W_j (1 - loss_j)`.
//!
//! # Integration
//!
//! The inner integral over the outgoing cells is done per incoming point on
//! panels graded towards the lobe's peak (`u = u'` on both sides) and split
//! at the cell edges and the total-reflection kinks
//! ([`km_core::microfacet::graded_edges`]), so every column's sum is the
//! directional albedo to about 1e-6 whatever the roughness; the outer
//! integral over the incoming cell takes [`CELL_POINTS`] Gauss points. The
//! two orders of integration of `Q` agree to the outer rule's accuracy, so
//! each block is integrated one way only, the other being its transpose:
//! the transmission from the side above (eq. R11'), each reflection block
//! from the cells further from the normal into those nearer it (eq. R11'').
//! `Q` is then scaled symmetrically, `D Q D`, until its column sums equal
//! the albedo sums of the columns' points (Sinkhorn–Knopp, as the phase
//! matrix, eq. R12; the part of a reflection column that the transpose
//! supplies is integrated at order 0 alone for that sum): reciprocity then
//! holds to rounding and energy to the albedo integral's accuracy.
//!
//! # The smooth limit
//!
//! As `alpha -> 0` the lobe becomes the mirror/refraction delta. The
//! operators are written as the smooth face's node operators (eq. F1 of
//! [`crate::interface`]) plus the cell integrals of the rough BSDF minus those
//! of the smooth one (eq. R13): the difference vanishes with `alpha`, so the
//! smooth operators are recovered exactly (no switch). Below
//! [`SPREAD_ALPHA`], in a request of totals alone, the collimated beam keeps
//! its delta slot the same way: the rough lobe of the beam minus the delta's
//! share of its cell goes to the nodes, the delta to the slot (eq. R14).
//! From [`SPREAD_ALPHA`] on the lobe spans cells enough that they carry it
//! better than a delta does, and a request with exit directions (probes)
//! needs the cells at any roughness ([`spreads`]): the whole lobe goes to the
//! cells, and a probe reads the cells only (eq. R14', R16'). The engine
//! takes the paths that meet rough faces once or twice exact at the exits
//! (eq. R18, R19: `double_path`). The solver reports no mirror or
//! unscattered part through a rough face ([`crate::stack::delta_parts`]).

use std::cell::RefCell;
use std::f64::consts::PI;
use std::hash::{Hash, Hasher};
use std::rc::Rc;

use faer::Mat;
use km_core::fresnel::reflectance;
use km_core::microfacet::{
    Far, FourierSum, Microfacet, conductor_reflectance, graded_edges, panel_rule_mu,
    panel_rule_mu_near,
};
use rayon::prelude::*;

use crate::adding::LayerOperators;
use crate::quadrature::MediumNodes;
use crate::slab::Extra;

/// The roughness from which a face spreads the beam over its cells
/// (eq. R14'): its lobe then spans enough cells that the cells carry it
/// better than a delta in the beam's slot does (docs/rough.md §3, §7);
/// below it the delta stays in the slot (eq. R14), exact as `alpha -> 0`.
pub const SPREAD_ALPHA: f64 = 0.1;

/// Whether a face spreads the beam over its cells (eq. R14') rather than
/// keeping its delta in the beam's slot (eq. R14): from [`SPREAD_ALPHA`] on,
/// and at any roughness when the request has exit directions (probes), whose
/// single rough path the engine takes exact (eq. R18) and which a delta in
/// the beam's slot would be read twice by (docs/rough.md §3, §7).
pub fn spreads(alpha: f64, ea: &[Extra], eb: &[Extra]) -> bool {
    alpha >= SPREAD_ALPHA || ea.iter().chain(eb).any(|e| !e.beam)
}

/// Gauss points per incoming cell (eq. R11): the outer rule whose
/// disagreement with the transposed integral the symmetric scaling absorbs.
pub const CELL_POINTS: usize = 2;

/// A rough face: its microfacet statistics and what lies below it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoughFace {
    /// The microfacet distribution and roughness.
    pub mf: Microfacet,
    /// Index above the face.
    pub n_above: f64,
    /// Below: a dielectric of index `n` or a conductor `n + i k`.
    pub below: Far,
}

/// The cells of one side of the face (eq. R10).
struct Side<'a> {
    n: f64,
    nodes: &'a MediumNodes,
    /// Cell of each node: `(lo, hi)` in `u`.
    cell: Vec<(f64, f64)>,
    /// Upper edges of the cells in ascending `u`, and the node of each.
    upper: Vec<f64>,
    node_at: Vec<usize>,
}

impl<'a> Side<'a> {
    fn new(nodes: &'a MediumNodes) -> Side<'a> {
        let n2 = nodes.n * nodes.n;
        let k = nodes.mu.len();
        let mut order: Vec<usize> = (0..k).collect();
        // Ascending u = n^2 (1 - mu^2), i.e. descending mu.
        order.sort_by(|&i, &j| nodes.mu[j].total_cmp(&nodes.mu[i]));
        let mut cell = vec![(0.0, 0.0); k];
        let (mut upper, mut lo) = (Vec::with_capacity(k), 0.0);
        for &i in &order {
            let hi = lo + 2.0 * n2 * nodes.mu[i] * nodes.w[i];
            cell[i] = (lo, hi);
            upper.push(hi);
            lo = hi;
        }
        // The last edge is n^2 up to rounding: make it exact.
        if let (Some(last), Some(&i)) = (upper.last_mut(), order.last()) {
            *last = n2;
            cell[i].1 = n2;
        }
        Side { n: nodes.n, nodes, cell, upper, node_at: order }
    }

    fn len(&self) -> usize {
        self.cell.len()
    }

    fn width(&self, i: usize) -> f64 {
        self.cell[i].1 - self.cell[i].0
    }

    /// The node whose cell holds `u` (`None` beyond the side's range).
    fn cell_of(&self, u: f64) -> Option<usize> {
        if !(0.0..=self.n * self.n).contains(&u) || self.upper.is_empty() {
            return None;
        }
        let p = self.upper.partition_point(|&x| x < u).min(self.upper.len() - 1);
        Some(self.node_at[p])
    }

    fn mu_of(&self, u: f64) -> f64 {
        (1.0 - u / (self.n * self.n)).max(0.0).sqrt()
    }
}

/// Everything [`column`] needs.
struct Ctx<'a> {
    face: RoughFace,
    sides: Vec<Side<'a>>,
    orders: usize,
    outer: Outer,
}

/// The outer rule of eq. R11: Gauss points per incoming cell, and whether
/// each block is integrated one way only (eq. R11', R11'') or both ways and
/// the two averaged by eq. R12 (the tests' reference, with more points).
#[derive(Debug, Clone, Copy)]
struct Outer {
    points: usize,
    one_way: bool,
}

/// The solver's outer rule: [`CELL_POINTS`] points, one way.
const OUTER: Outer = Outer { points: CELL_POINTS, one_way: true };

impl Ctx<'_> {
    /// Index of the side (0 above, 1 below) and the BSDF's far medium for
    /// light arriving from side `x`.
    fn far(&self, x: usize) -> Far {
        match (x, self.face.below) {
            (0, b) => b,
            (_, _) => Far::Dielectric(self.face.n_above),
        }
    }

    /// Smooth reflectance of side `x` at `u` (1 where the far side lacks `u`).
    fn r_smooth(&self, x: usize, u: f64) -> f64 {
        let mu = self.sides[x].mu_of(u);
        match self.far(x) {
            Far::Dielectric(n_t) => reflectance(mu, self.sides[x].n, n_t),
            Far::Conductor(n, k) => conductor_reflectance(mu, self.sides[x].n, n, k),
        }
    }
}

/// The cell integrals of one incoming point, per side (see [`column`]).
type Column = Vec<Vec<f64>>;

/// For light arriving at `u_in` from side `x`: `integral_{c_i} F^m(u <- u_in) du`
/// for every cell `i` of every side (`out[side][i * orders + m]`, eq. R11).
fn column(c: &Ctx<'_>, x: usize, u_in: f64) -> Column {
    (0..c.sides.len()).map(|y| side_column(c, x, u_in, y, None).0).collect()
}

/// [`column`]'s integrals on side `y` alone (`out[i * orders + m]`); with
/// `upto`, only those of the cells whose lower edge in `u` is at most
/// `upto` (the others stay zero: eq. R11''), and the integral of order 0
/// over the others (the rest of the directional albedo, eq. R12's target),
/// else 0.
fn side_column(c: &Ctx<'_>, x: usize, u_in: f64, y: usize, upto: Option<f64>) -> (Vec<f64>, f64) {
    let mo = c.orders;
    let (n_i, far) = (c.sides[x].n, c.far(x));
    let mu_in = c.sides[x].mu_of(u_in);
    let side = &c.sides[y];
    let mut out = vec![0.0; side.len() * mo];
    let transmit = y != x;
    let top = side.n * side.n;
    // Panels: cell edges, kinks, graded towards the peak u = u_in; the
    // panels far from the peak, the kinks and the normal (u = 0, where the
    // odd orders go as sqrt(u)) with fewer points.
    let mut singular = c.face.mf.kink_cuts(mu_in, n_i, far, transmit);
    let mut cuts = side.upper.clone();
    cuts.extend(&singular);
    singular.extend([u_in, 0.0]);
    let width = c.face.mf.lobe_width_u(top, mu_in.min(side.mu_of(u_in)))
        / km_core::microfacet::sharpness(n_i, far, transmit);
    let edges = graded_edges(0.0, top, u_in, width, &cuts);
    let (pts, wts) = panel_rule_mu_near(&edges, top, &singular);
    // Per cell, the points' samples summed before the moments (eq. R6a);
    // beyond `upto`, order 0 alone (on the same panels: without the cell
    // edges among the cuts, the grading alone left it 1.5e-4 of the
    // column off).
    let mut sums: Vec<Option<FourierSum>> = (0..side.len()).map(|_| None).collect();
    let upto = upto.unwrap_or(f64::INFINITY);
    let mut rest = FourierSum::new(1);
    for (&u, &wt) in pts.iter().zip(&wts) {
        let Some(i) = side.cell_of(u) else { continue };
        let sum = if side.cell[i].0 > upto {
            &mut rest
        } else {
            sums[i].get_or_insert_with(|| FourierSum::new(mo))
        };
        c.face.mf.fourier_add((side.mu_of(u), mu_in), n_i, far, transmit, wt, sum);
    }
    for (i, sum) in sums.iter_mut().enumerate() {
        if let Some(sum) = sum {
            sum.finish_into(&mut out[i * mo..(i + 1) * mo]);
        }
    }
    let mut r = [0.0];
    rest.finish_into(&mut r);
    (out, r[0])
}

/// `integral_{c_i} f du` by the incoming points' rule (`points` Gauss
/// points, [`CELL_POINTS`] in the solver): the same rule as the rough
/// integrals of eq. R11, so that their difference in eq. R13 vanishes
/// exactly as `alpha -> 0`.
fn cell_integral(cell: (f64, f64), points: usize, f: impl Fn(f64) -> f64) -> f64 {
    cell_points(cell, points).map(|(u, v)| v * f(u)).sum()
}

/// The `points` incoming points of a cell and their weights (sum: the
/// cell's width).
fn cell_points(cell: (f64, f64), points: usize) -> impl Iterator<Item = (f64, f64)> {
    let (gx, gw) = km_core::quadrature::gauss_legendre(points);
    let (lo, hi) = cell;
    (0..points).map(move |k| (lo + 0.5 * (gx[k] + 1.0) * (hi - lo), 0.5 * gw[k] * (hi - lo)))
}

/// The operators of a rough face for Fourier orders `0..orders` (eq.
/// R10–R16), on the augmented spaces `[nodes, extras]` of each side; `b` is
/// `None` for a conductor floor (reflection only: `t_down` and `t_up` have
/// no rows/columns below, as a Lambertian floor). Also returns the
/// single-scattering loss of each node's cell above (`1 - R - T`, flux
/// averaged over the cell).
pub fn rough_operators(
    face: RoughFace,
    a: &MediumNodes,
    b: Option<&MediumNodes>,
    ea: &[Extra],
    eb: &[Extra],
    orders: usize,
) -> (Vec<LayerOperators>, Vec<f64>) {
    rough_operators_with(face, (a, b), (ea, eb), orders, OUTER)
}

/// [`rough_operators`] by the outer rule `outer`.
fn rough_operators_with(
    face: RoughFace,
    (a, b): (&MediumNodes, Option<&MediumNodes>),
    (ea, eb): (&[Extra], &[Extra]),
    orders: usize,
    outer: Outer,
) -> (Vec<LayerOperators>, Vec<f64>) {
    let mut sides = vec![Side::new(a)];
    sides.extend(b.map(Side::new));
    let c = Ctx { face, sides, orders: orders.max(1), outer };
    let blocks = node_blocks(&c);
    let (mut ops, loss) = node_operators(&c, &blocks);
    extras(&c, ea, eb, &mut ops);
    (ops, loss)
}

/// The blocks `Q[y][x]` (rows: cells of side `y`, columns: cells of side
/// `x`, per order) integrated as in eq. R11, before symmetrisation. One way
/// (the solver's [`OUTER`]): the transmission is integrated from the points
/// of the side above only, the other way being its transpose (eq. R11'),
/// and each reflection block from the points of the cells further from the
/// normal (larger `u`) into those nearer it, the other triangle being the
/// transpose (eq. R11''); as the symmetrisation of eq. R12 would make
/// them. Both ways: every column whole. The incoming points' columns are
/// independent and computed in parallel (rayon), then summed in a fixed
/// order: the result does not depend on the number of threads.
fn node_blocks(c: &Ctx<'_>) -> Blocks {
    let ns = c.sides.len();
    let mo = c.orders;
    let mut q: Vec<Vec<Vec<f64>>> = (0..ns)
        .map(|y| (0..ns).map(|x| vec![0.0; c.sides[y].len() * c.sides[x].len() * mo]).collect())
        .collect();
    let points: Vec<(usize, usize, f64, f64)> = (0..ns)
        .flat_map(|x| {
            (0..c.sides[x].len()).flat_map(move |j| {
                cell_points(c.sides[x].cell[j], c.outer.points).map(move |(u, vq)| (x, j, u, vq))
            })
        })
        .collect();
    // The transmission from the points above (from below, on the 1.5 / 1.4
    // face of docs/rough.md §7's three-layer table, its energy check read
    // 4.4e-4 instead of 1.5e-4); the points below integrate their
    // reflection alone.
    let columns: Vec<(Column, f64)> = points
        .par_iter()
        .map(|&(x, j, u, _)| {
            let mut rest = 0.0;
            let col = (0..ns)
                .map(|y| match (c.outer.one_way, y == x, x) {
                    (true, true, _) => {
                        let (g, r) = side_column(c, x, u, y, Some(c.sides[x].cell[j].0));
                        rest = r;
                        g
                    }
                    (true, false, 0) | (false, _, _) => side_column(c, x, u, y, None).0,
                    (true, false, _) => Vec::new(),
                })
                .collect();
            (col, rest)
        })
        .collect();
    // Eq. R12's target: each column's own integrals of order 0, the rest of
    // its reflection (beyond `upto`) and its transmission (below: eq. R11').
    let mut target: Vec<Vec<f64>> = c.sides.iter().map(|s| vec![0.0; s.len()]).collect();
    for (&(x, j, _, vq), (col, rest)) in points.iter().zip(&columns) {
        let nx = c.sides[x].len();
        target[x][j] += vq * rest / (c.sides[x].n * c.sides[x].n);
        for y in (0..ns).filter(|&y| !col[y].is_empty()) {
            let inv = 1.0 / (c.sides[y].n * c.sides[y].n);
            for i in 0..c.sides[y].len() {
                let dst = &mut q[y][x][(i * nx + j) * mo..(i * nx + j + 1) * mo];
                for (d, g) in dst.iter_mut().zip(&col[y][i * mo..(i + 1) * mo]) {
                    *d += vq * g * inv;
                }
                target[x][j] += vq * col[y][i * mo] * inv;
            }
        }
    }
    if !c.outer.one_way {
        return Blocks { q, target };
    }
    // The reflection blocks: Q[x][x](i, j) for a cell i beyond cell j in u
    // is Q[x][x](j, i) (eq. R11'': R11's exact integrals are symmetric).
    for (x, qx) in q.iter_mut().enumerate() {
        let side = &c.sides[x];
        let n = side.len();
        let block = &mut qx[x];
        for i in 0..n {
            for j in 0..n {
                if side.cell[i].0 > side.cell[j].0 {
                    let (to, from) = ((i * n + j) * mo, (j * n + i) * mo);
                    block.copy_within(from..from + mo, to);
                }
            }
        }
    }
    if let [above, below] = &mut q[..] {
        // Q[0][1](i, j) = Q[1][0](j, i) (eq. R11': R11's 1/n_Y^2 makes the
        // exact integrals symmetric).
        let (n0, n1) = (c.sides[0].len(), c.sides[1].len());
        for i in 0..n0 {
            for j in 0..n1 {
                let (from, to) = ((j * n0 + i) * mo, (i * n1 + j) * mo);
                above[1][to..to + mo].copy_from_slice(&below[0][from..from + mo]);
            }
        }
    }
    // The columns from below: their transmission is the transpose's.
    if let [above, _] = &q[..] {
        let (n0, n1) = (c.sides[0].len(), c.sides.get(1).map_or(0, |s| s.len()));
        for j in 0..n1 {
            target[1][j] += (0..n0).map(|i| above[1][(i * n1 + j) * mo]).sum::<f64>();
        }
    }
    Blocks { q, target }
}

/// The blocks `Q[y][x]` of eq. R11 (`q[y][x][(i * n_x + j) * orders + m]`)
/// and the albedo sums of their columns (`target[x][j]`, eq. R12).
struct Blocks {
    q: Vec<Vec<Vec<f64>>>,
    target: Vec<Vec<f64>>,
}

/// Symmetrise the blocks, scale them to the columns' albedos (eq. R12), and
/// form the node operators with the smooth face's correction (eq. R13).
fn node_operators(c: &Ctx<'_>, b: &Blocks) -> (Vec<LayerOperators>, Vec<f64>) {
    let q = &b.q;
    let ns = c.sides.len();
    let mo = c.orders;
    let len: Vec<usize> = c.sides.iter().map(|s| s.len()).collect();
    let off: Vec<usize> = (0..ns).map(|s| len[..s].iter().sum()).collect();
    let total: usize = len.iter().sum();
    // The whole face's matrix, order by order: S[m][(I, J)] over all cells.
    let at = |m: usize, y: usize, i: usize, x: usize, j: usize| q[y][x][(i * len[x] + j) * mo + m];
    let mut s = vec![vec![0.0; total * total]; mo];
    let target: Vec<f64> = b.target.iter().flatten().copied().collect();
    // Row by row: each order's matrix written in order.
    for y in 0..ns {
        for i in 0..len[y] {
            for x in 0..ns {
                for j in 0..len[x] {
                    for (m, sm) in s.iter_mut().enumerate() {
                        let v = 0.5 * (at(m, y, i, x, j) + at(m, x, j, y, i));
                        sm[(off[y] + i) * total + off[x] + j] = v;
                    }
                }
            }
        }
    }
    let d = symmetric_scaling(&s[0], &target, total);
    let mut loss = Vec::with_capacity(len[0]);
    for j in 0..len[0] {
        loss.push(1.0 - target[j] / (2.0 * c.sides[0].width(j)));
    }
    let mut ops = Vec::with_capacity(mo);
    for sm in &s {
        let block = |y: usize, x: usize| {
            let mut o = Mat::<f64>::zeros(len[y], len[x]);
            let (ny2, nx2) = (c.sides[y].n.powi(2), c.sides[x].n.powi(2));
            for i in 0..len[y] {
                let w = c.sides[y].width(i);
                for j in 0..len[x] {
                    let (gi, gj) = (off[y] + i, off[x] + j);
                    // O = n_Y^2 Q / (2 n_X^2 W_i) (eq. R10) on the scaled Q.
                    o[(i, j)] = ny2 * d[gi] * sm[gi * total + gj] * d[gj] / (2.0 * nx2 * w);
                }
            }
            o
        };
        let r_top = block(0, 0);
        let (t_down, r_bottom, t_up) = if ns == 2 {
            (block(1, 0), block(1, 1), block(0, 1))
        } else {
            (Mat::zeros(0, len[0]), Mat::zeros(0, 0), Mat::zeros(len[0], 0))
        };
        let mut o = LayerOperators { r_top, t_down, r_bottom, t_up };
        smooth_correction(c, &mut o);
        ops.push(o);
    }
    (ops, loss)
}

/// `D` with `D S D` of column sums `target` (S symmetric, non-negative):
/// the symmetric Sinkhorn–Knopp iteration `D_j <- D_j sqrt(t_j / (D S D)_j)`
/// (Knight 2008), to 1e-14 relative or 500 sweeps. `S` is symmetric bit
/// for bit (an average of the two ways, [`node_operators`]), so column `j`
/// is read as row `j`: the same products in the same order, contiguous.
fn symmetric_scaling(s: &[f64], target: &[f64], n: usize) -> Vec<f64> {
    debug_assert!(
        (0..n).all(|i| (0..i).all(|j| s[i * n + j].to_bits() == s[j * n + i].to_bits())),
        "the scaled matrix is symmetric bit for bit"
    );
    let mut d = vec![1.0; n];
    for _ in 0..500 {
        let mut worst = 0.0f64;
        for j in 0..n {
            let row = &s[j * n..(j + 1) * n];
            let col: f64 = d.iter().zip(row).map(|(di, sji)| di * sji).sum::<f64>() * d[j];
            if col > 0.0 && target[j] > 0.0 {
                let r = target[j] / col;
                worst = worst.max((r - 1.0).abs());
                d[j] *= r.sqrt();
            }
        }
        if worst < 1e-14 {
            break;
        }
    }
    d
}

/// Eq. R13 on the node diagonals: the smooth face's node value minus its
/// cell average (the delta's share of the rough integral as `alpha -> 0`).
fn smooth_correction(c: &Ctx<'_>, o: &mut LayerOperators) {
    let a = &c.sides[0];
    for i in 0..a.len() {
        let avg = cell_integral(a.cell[i], c.outer.points, |u| c.r_smooth(0, u)) / a.width(i);
        o.r_top[(i, i)] += c.r_smooth(0, a.nodes.mu_u(i)) - avg;
    }
    let Some(b) = c.sides.get(1) else { return };
    for k in 0..b.len() {
        let avg = cell_integral(b.cell[k], c.outer.points, |u| c.r_smooth(1, u)) / b.width(k);
        o.r_bottom[(k, k)] += c.r_smooth(1, b.nodes.mu_u(k)) - avg;
    }
    let (na2, nb2) = (a.n * a.n, b.n * b.n);
    for g in 0..a.len().min(b.len()) {
        // Stokes: the transmittance is the same from both sides at one u.
        let t = |u: f64| 1.0 - c.r_smooth(0, u);
        let avg = cell_integral(a.cell[g], c.outer.points, t) / a.width(g);
        let dt = t(a.nodes.mu_u(g)) - avg;
        o.t_down[(g, g)] += nb2 / na2 * dt;
        o.t_up[(g, g)] += na2 / nb2 * dt;
    }
}

/// `u = n^2 (1 - mu^2)` of a node.
trait NodeU {
    fn mu_u(&self, i: usize) -> f64;
}

impl NodeU for MediumNodes {
    fn mu_u(&self, i: usize) -> f64 {
        self.n * self.n * (1.0 - self.mu[i] * self.mu[i])
    }
}

/// The beam and probe rows and columns (eq. R14–R16), on operators grown to
/// `[nodes, extras]`.
fn extras(c: &Ctx<'_>, ea: &[Extra], eb: &[Extra], ops: &mut [LayerOperators]) {
    let ne = ea.len();
    let len: Vec<usize> = c.sides.iter().map(|s| s.len()).collect();
    let dims: Vec<usize> = len.iter().map(|l| l + ne).collect();
    for o in ops.iter_mut() {
        *o = grow(o, &dims, ne);
    }
    let ex: [&[Extra]; 2] = [ea, eb];
    // Per side, the u of each extra present there.
    let u_of = |x: usize, e: usize| -> Option<f64> {
        let mu = ex[x].get(e)?.mu?;
        (x < c.sides.len()).then(|| c.sides[x].n.powi(2) * (1.0 - mu * mu))
    };
    let spread = spreads(c.face.mf.alpha(), ea, eb);
    // The distinct columns the extras need (`slot[x][e]`: which), computed
    // in parallel.
    let mut wanted: Vec<(usize, f64)> = Vec::new();
    let mut slot = vec![vec![None; ne]; c.sides.len()];
    for e in 0..ne {
        for (x, row) in slot.iter_mut().enumerate() {
            let Some(u) = u_of(x, e) else { continue };
            let k = wanted.iter().position(|&(y, v)| y == x && v.to_bits() == u.to_bits());
            row[e] = Some(k.unwrap_or_else(|| {
                wanted.push((x, u));
                wanted.len() - 1
            }));
        }
    }
    let columns: Vec<Column> = wanted.par_iter().map(|&(x, u)| column(c, x, u)).collect();
    for e in 0..ne {
        for x in 0..c.sides.len() {
            let Some(k) = slot[x][e] else { continue };
            let (g, u) = (&columns[k], wanted[k].1);
            if ex[x][e].beam {
                beam_column(c, ops, (x, e, u), g, &u_of, &len, ex, spread);
            } else {
                probe_rows(c, ops, (x, e), g, &len);
            }
        }
    }
}

/// The operator from side `x` to side `y`, mutable.
fn op_mut(o: &mut LayerOperators, y: usize, x: usize) -> &mut Mat<f64> {
    match (y, x) {
        (0, 0) => &mut o.r_top,
        (1, 0) => &mut o.t_down,
        (1, 1) => &mut o.r_bottom,
        _ => &mut o.t_up,
    }
}

/// The beam arriving from side `x` at `u` (irradiance slot `len[x] + e`):
/// its lobe into the nodes (minus the delta's cell share) and the probes, the
/// delta into the beam slots (eq. R14).
#[allow(clippy::too_many_arguments)]
fn beam_column(
    c: &Ctx<'_>,
    ops: &mut [LayerOperators],
    (x, e, u): (usize, usize, f64),
    g: &[Vec<f64>],
    u_of: &dyn Fn(usize, usize) -> Option<f64>,
    len: &[usize],
    ex: [&[Extra]; 2],
    spread: bool,
) {
    let mo = c.orders;
    let r = c.r_smooth(x, u);
    let mu_in = c.sides[x].mu_of(u);
    let mut buf = vec![0.0; mo];
    for (m, o) in ops.iter_mut().enumerate() {
        let k = if m == 0 { 1.0 } else { 2.0 } / (2.0 * PI);
        for (y, side) in c.sides.iter().enumerate() {
            let mat = op_mut(o, y, x);
            let col = len[x] + e;
            for i in 0..side.len() {
                mat[(i, col)] = k * g[y][i * mo + m] / side.width(i);
            }
            if spread {
                continue;
            }
            // The delta's share of its cell, and the delta in the beam slot.
            let delta = if y == x { r } else { 1.0 - r };
            if let (Some(i), Some(_)) = (side.cell_of(u), u_of(y, e)) {
                mat[(i, col)] -= k * 2.0 * side.n * side.n * delta / side.width(i);
                mat[(len[y] + e, col)] = delta;
            } else if let Some(i) = side.cell_of(u) {
                mat[(i, col)] -= k * 2.0 * side.n * side.n * delta / side.width(i);
            }
        }
    }
    // Probes: the point values of the lobe.
    for (y, side) in c.sides.iter().enumerate() {
        for (p, xp) in ex[y].iter().enumerate() {
            let (false, Some(up)) = (xp.beam, u_of(y, p)) else { continue };
            let far = c.far(x);
            c.face.mf.fourier(side.mu_of(up), mu_in, c.sides[x].n, far, y != x, &mut buf);
            for (m, o) in ops.iter_mut().enumerate() {
                let k = if m == 0 { 1.0 } else { 2.0 } / (2.0 * PI);
                op_mut(o, y, x)[(len[y] + p, len[x] + e)] = k * buf[m];
            }
        }
    }
}

/// The probe `e` on side `y`: its rows from the nodes of every side (by
/// reciprocity, from the column of light leaving along the probe; eq.
/// R16'). A request with probes spreads the beam ([`spreads`]), so a probe
/// reads the cells only.
fn probe_rows(
    c: &Ctx<'_>,
    ops: &mut [LayerOperators],
    (y, e): (usize, usize),
    g: &[Vec<f64>],
    len: &[usize],
) {
    let mo = c.orders;
    let ny2 = c.sides[y].n.powi(2);
    for (m, o) in ops.iter_mut().enumerate() {
        for (x, side) in c.sides.iter().enumerate() {
            let nx2 = side.n * side.n;
            let mat = op_mut(o, y, x);
            let row = len[y] + e;
            // O_xj = (n_Y^2 / n_X^2) C_j / (2 n_X^2) (reciprocity of eq. R10).
            for j in 0..side.len() {
                mat[(row, j)] = ny2 / nx2 * g[x][j * mo + m] / (2.0 * nx2);
            }
        }
    }
}

/// `o` grown to `[nodes, extras]` on each side (the node blocks kept).
fn grow(o: &LayerOperators, dims: &[usize], ne: usize) -> LayerOperators {
    let put = |src: &Mat<f64>, rows: usize, cols: usize| {
        let mut m = Mat::<f64>::zeros(rows, cols);
        for i in 0..src.nrows() {
            for j in 0..src.ncols() {
                m[(i, j)] = src[(i, j)];
            }
        }
        m
    };
    let da = dims[0];
    if dims.len() == 2 {
        let db = dims[1];
        LayerOperators {
            r_top: put(&o.r_top, da, da),
            t_down: put(&o.t_down, db, da),
            r_bottom: put(&o.r_bottom, db, db),
            t_up: put(&o.t_up, da, db),
        }
    } else {
        let _ = ne;
        LayerOperators {
            r_top: put(&o.r_top, da, da),
            t_down: Mat::zeros(0, da),
            r_bottom: Mat::zeros(0, 0),
            t_up: Mat::zeros(da, 0),
        }
    }
}

/// Key of a face's operators in the per-thread cache.
fn key(
    face: &RoughFace,
    a: &MediumNodes,
    b: Option<&MediumNodes>,
    ea: &[Extra],
    eb: &[Extra],
    orders: usize,
) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    let mut f = |x: f64| x.to_bits().hash(&mut h);
    f(face.mf.alpha());
    f(face.n_above);
    match face.below {
        Far::Dielectric(n) => f(n),
        Far::Conductor(n, k) => {
            f(-n);
            f(k);
        }
    }
    for nodes in std::iter::once(a).chain(b) {
        nodes.mu.iter().chain(&nodes.w).for_each(|&x| f(x));
        f(f64::NAN);
    }
    for e in ea.iter().chain(eb) {
        f(e.mu.unwrap_or(-1.0));
        f(if e.beam { 1.0 } else { 0.0 });
    }
    (face.mf.distribution() as u8, orders).hash(&mut h);
    h.finish()
}

/// Faces whose operators a thread keeps (the oldest goes).
const FACES_KEPT: usize = 4;

thread_local! {
    static CACHE: RefCell<Vec<(u64, Rc<Vec<LayerOperators>>)>> = const { RefCell::new(Vec::new()) };
}

/// The operators of `face` for order `m` (of `orders` computed at once and
/// kept per thread: a solve asks for the orders one at a time).
pub fn rough_operators_order(
    face: RoughFace,
    a: &MediumNodes,
    b: Option<&MediumNodes>,
    ea: &[Extra],
    eb: &[Extra],
    m: usize,
    orders: usize,
) -> LayerOperators {
    let orders = orders.max(m + 1);
    let k = key(&face, a, b, ea, eb, orders);
    let hit = CACHE.with(|c| c.borrow().iter().find(|(x, _)| *x == k).map(|(_, v)| Rc::clone(v)));
    let all = hit.unwrap_or_else(|| {
        let v = Rc::new(rough_operators(face, a, b, ea, eb, orders).0);
        CACHE.with(|c| {
            let mut c = c.borrow_mut();
            if c.len() >= FACES_KEPT {
                c.remove(0);
            }
            c.push((k, Rc::clone(&v)));
        });
        v
    });
    all[m].clone()
}

/// A smooth conductor floor: the mirror reflection `R_c(mu)` of eq. R5 on
/// the diagonal, for nodes, probes and the beam alike (every order).
pub fn smooth_conductor(a: &MediumNodes, ea: &[Extra], n: f64, k: f64) -> Mat<f64> {
    let na = a.mu.len();
    let mut r = Mat::<f64>::zeros(na + ea.len(), na + ea.len());
    for (i, &mu) in a.mu.iter().enumerate() {
        r[(i, i)] = conductor_reflectance(mu, a.n, n, k);
    }
    for (e, x) in ea.iter().enumerate() {
        if let Some(mu) = x.mu {
            r[(na + e, na + e)] = conductor_reflectance(mu, a.n, n, k);
        }
    }
    r
}

/// The double transmitted path of eq. R19 (docs/rough.md §3) per Fourier
/// order, without the factor `(2 - delta_m0) / (2 pi)`: the beam through a
/// first rough face, the layers between unscattered, and through a second
/// rough face to an exit below it.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct DoublePath {
    /// As the operators hold it (the orders built): the beam's column of the
    /// first face into the cells between, their unscattered transmission,
    /// and the probe's row of the second face (eq. R14', R16').
    pub held: Vec<f64>,
    /// The same integral over the cells' variable `u` by a fine rule.
    pub exact: Vec<f64>,
}

/// Where the double path of eq. R19 leaves: through a second rough face
/// into the medium below it (`Below`); or, after the delta path below has
/// reflected it, back up through the first face (`Back`) or reflected down
/// again by the first face from below (`Inside`, to an exit under the
/// stack).
#[derive(Clone, Copy)]
pub(crate) enum Exit<'a> {
    Below(RoughFace, &'a MediumNodes),
    Back,
    Inside,
}

/// The faces of eq. R19 and the media around them: the first face with the
/// nodes above it, the nodes of the medium below it, the delta path's factor
/// between the two meetings (of `mu` in that medium: the layers' unscattered
/// transmission, or the reflection of what lies below), and the exit.
pub(crate) struct TwoFaces<'a> {
    pub first: (RoughFace, &'a MediumNodes),
    pub mid: &'a MediumNodes,
    pub between: &'a dyn Fn(f64) -> f64,
    pub exit: Exit<'a>,
}

/// Eq. R19's coefficients for the beam at `u_b` (above the first face) and
/// the exit at `u_o`, `built` orders as the operators hold them,
/// `exact_orders` by the fine rule.
pub(crate) fn double_path(
    faces: &TwoFaces<'_>,
    (u_b, u_o): (f64, f64),
    built: usize,
    exact_orders: usize,
) -> DoublePath {
    let ((f1, a), mid, between) = (faces.first, faces.mid, faces.between);
    let nm = mid.n;
    let top = nm * nm;
    let far = Far::Dielectric(nm);
    // As held: the cells' integrals of both meetings (the operators' own
    // rule): the beam's column into the cells below the first face, and
    // the exit's column (its probe's row by reciprocity, eq. R16') there.
    let sides = vec![Side::new(a), Side::new(mid)];
    let c1 = Ctx { face: f1, sides, orders: built.max(1), outer: OUTER };
    let g1 = side_column(&c1, 0, u_b, 1, None).0;
    // The second meeting: its face's context, the exit's side `y` and the
    // side of the medium between (`x`).
    let second;
    let (c2, y, x) = match faces.exit {
        Exit::Below(f2, b) => {
            second = Ctx {
                face: f2,
                sides: vec![Side::new(mid), Side::new(b)],
                orders: c1.orders,
                outer: OUTER,
            };
            (&second, 1, 0)
        }
        Exit::Back => (&c1, 0, 1),
        Exit::Inside => (&c1, 1, 1),
    };
    let g2 = side_column(c2, y, u_o, x, None).0;
    let (mf2, n_o, far2, transmit2) = (c2.face.mf, c2.sides[y].n, c2.far(y), x != y);
    // The probe's row of eq. R16' without its cell integral.
    let row = (n_o * n_o) / (nm * nm) / (2.0 * nm * nm);
    let mo = c1.orders;
    let mut held = vec![0.0; mo];
    for j in 0..c1.sides[1].len() {
        let t = between(mid.mu[j]) / c1.sides[1].width(j) * row;
        for (m, h) in held.iter_mut().enumerate() {
            *h += g1[j * mo + m] * t * g2[j * mo + m];
        }
    }
    // Exact: the same integrand on panels graded towards both peaks (the
    // beam's u_b and the exit's u_o: u = s^2 is Snell's invariant squared)
    // and split at both meetings' kinks.
    let (mu_b, mu_o) = (mid_mu(a.n * a.n, u_b), mid_mu(n_o * n_o, u_o));
    let w1 = f1.mf.lobe_width_u(top, mu_b.min(mid_mu(top, u_b)))
        / km_core::microfacet::sharpness(a.n, far, true);
    let w2 = mf2.lobe_width_u(top, mu_o.min(mid_mu(top, u_o)))
        / km_core::microfacet::sharpness(n_o, far2, transmit2);
    let mut cuts = f1.mf.kink_cuts(mu_b, a.n, far, true);
    cuts.extend(mf2.kink_cuts(mu_o, n_o, far2, transmit2));
    cuts.extend(graded_edges(0.0, top, u_o, w2, &[]));
    let edges = graded_edges(0.0, top, u_b, w1, &cuts);
    let (pts, wts) = panel_rule_mu(&edges, top);
    let mut exact = vec![0.0; exact_orders.max(1)];
    let (mut b1, mut b2) = (exact.clone(), exact.clone());
    for (&u, &wt) in pts.iter().zip(&wts) {
        let mu = mid_mu(top, u);
        let t = wt * between(mu) * row;
        if t == 0.0 {
            continue;
        }
        // The orders this point contributes to: the product of the two
        // coefficients falls at least as fast as the narrower lobe's, about
        // as exp(-m width) (eq. R6b), below 1e-8 from m width = 20; a power
        // of two (the azimuthal rules are cached per order count).
        let width = f1.mf.psi_width((mu, mu_b), a.n, far, true).max(mf2.psi_width(
            (mu, mu_o),
            n_o,
            far2,
            transmit2,
        ));
        let m = ((20.0 / width).ceil() as usize).next_power_of_two().min(exact.len());
        f1.mf.fourier(mu, mu_b, a.n, far, true, &mut b1[..m]);
        mf2.fourier(mu, mu_o, n_o, far2, transmit2, &mut b2[..m]);
        for ((e, x), y) in exact.iter_mut().zip(&b1[..m]).zip(&b2[..m]) {
            *e += t * x * y;
        }
    }
    DoublePath { held, exact }
}

/// `mu` of `u` on a side with `top = n^2`.
fn mid_mu(top: f64, u: f64) -> f64 {
    (1.0 - u / top).max(0.0).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quadrature::AngularGrid;
    use km_core::microfacet::Distribution;

    /// A GGX face of roughness `alpha` under index `na`, and the nodes of
    /// `streams` streams above and below it.
    fn face(
        alpha: f64,
        na: f64,
        below: Far,
        streams: usize,
    ) -> (RoughFace, MediumNodes, MediumNodes) {
        let nb = if let Far::Dielectric(n) = below { n } else { na };
        let grid = AngularGrid::new(&[na, nb], streams);
        let mf = Microfacet::new(alpha, Distribution::Ggx).unwrap();
        (RoughFace { mf, n_above: na, below }, grid.medium(na), grid.medium(nb))
    }

    /// The face's context of 8 orders (the side below only for a
    /// dielectric) with the outer rule `outer`.
    fn context<'a>(
        face: RoughFace,
        (a, b): (&'a MediumNodes, &'a MediumNodes),
        outer: Outer,
    ) -> Ctx<'a> {
        let mut sides = vec![Side::new(a)];
        if let Far::Dielectric(_) = face.below {
            sides.push(Side::new(b));
        }
        Ctx { face, sides, orders: 8, outer }
    }

    /// The L1 distance of two faces' blocks, symmetrised as eq. R12 does
    /// (`(Q + Q^T) / 2` over all cells, before the scaling), relative to the
    /// reference's L1 norm; the largest over the orders.
    fn distance(c: &Ctx<'_>, q: &[Vec<Vec<f64>>], r: &[Vec<Vec<f64>>]) -> f64 {
        let len: Vec<usize> = c.sides.iter().map(|s| s.len()).collect();
        let mo = c.orders;
        let sym = |q: &[Vec<Vec<f64>>], m, (y, i): (usize, usize), (x, j): (usize, usize)| {
            let at = |y: usize, i: usize, x: usize, j: usize| q[y][x][(i * len[x] + j) * mo + m];
            0.5 * (at(y, i, x, j) + at(x, j, y, i))
        };
        let cells: Vec<(usize, usize)> =
            (0..len.len()).flat_map(|s| (0..len[s]).map(move |i| (s, i))).collect();
        let mut worst = 0.0f64;
        for m in 0..mo {
            let (mut d, mut t) = (0.0, 0.0);
            for &a in &cells {
                for &b in &cells {
                    let v = sym(r, m, a, b);
                    d += (sym(q, m, a, b) - v).abs();
                    t += v.abs();
                }
            }
            worst = worst.max(d / t);
        }
        worst
    }

    /// The blocks integrated one way (eq. R11', R11''), against a reference
    /// of 8 incoming points per cell both ways: about as accurate as the
    /// mean of both ways with the solver's 2 points (each way carries the
    /// 2-point rule's error; their mean at best halves it), and more
    /// accurate on a conductor floor, where the cells nearest the normal
    /// no longer serve as incoming cells (the odd orders go as `sqrt(u)`
    /// there). A triangle left unfilled, or filled from the wrong side,
    /// makes the distance of order 1.
    #[test]
    fn one_way_blocks_keep_the_outer_rules_accuracy() {
        let gold = Far::Conductor(0.47, 2.4);
        for (alpha, na, below) in [
            (0.3, 1.0, Far::Dielectric(1.5)),
            (0.05, 1.0, Far::Dielectric(1.5)),
            (0.2, 1.33, Far::Dielectric(1.0)),
            (0.5, 1.0, Far::Dielectric(1.7)),
            (0.2, 1.5, gold),
        ] {
            for streams in [6, 12] {
                let (face, a, b) = face(alpha, na, below, streams);
                let ctx = |outer| context(face, (&a, &b), outer);
                let reference = node_blocks(&ctx(Outer { points: 8, one_way: false })).q;
                let c = ctx(OUTER);
                let one = distance(&c, &node_blocks(&c).q, &reference);
                let both = distance(
                    &c,
                    &node_blocks(&ctx(Outer { one_way: false, ..OUTER })).q,
                    &reference,
                );
                // Measured one / both: 0.50-1.81 (0.50, 0.76 on the conductor).
                assert!(
                    one <= 2.0 * both,
                    "alpha {alpha}, {na} over {below:?}, {streams} streams: one way {one:.2e}, both ways {both:.2e}"
                );
                if let Far::Conductor(..) = below {
                    assert!(
                        one < both,
                        "conductor, {streams} streams: {one:.2e} against {both:.2e}"
                    );
                }
            }
        }
    }

    /// Eq. R12's target of a column from above one way (its reflection up
    /// to its own cell with every order, beyond it order 0 alone, on the
    /// same panels) against both ways (the whole column with every order):
    /// the same directional albedo of its points, to the difference of the
    /// azimuthal rules of one order and of many.
    #[test]
    fn one_way_targets_are_the_albedos_of_the_columns_above() {
        for (alpha, na, below) in [
            (0.3, 1.0, Far::Dielectric(1.5)),
            (0.05, 1.0, Far::Dielectric(1.5)),
            (0.2, 1.33, Far::Dielectric(1.0)),
            (0.2, 1.5, Far::Conductor(0.47, 2.4)),
        ] {
            let (face, a, b) = face(alpha, na, below, 8);
            let ctx = |outer| context(face, (&a, &b), outer);
            let one = node_blocks(&ctx(OUTER)).target;
            let both = node_blocks(&ctx(Outer { one_way: false, ..OUTER })).target;
            // Measured: at most 1.9e-11; the bound is the kink pieces' own
            // accuracy (8 points over a phase of 4: 3e-9 of their share).
            for (j, (x, y)) in one[0].iter().zip(&both[0]).enumerate() {
                let d = (x - y).abs() / y;
                assert!(
                    d < 1e-9,
                    "alpha {alpha} over {below:?}, cell {j}: {x} against {y} ({d:.1e})"
                );
            }
        }
    }
}
