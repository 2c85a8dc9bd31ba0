//! The work budget of a multi-flux solve, estimated from the scene and the
//! options before any matrix is built.
//!
//! The solver's cost is dominated by dense `N x N` linear algebra (eigen
//! decomposition of each layer, products and inverses of the adding method),
//! `O(N^3)` each, where `N` is the number of quadrature nodes of the medium:
//! on the Snell-mapped grid of [`crate::quadrature::AngularGrid`] a medium of
//! index `n` has `streams x d(n)` nodes per hemisphere, `d(n)` being the
//! number of distinct indices of the stack that are `<= n`. A stack of `k`
//! layers of distinct indices thus costs `~ streams^3 k^4 / 4`: the grid,
//! not the layer count, is what grows. The estimate, in units of one
//! `N^3` step, is
//!
//! `W = sum_channels sum_{operators o} [M (N_o + B)^3 + c_p (M P + Q) (N_o + B)^2 + M c_0] (1 + K)`   (eq. W1)
//!
//! where the operators are the layers and the interfaces between media of
//! different index (every boundary with `all_effects`), `N_o` the node count
//! of the operator's denser medium, `B` the beams carried through every
//! operator (1 under collimated light), `P` the probes (one per distinct exit
//! polar angle on each side: [`crate::adding::probed`] keeps them apart from
//! the core, so each costs `(N_o + B)^2` per operator and order), `Q` the
//! markers of the single-scattering correction at order 0 (up to three per
//! probe and peaked layer), `M` the number of Fourier orders (1 for
//! totals; with BRDF/BTDF directions under a beam, `min(2 streams,
//! TYPICAL_ORDERS)`: the solver stops the azimuthal series once two orders
//! are negligible, after 10 orders for `g = 0.6` at 64 and at 192 streams on
//! `examples/paint-over-primer.toml`; `2 streams` with `all_effects`) and `K`
//! the truncation order of the
//! Neumann series (`neumann_order`; 0 for exact adding, whose cost the `1`
//! accounts for). The exit directions themselves cost a cosine sum each per
//! order, `D M` (counted with the same unit). `c_0` ([`OPERATOR_WORK`]) is
//! what an operator costs at each order besides its cubic steps (the phase
//! matrix's Fourier blocks, the eigen set-up, the boundary matrices, the
//! allocations): it dominates for small `N`, i.e. for scenes of many
//! channels of a few layers each.
//!
//! Calibration (2026-11, a 2-core machine): a stack of 60 layers of distinct
//! indices at 16 streams (`W = 2.8e10`) took 17.7 s unloaded, about 0.7 ns
//! per unit; under load 1.5 to 2.6 ns per unit were measured (10 layers at 64
//! streams, `W = 2.3e9`: 3.4 s; paint-over-primer at 192 streams, `W = 8e9`:
//! 17.9 s). The default budget [`DEFAULT_MAX_WORK`] is `1e10`: 7 to 25 s.

use km_core::{Light, MonoScene, Scene, Substrate};

use crate::error::MultifluxError;
use crate::options::MultifluxOptions;

/// Default work budget of one solve (eq. W1 units): 10^10, 7 to 25 s.
pub const DEFAULT_MAX_WORK: f64 = 1e10;

/// The cost of one probe row per operator and order in units of `(N_o +
/// B)^2` (eq. W1's `c_p`): its source-function integral in each layer (the
/// kernels to every node and every mode's path integral, two transposed
/// solves) and its share of the adding. Measured with callgrind on
/// `examples/paint-over-primer.toml` with 200 and 2000 distinct exit polar
/// angles at 6 and 16 streams: about 60 instructions per unit for the probes
/// against about 2 for the core's `N^3` steps, so that the 0.7 ns per unit of
/// the calibration below holds for both with `c_p = 50`.
pub const PROBE_WEIGHT: f64 = 50.0;

/// The work of one operator at one Fourier order besides its `(N_o + B)^3`
/// steps (eq. W1's `c_0`), in the same units. Measured (2026-12, 2 cores
/// at a load of 6 to 8) on a two-layer scene of index 1 (16 streams, `N_o +
/// B = 17`, eq. W1 without `c_0` 4 913 units per operator) with 500, 2000
/// and 8000 spectral channels of distinct albedos: 0.05, 0.22 and 0.87 s of
/// CPU, linear in the channels, 110 us a channel (55 us an operator), 11 ns
/// per unit of the cubic term alone; the profile (`perf`) shows the eigen
/// set-up, the phase matrix's blocks, the LU and boundary matrices and
/// `exp` each at a few per cent, none cubic. 55 us is 3.7e4 units at the
/// calibration's 1.5 ns per unit; with the margin of the calibration's
/// spread (0.7 to 2.6 ns) and a sweep point's reading of the scene (0.35 s
/// of CPU a point of the 2000-channel scene, against 0.22 s for the solve
/// alone) `c_0 = 1e5`: a 2000-channel solve of this scene is estimated at
/// 4.2e8 units (0.3 to 1.1 s), a 100-point sweep of it at 4.2e10.
pub const OPERATOR_WORK: f64 = 1e5;

/// Fourier orders assumed when angles are asked (eq. W1's `M`), unless the
/// streams resolve fewer.
pub const TYPICAL_ORDERS: usize = 12;

/// Largest truncation order of the Neumann series (`neumann_order`): past
/// ~10^4 round trips the truncated series equals exact adding to rounding in
/// any stack whose interreflection factor is below `1 - 1e-3`, and exact
/// adding (`neumann_order = None`) costs less.
pub const MAX_NEUMANN_ORDER: usize = 100_000;

/// The estimated work of a solve (eq. W1) and its parts, for messages.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorkEstimate {
    /// `W` of eq. W1, in `N^3` units.
    pub units: f64,
    /// Largest node count `N` of any medium, one hemisphere.
    pub max_nodes: usize,
    /// Largest number of Fourier orders `M` of any channel.
    pub orders: usize,
    /// Largest number of operators (layers + interfaces) of any channel.
    pub operators: usize,
    /// Channels solved.
    pub channels: usize,
}

impl WorkEstimate {
    /// Add one channel's estimate: the units summed, the sizes the largest.
    fn add_channel(&mut self, w: WorkEstimate) {
        self.units += w.units;
        self.max_nodes = self.max_nodes.max(w.max_nodes);
        self.orders = self.orders.max(w.orders);
        self.operators = self.operators.max(w.operators);
        self.channels += 1;
    }
}

/// Estimate the work of solving `scene` with `opts` (eq. W1), without
/// building anything: `O(channels x layers log layers)` arithmetic.
///
/// # Reference
/// The cost model of dense eigen and adding steps, `O(N^3)`: Golub & Van
/// Loan, *Matrix Computations*, 4th ed. (2013), §7.5; the node count of the
/// Snell-mapped grid: `docs/multiflux.md` (eq. Q1, Q2).
///
/// ```
/// use km_multiflux::{MultifluxOptions, budget::estimate};
/// let s = km_core::Scene::from_toml_str("[[layer]]\ntau = 1.0\nalbedo = 0.9\nn = 1.5\n").unwrap();
/// let w = estimate(&s, &MultifluxOptions { streams: Some(16), ..Default::default() });
/// // Ambient 1.0 and layer 1.5: 32 nodes in the layer, 1 extra column (the
/// // beam); one layer and two interfaces, each with its set-up `c_0`.
/// assert_eq!(w.max_nodes, 32);
/// assert_eq!(w.units, 3.0 * (33f64.powi(3) + km_multiflux::budget::OPERATOR_WORK));
/// ```
pub fn estimate(scene: &Scene, opts: &MultifluxOptions) -> WorkEstimate {
    let mut est = WorkEstimate { units: 0.0, max_nodes: 0, orders: 0, operators: 0, channels: 0 };
    for ch in scene.channels() {
        let w = estimate_mono(ch, opts);
        est.add_channel(w);
    }
    est
}

fn estimate_mono(scene: &MonoScene, opts: &MultifluxOptions) -> WorkEstimate {
    let streams = opts.streams.unwrap_or_else(|| crate::options::default_streams(scene));
    let beam = matches!(scene.light(), Light::Collimated { .. });
    let dirs = scene.directions_deg();
    let mut polar: Vec<f64> = dirs.iter().map(|d| d[0]).collect();
    polar.sort_by(|a, b| a.total_cmp(b));
    polar.dedup();
    let parts = Parts {
        streams,
        beams: if beam { 1 } else { 0 },
        probes: polar.len(),
        angles: !dirs.is_empty() && beam,
        exits: dirs.len(),
    };
    estimate_parts(scene, opts, parts)
}

/// What eq. W1 counts of a request besides the scene: the streams, the
/// beams `B`, the distinct exit polar angles (probes on each side), whether
/// angles are asked (the Fourier orders), and the exit values (`D`).
struct Parts {
    streams: usize,
    beams: usize,
    probes: usize,
    angles: bool,
    exits: usize,
}

fn estimate_parts(scene: &MonoScene, opts: &MultifluxOptions, parts: Parts) -> WorkEstimate {
    let streams = parts.streams as f64;
    // Media top to bottom; the substrate is a medium when it is transparent.
    let substrate_n = match scene.substrate() {
        Substrate::Transparent { n } => Some(n),
        _ => None,
    };
    let media = std::iter::once(scene.ambient_n())
        .chain(scene.layers().iter().map(|l| l.n()))
        .chain(substrate_n);
    // d(n): rank of n among the distinct indices (sorted once, then a binary
    // search); on the stack for a few media (the estimate runs on every solve).
    let mut few = [0.0f64; 8];
    let mut many = Vec::new();
    let count = scene.layers().len() + 1 + usize::from(substrate_n.is_some());
    let all: &mut [f64] = if count <= few.len() {
        &mut few[..count]
    } else {
        many.resize(count, 0.0);
        &mut many
    };
    let mut finite = 0;
    for x in media.filter(|x| x.is_finite()) {
        all[finite] = x;
        finite += 1;
    }
    let distinct = sorted_distinct(&mut all[..finite]);
    // The beams, and a probe per distinct exit polar angle above (and below
    // when the substrate is transparent), with up to three markers per probe
    // and peaked layer at order 0.
    let below = matches!(scene.substrate(), Substrate::Transparent { .. });
    let beams = parts.beams as f64;
    let probes = parts.probes as f64 * if below { 2.0 } else { 1.0 };
    let peaked = scene.layers().iter().filter(|l| l.albedo() > 0.0 && l.g() != 0.0).count();
    let markers = if parts.beams > 0 && opts.delta_m { 3.0 * probes * peaked as f64 } else { 0.0 };
    let nodes = |n: f64| streams * distinct.partition_point(|&x| x <= n).max(1) as f64;
    let size = |n: f64| nodes(n) + beams;
    // Per operator: the core's cubic cost, and the probes' and markers' rows.
    let mut orders = if opts.all_effects {
        2.0 * streams
    } else if parts.angles {
        (2.0 * streams).min(TYPICAL_ORDERS as f64)
    } else {
        1.0
    };
    if let Some(m) = opts.max_fourier_order {
        orders = orders.min(m as f64 + 1.0);
    }
    let cost = |n: f64| {
        orders * (size(n).powi(3) + OPERATOR_WORK)
            + PROBE_WEIGHT * (orders * probes + markers) * size(n).powi(2)
    };
    let mut work = 0.0;
    let mut operators = 0;
    let mut max_nodes = 0.0f64;
    let mut n_above = scene.ambient_n();
    for l in scene.layers() {
        let n_layer = nodes(l.n());
        max_nodes = max_nodes.max(n_layer);
        work += cost(l.n());
        operators += 1;
        let above = std::mem::replace(&mut n_above, l.n());
        if above != l.n() || opts.all_effects {
            work += cost(above.max(l.n()));
            operators += 1;
        }
    }
    if let (Substrate::Transparent { n }, Some(last)) = (scene.substrate(), scene.layers().last())
        && (n != last.n() || opts.all_effects)
    {
        work += cost(n.max(last.n()));
        operators += 1;
    }
    work += orders * parts.exits as f64;
    let neumann = opts.neumann_order.map_or(0.0, |k| k as f64);
    WorkEstimate {
        units: work * (1.0 + neumann),
        max_nodes: max_nodes as usize,
        orders: orders as usize,
        operators,
        channels: 1,
    }
}

/// Sort `x` and move its distinct values to its front (`Vec::dedup` on a
/// slice): the sorted distinct values.
fn sorted_distinct(x: &mut [f64]) -> &[f64] {
    x.sort_by(|a, b| a.total_cmp(b));
    let mut len = 0;
    for i in 0..x.len() {
        if len == 0 || x[i] != x[len - 1] {
            x[len] = x[i];
            len += 1;
        }
    }
    &x[..len]
}

/// The work of a BSDF table ([`crate::bsdf::Bsdf::new`]) of `scene` at the
/// incidence angles `theta_i` and exit polar angles `theta_o` (degrees):
/// eq. W1 with every incidence a beam (`B = theta_i` count, carried through
/// every operator: the cost grows as its cube), a probe per distinct exit
/// polar angle, the table's Fourier orders, and a value per angle pair and
/// order (eq. W2 of docs/limits.md). The streams are the options' or the
/// table's default ([`crate::default_bsdf_streams`]).
///
/// ```
/// use km_multiflux::{MultifluxOptions, budget::estimate_bsdf};
/// let s = km_core::Scene::from_toml_str("[[layer]]\ntau = 1.0\nalbedo = 0.9\n").unwrap();
/// let o = MultifluxOptions { streams: Some(8), ..Default::default() };
/// let w400 = estimate_bsdf(&s, &o, &vec![10.0; 400], &[0.0]).units;
/// let w800 = estimate_bsdf(&s, &o, &vec![10.0; 800], &[0.0]).units;
/// // Beams beside 8 nodes: doubling 400 angles multiplies the cubic part
/// // by (808 / 408)^3 = 7.8, the probe's rows by (808 / 408)^2 = 3.9.
/// assert!((6.5..8.0).contains(&(w800 / w400)), "{}", w800 / w400);
/// ```
pub fn estimate_bsdf(
    scene: &Scene,
    opts: &MultifluxOptions,
    theta_i: &[f64],
    theta_o: &[f64],
) -> WorkEstimate {
    let mut polar = theta_o.to_vec();
    polar.sort_by(|a, b| a.total_cmp(b));
    polar.dedup();
    let mut est = WorkEstimate { units: 0.0, max_nodes: 0, orders: 0, operators: 0, channels: 0 };
    for ch in scene.channels() {
        let streams =
            opts.streams.unwrap_or_else(|| crate::options::default_bsdf_streams(ch, theta_i));
        let parts = Parts {
            streams,
            beams: theta_i.len(),
            probes: polar.len(),
            angles: true,
            exits: theta_i.len() * theta_o.len(),
        };
        let w = estimate_parts(ch, opts, parts);
        est.add_channel(w);
    }
    est
}

/// Refuse a BSDF table whose estimate ([`estimate_bsdf`]) exceeds the
/// budget `opts.max_work` (default [`DEFAULT_MAX_WORK`]), before any
/// operator is built.
///
/// # Errors
/// [`MultifluxError::TooExpensive`] naming the estimate and what to change;
/// [`MultifluxError::Option`] for a budget that is not a positive number.
pub fn check_bsdf(
    scene: &Scene,
    opts: &MultifluxOptions,
    theta_i: &[f64],
    theta_o: &[f64],
) -> Result<WorkEstimate, MultifluxError> {
    check_fourier_tol(opts)?;
    let budget = checked_budget(opts)?;
    let est = estimate_bsdf(scene, opts, theta_i, theta_o);
    if est.units > budget {
        return Err(MultifluxError::TooExpensive {
            work: est.units,
            budget,
            hint: format!(
                "a BSDF table of {} channel(s), {} incidence angles (each a beam carried \
                 through every operator: the work grows as the cube of their number plus the \
                 nodes, {}) and {} exit polar angles, {} Fourier order(s); about {:.0} s at \
                 0.7 ns per unit. Use fewer incidence angles (split the table), fewer streams \
                 or channels, or raise the budget (km: --budget FACTOR; library: max_work)",
                est.channels,
                theta_i.len(),
                est.max_nodes,
                theta_o.len(),
                est.orders,
                est.units * 0.7e-9,
            ),
        });
    }
    Ok(est)
}

/// `opts.fourier_tol` in `[0, MAX_FOURIER_TOL]` (not a number is refused).
fn check_fourier_tol(opts: &MultifluxOptions) -> Result<(), MultifluxError> {
    let tol = opts.fourier_tol;
    if (0.0..=crate::options::MAX_FOURIER_TOL).contains(&tol) {
        return Ok(());
    }
    Err(MultifluxError::Option { name: "fourier_tol", value: tol, reason: "must lie in [0, 0.1]" })
}

/// `opts.max_work` (default [`DEFAULT_MAX_WORK`]) when it is a positive number.
fn checked_budget(opts: &MultifluxOptions) -> Result<f64, MultifluxError> {
    let budget = opts.max_work.unwrap_or(DEFAULT_MAX_WORK);
    if budget.is_nan() || budget <= 0.0 {
        return Err(MultifluxError::Option {
            name: "max_work",
            value: budget,
            reason: "must be a positive number",
        });
    }
    Ok(budget)
}

/// Refuse a solve whose estimate (eq. W1) exceeds its budget
/// (`opts.max_work`, default [`DEFAULT_MAX_WORK`]) or whose Neumann order
/// exceeds [`MAX_NEUMANN_ORDER`]; called first thing by [`crate::solve`].
///
/// # Errors
/// [`MultifluxError::TooExpensive`] naming the estimate, its parts and what
/// to change; [`MultifluxError::Option`] for the Neumann order or a budget
/// that is not a positive number.
pub fn check(scene: &Scene, opts: &MultifluxOptions) -> Result<WorkEstimate, MultifluxError> {
    if let Some(k) = opts.neumann_order.filter(|&k| k > MAX_NEUMANN_ORDER) {
        return Err(MultifluxError::Option {
            name: "neumann_order",
            value: k as f64,
            reason: "must be <= 100000 (leave it unset for exact adding, which is cheaper)",
        });
    }
    check_fourier_tol(opts)?;
    let budget = checked_budget(opts)?;
    let est = estimate(scene, opts);
    if est.units > budget {
        return Err(MultifluxError::TooExpensive {
            work: est.units,
            budget,
            hint: format!(
                "{} channel(s), up to {} operators (layers and interfaces) of up to {} nodes, \
                 {} Fourier order(s){}; about {:.0} s at 0.7 ns per unit. Use fewer streams, \
                 fewer distinct refractive indices (each adds a Snell segment of `streams` \
                 nodes), fewer channels or directions, or raise the budget (km: --budget \
                 FACTOR; library: max_work)",
                est.channels,
                est.operators,
                est.max_nodes,
                est.orders,
                opts.neumann_order.map(|k| format!(", Neumann order {k}")).unwrap_or_default(),
                est.units * 0.7e-9,
            ),
        });
    }
    Ok(est)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stack(k: usize) -> Scene {
        let mut t = String::new();
        for i in 0..k {
            t.push_str(&format!(
                "[[layer]]\ntau = 0.1\nalbedo = 0.9\nn = {}\n",
                1.0 + 0.5 * i as f64 / k as f64
            ));
        }
        Scene::from_toml_str(&t).unwrap()
    }

    #[test]
    fn sorted_distinct_is_sort_then_dedup() {
        for x in [
            Vec::<f64>::new(),
            vec![1.5],
            vec![1.0, 1.5, 1.0, 1.33, 1.5, 1.5],
            vec![2.0, 1.0, 2.0, 1.0, 1.0, 3.0, 2.5, 2.5, 1.0, 4.0, 1.0, 0.5],
        ] {
            let mut want = x.clone();
            want.sort_by(|a, b| a.total_cmp(b));
            want.dedup();
            let mut got = x.clone();
            assert_eq!(sorted_distinct(&mut got), &want[..], "{x:?}");
        }
    }

    /// Up to 8 media the ranks are found on the stack, from 9 on in a
    /// vector. `stack(k)` has `k` distinct indices (its first is the
    /// ambient's), so its deepest layer meets `8 k` nodes at 8 streams, on
    /// either side of the switch; a repeated index adds no rank.
    #[test]
    fn index_ranks_on_both_sides_of_the_stack_buffer() {
        let o = MultifluxOptions { streams: Some(8), ..Default::default() };
        for k in [1, 6, 7, 8, 9, 12] {
            assert_eq!(estimate(&stack(k), &o).max_nodes, 8 * k, "{k} layers");
        }
        let repeated = Scene::from_toml_str(
            &"[[layer]]\ntau = 0.1\nalbedo = 0.9\nn = 1.5\n[[layer]]\ntau = 0.1\nalbedo = 0.9\nn = 1.2\n"
                .repeat(6),
        )
        .unwrap();
        assert_eq!(estimate(&repeated, &o).max_nodes, 8 * 3);
    }

    #[test]
    fn distinct_indices_grow_the_grid_as_k_to_the_fourth() {
        // eq. W1 with N_i = 16 i (layer i has the i-th distinct index):
        // doubling k multiplies the sum of N^3 by about 2^4.
        let o = MultifluxOptions { streams: Some(16), ..Default::default() };
        let w20 = estimate(&stack(20), &o).units;
        let w40 = estimate(&stack(40), &o).units;
        assert!((w40 / w20 - 16.0).abs() < 2.0, "{}", w40 / w20);
    }

    #[test]
    fn the_issue_stacks_are_refused_and_small_ones_pass() {
        let o = MultifluxOptions::default();
        assert!(check(&stack(3), &o).is_ok());
        for k in [100, 1000] {
            let e = check(&stack(k), &o).unwrap_err();
            assert!(matches!(e, MultifluxError::TooExpensive { .. }), "{e}");
            assert!(e.to_string().contains("--budget"), "{e}");
        }
        let raised = MultifluxOptions { max_work: Some(1e14), ..Default::default() };
        assert!(check(&stack(100), &raised).is_ok());
    }

    #[test]
    fn neumann_order_is_capped_and_priced() {
        let s = stack(2);
        let big = MultifluxOptions { neumann_order: Some(usize::MAX), ..Default::default() };
        assert!(matches!(check(&s, &big), Err(MultifluxError::Option { .. })));
        let o1 = MultifluxOptions { neumann_order: Some(1), ..Default::default() };
        let o9 = MultifluxOptions { neumann_order: Some(9), ..Default::default() };
        assert_eq!(estimate(&s, &o9).units, 5.0 * estimate(&s, &o1).units);
    }
}
