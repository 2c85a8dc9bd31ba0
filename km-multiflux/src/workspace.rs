//! Scratch space reused across Fourier orders, layers, channels and solves.
//!
//! The per-order work of a layer (probe rows, kernels, the beam's particular
//! solution and its columns, the boundary-value solves) needs a few dozen
//! short vectors of `N`, `2N` or `N + extras` values. Allocating them afresh
//! in every order made allocation a large share of a small solve
//! (docs/multiflux.md §9 (i)). A [`Workspace`] keeps the vectors handed back
//! to it and hands them out again, so after the first order of the first
//! solve on a thread the per-order loop of a lone layer allocates none of
//! them. The values computed are the same bit for bit: a vector taken from
//! the workspace is zero-filled to the requested length, as `vec![0.0; len]`,
//! except where the caller writes every element before reading any
//! ([`Workspace::take_for_overwrite`], [`Workspace::take_mat_for_overwrite`]:
//! the zero fill was a few per cent of a small solve, docs/multiflux.md
//! §9 (v)).
//!
//! One workspace is kept per thread ([`with_workspace`]), so channels solved
//! on the rayon pool each use their own. It is bounded: at most
//! [`MAX_VECTORS`] vectors and [`MAX_MATRICES`] matrices of at most
//! [`MAX_LEN`] values each are kept (12 MiB per thread at most, besides
//! faer's scratch); anything
//! beyond is freed as usual. The boundary matrices of eq. S4 and the node
//! operators of a layer come from it too ([`Workspace::take_mat`]), and so
//! do the matrices of the eigen-solve ([`crate::eigen`]: `H+-`, the Cholesky
//! factor, the products, the eigenvectors, `v~`, `z~`) and faer's scratch
//! for its Cholesky factorisation and symmetric eigen-solver
//! ([`Workspace::stack`]: one buffer, grown to the largest request, that
//! is `O(N^2)` values for `N` nodes).

use std::cell::RefCell;

use faer::Mat;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};

/// Most vectors a workspace keeps.
pub(crate) const MAX_VECTORS: usize = 128;
/// Most matrices a workspace keeps.
pub(crate) const MAX_MATRICES: usize = 64;
/// Shortest capacity of a new vector (values).
const MIN_LEN: usize = 64;
/// Longest vector (values) a workspace keeps: `8192` values = 64 KiB.
pub(crate) const MAX_LEN: usize = 8192;

/// A pool of `f64` vectors (see the module doc).
pub(crate) struct Workspace {
    free: Vec<Vec<f64>>,
    /// Kept index vectors (the LU's pivots, the probes' map).
    idx: Vec<Vec<usize>>,
    mats: Vec<Mat<f64>>,
    /// faer's scratch (the Cholesky factorisation and the symmetric
    /// eigen-solver of [`crate::eigen`]), grown to the largest request seen.
    stack: Option<MemBuffer>,
    /// Vectors handed out, and how many of them needed a fresh allocation
    /// (none kept, or none long enough): counts for tests and benchmarks.
    taken: usize,
    fresh: usize,
    /// The beam's path factors into the probes of the last layer and beam
    /// seen ([`Workspace::beam_paths`]): they do not depend on the Fourier
    /// order, so the orders after the first reuse them.
    paths: PathMemo,
    /// The probes' attenuations `exp(-tau / mu_x)` through the last layer
    /// seen ([`Workspace::probe_attenuations`]), order-independent too.
    atten: PathMemo,
}

/// Values per probe cosine that do not depend on the Fourier order
/// ([`Workspace::beam_paths`]), kept with
/// their arguments: the layer's `tau`, the beam's `mu_b` and the cosines.
struct PathMemo {
    tau: f64,
    mu_b: f64,
    mu: Vec<f64>,
    values: Vec<[f64; 2]>,
}

impl PathMemo {
    const fn new() -> Self {
        PathMemo { tau: 0.0, mu_b: 0.0, mu: Vec::new(), values: Vec::new() }
    }

    /// The values `f(mu_x)` for the cosines `mu`, computed afresh unless
    /// `tau`, `mu_b` and `mu` are those of the last call (bit for bit).
    fn get(&mut self, tau: f64, mu_b: f64, mu: &[f64], f: impl Fn(f64) -> [f64; 2]) -> &[[f64; 2]] {
        let same = self.tau.to_bits() == tau.to_bits()
            && self.mu_b.to_bits() == mu_b.to_bits()
            && self.mu.len() == mu.len()
            && self.mu.iter().zip(mu).all(|(a, b)| a.to_bits() == b.to_bits());
        if !same || self.values.len() != mu.len() {
            self.tau = tau;
            self.mu_b = mu_b;
            self.mu.clear();
            self.mu.extend_from_slice(mu);
            self.values.clear();
            self.values.extend(mu.iter().map(|&mu_x| f(mu_x)));
        }
        &self.values
    }
}

impl Default for Workspace {
    fn default() -> Self {
        Workspace::new()
    }
}

impl Workspace {
    /// An empty workspace.
    pub(crate) const fn new() -> Self {
        Workspace {
            free: Vec::new(),
            idx: Vec::new(),
            mats: Vec::new(),
            stack: None,
            taken: 0,
            fresh: 0,
            paths: PathMemo::new(),
            atten: PathMemo::new(),
        }
    }

    /// A vector of `len` zeros, reusing a kept one where possible: the
    /// shortest one long enough (best fit, so that short requests do not use
    /// up the long vectors; the search stops at the first one of at most
    /// `max(len, MIN_LEN)` values, from the most recently returned).
    pub(crate) fn take(&mut self, len: usize) -> Vec<f64> {
        let mut v = self.take_kept(len);
        v.clear();
        v.resize(len, 0.0);
        v
    }

    /// The kept vector of [`Workspace::take`] (best fit, its old contents),
    /// or a new empty one.
    #[inline]
    fn take_kept(&mut self, len: usize) -> Vec<f64> {
        self.taken += 1;
        let fit = len.max(MIN_LEN);
        // The common case, inlined: the most recently returned vector fits
        // (long enough, at most `fit`), which is where the search below stops.
        if let Some(c) = self.free.last().map(Vec::capacity)
            && c >= len
            && c <= fit
        {
            return self.free.pop().expect("checked above");
        }
        self.search_kept(len, fit)
    }

    /// [`Workspace::take_kept`] past its common case: the best fit among
    /// the kept vectors, or a new one.
    #[inline(never)]
    fn search_kept(&mut self, len: usize, fit: usize) -> Vec<f64> {
        let mut best: Option<(usize, usize)> = None;
        for (i, v) in self.free.iter().enumerate().rev() {
            let c = v.capacity();
            if c >= len && best.is_none_or(|(_, b)| c < b) {
                best = Some((i, c));
                if c <= fit {
                    break;
                }
            }
        }
        match best.map(|(i, _)| i) {
            Some(i) => self.free.swap_remove(i),
            None => {
                // None long enough: a new one (the kept ones stay for shorter
                // requests), at least MIN_LEN long so it serves most later ones.
                self.fresh += 1;
                Vec::with_capacity(len.max(MIN_LEN))
            }
        }
    }

    /// A vector of `len` unspecified values (those of its last use, zeros
    /// where it grows): [`Workspace::take`] without the zero fill, for
    /// callers that write every element before reading any.
    #[inline(always)]
    pub(crate) fn take_for_overwrite(&mut self, len: usize) -> Vec<f64> {
        let mut v = self.take_kept(len);
        if v.len() >= len {
            v.truncate(len);
            v
        } else {
            grown(v, len)
        }
    }

    /// Hand `v` back for reuse (freed instead when the workspace is full or
    /// `v` is longer than [`MAX_LEN`]).
    #[inline(always)]
    pub(crate) fn give(&mut self, v: Vec<f64>) {
        if v.capacity() > 0 && v.capacity() <= MAX_LEN && self.free.len() < MAX_VECTORS {
            self.free.push(v);
        }
    }

    /// A vector of `len` zero indices, reusing a kept one where possible.
    pub(crate) fn take_idx(&mut self, len: usize) -> Vec<usize> {
        self.taken += 1;
        let mut v = match self.idx.iter().rposition(|v| v.capacity() >= len) {
            Some(i) => self.idx.swap_remove(i),
            None => {
                self.fresh += 1;
                Vec::with_capacity(len.max(MIN_LEN))
            }
        };
        v.clear();
        v.resize(len, 0);
        v
    }

    /// Hand an index vector back for reuse (freed instead when the
    /// workspace is full or `v` is longer than [`MAX_LEN`]).
    pub(crate) fn give_idx(&mut self, v: Vec<usize>) {
        if v.capacity() > 0 && v.capacity() <= MAX_LEN && self.idx.len() < MAX_VECTORS {
            self.idx.push(v);
        }
    }

    /// A zero matrix of `nrows x ncols`, reusing a kept one of that shape.
    pub(crate) fn take_mat(&mut self, nrows: usize, ncols: usize) -> Mat<f64> {
        let mut m = self.take_mat_for_overwrite(nrows, ncols);
        m.as_mut().fill(0.0);
        m
    }

    /// A matrix of `nrows x ncols` whose values are unspecified (those of
    /// its last use, or zeros when new): [`Workspace::take_mat`] without the
    /// zero fill, for callers that write every element before reading any.
    pub(crate) fn take_mat_for_overwrite(&mut self, nrows: usize, ncols: usize) -> Mat<f64> {
        self.taken += 1;
        match self.mats.iter().rposition(|m| m.nrows() == nrows && m.ncols() == ncols) {
            Some(i) => self.mats.swap_remove(i),
            None => {
                self.fresh += 1;
                Mat::zeros(nrows, ncols)
            }
        }
    }

    /// Hand `m` back for reuse (freed instead when empty, when the
    /// workspace keeps [`MAX_MATRICES`] already, or above [`MAX_LEN`] values).
    pub(crate) fn give_mat(&mut self, m: Mat<f64>) {
        let len = m.nrows() * m.ncols();
        if len > 0 && len <= MAX_LEN && self.mats.len() < MAX_MATRICES {
            self.mats.push(m);
        }
    }

    /// faer's scratch for a request `req`: the kept buffer when it can hold
    /// `req`, else a new one of `req` (the old one is freed). Its contents
    /// are arbitrary, as those of a new buffer.
    pub(crate) fn stack(&mut self, req: StackReq) -> &mut MemStack {
        let fits = self.stack.as_mut().is_some_and(|b| MemStack::new(b).can_hold(req));
        if !fits {
            self.fresh += 1;
            self.stack = Some(MemBuffer::new(req));
        }
        self.taken += 1;
        MemStack::new(self.stack.as_mut().expect("set above"))
    }

    /// For a beam at cosine `mu_b` in a layer of optical thickness `tau`,
    /// per probe cosine `mu_x` of `mu`: `[phi(1/mu_b + 1/mu_x, tau),
    /// e2(1/mu_b, 1/mu_x, tau)]` (the path integrals of the beam's particular
    /// solution up and down a probe, eq. 14 of docs/multiflux.md), computed
    /// once and reused while the layer, the beam and the probes stay the same
    /// (every Fourier order of a solve): the same numbers as computing them
    /// afresh, from the same function of the same arguments.
    pub(crate) fn beam_paths(&mut self, tau: f64, mu_b: f64, mu: &[f64]) -> &[[f64; 2]] {
        self.paths.get(tau, mu_b, mu, |mu_x| {
            let (kb, beta) = (1.0 / mu_b, 1.0 / mu_x);
            [crate::correction::phi(kb + beta, tau), crate::correction::e2(kb, beta, tau)]
        })
    }

    /// `exp(-tau / mu_x)` (0 for a half-space) per probe cosine `mu_x` of
    /// `mu`, in the first of each pair: like [`Workspace::beam_paths`], kept
    /// with its arguments (the beam's cosine plays no part: 0 in the key).
    pub(crate) fn probe_attenuations(&mut self, tau: f64, mu: &[f64]) -> &[[f64; 2]] {
        self.atten.get(tau, 0.0, mu, |mu_x| [crate::correction::atten(tau, mu_x), 0.0])
    }

    /// `(taken, fresh)`: vectors handed out since the workspace was made and
    /// how many of them were new allocations.
    #[cfg(test)]
    pub(crate) fn counts(&self) -> (usize, usize) {
        (self.taken, self.fresh)
    }
}

/// `v` grown to `len` values (zeros past its old ones): the rare path of
/// [`Workspace::take_for_overwrite`], kept out of its inlined common one.
#[inline(never)]
fn grown(mut v: Vec<f64>, len: usize) -> Vec<f64> {
    v.resize(len, 0.0);
    v
}

/// `n` zeros in a vector taken from `malloc`, not `calloc` (`vec![0.0; n]`):
/// glibc (2.36) serves `calloc` outside its per-thread cache, by its general
/// allocator, at several times the instructions of a cached `malloc` and a
/// fill for the short vectors a solve makes once (docs/benchmarks.md §9).
pub(crate) fn zeros(n: usize) -> Vec<f64> {
    let mut v = Vec::with_capacity(n);
    v.resize(n, 0.0);
    v
}

thread_local! {
    static WORKSPACE: RefCell<Workspace> = const { RefCell::new(Workspace::new()) };
}

/// Run `f` with this thread's workspace (borrowed in place, not moved).
/// Re-entrant: a nested call (none is made today) gets a fresh, empty
/// workspace, and the outer one is kept.
pub(crate) fn with_workspace<R>(f: impl FnOnce(&mut Workspace) -> R) -> R {
    WORKSPACE.with(|cell| match cell.try_borrow_mut() {
        Ok(mut ws) => f(&mut ws),
        Err(_) => f(&mut Workspace::new()),
    })
}

/// `(taken, fresh)` of this thread's workspace (see [`Workspace::counts`]).
#[cfg(test)]
pub(crate) fn thread_counts() -> (usize, usize) {
    with_workspace(|ws| ws.counts())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A vector of `len` sevens taken from `ws` and handed back: its address.
    fn kept_sevens(ws: &mut Workspace, len: usize) -> *const f64 {
        let mut a = ws.take(len);
        a.iter_mut().for_each(|x| *x = 7.0);
        let ptr = a.as_ptr();
        ws.give(a);
        ptr
    }

    /// A vector taken back is zero-filled to the requested length, reused
    /// (no new allocation) when one long enough was returned, and the pool
    /// stays within its bounds.
    #[test]
    fn reuses_and_zero_fills() {
        let mut ws = Workspace::default();
        let ptr = kept_sevens(&mut ws, 5);
        let b = ws.take(3);
        assert_eq!(b, vec![0.0; 3]);
        assert_eq!(b.as_ptr(), ptr, "the returned vector is reused");
        assert_eq!(ws.counts(), (2, 1));
        ws.give(b);
        for _ in 0..2 * MAX_VECTORS {
            ws.give(vec![1.0; 4]);
        }
        assert_eq!(ws.free.len(), MAX_VECTORS);
        ws.give(vec![0.0; MAX_LEN + 1]);
        assert!(ws.free.iter().all(|v| v.capacity() <= MAX_LEN));
    }

    /// The variants for callers that overwrite every element hand out a
    /// kept vector or matrix of the requested size without filling it, and
    /// count as `take` does.
    #[test]
    fn for_overwrite_reuses_without_filling() {
        let mut ws = Workspace::default();
        let ptr = kept_sevens(&mut ws, 6);
        let b = ws.take_for_overwrite(4);
        assert_eq!((b.len(), b.as_ptr()), (4, ptr), "the kept vector, cut to length");
        assert_eq!(b, vec![7.0; 4], "its old values are not cleared");
        ws.give(b);
        let c = ws.take_for_overwrite(9);
        assert_eq!(c.len(), 9, "grown to the length asked");
        let mut m = ws.take_mat(3, 2);
        m[(1, 1)] = 5.0;
        ws.give_mat(m);
        let m = ws.take_mat_for_overwrite(3, 2);
        assert_eq!((m.nrows(), m.ncols(), m[(1, 1)]), (3, 2, 5.0));
        assert_eq!(ws.take_mat(3, 2)[(1, 1)], 0.0, "a new zero matrix: the kept one is out");
        assert_eq!(ws.counts().0, 6);
    }

    /// The per-order loop of a lone layer under a beam with exit directions
    /// (the BRDF case of docs/benchmarks.md §6) uses the workspace, and a
    /// second, warm solve on the same thread takes no new vector, matrix
    /// (the eigen-solve's `H+-`, factor, products, eigenvectors, the boundary
    /// matrices) or faer scratch buffer from the allocator for it; its answer
    /// is the same bit for bit.
    #[test]
    fn warm_solve_takes_no_new_vectors() {
        let mut text = String::from(
            "[light]\ntheta_deg = 30.0\n[[layer]]\ntau = 1.0\nalbedo = 0.9\ng = 0.8\n\
             [substrate]\nkind = \"black\"\n[output]\ndirections_deg = [",
        );
        for t in [10, 20, 30, 40, 50, 60] {
            for p in [0, 45, 90, 135, 180] {
                text += &format!("[{t}.0, {p}.0], ");
            }
        }
        text += "]\n";
        let scene = km_core::Scene::from_toml_str(&text).unwrap();
        let opts = crate::MultifluxOptions { streams: Some(8), ..Default::default() };
        let first = crate::solve(&scene, &opts).unwrap();
        let (t0, f0) = thread_counts();
        let second = crate::solve(&scene, &opts).unwrap();
        let (t1, f1) = thread_counts();
        // 16 Fourier orders, each with a few dozen vectors and, in the
        // eigen-solve alone, 9 matrices and 2 scratch requests.
        assert!(t1 - t0 > 16 * (20 + 11), "the solve uses the workspace: {} vectors", t1 - t0);
        assert_eq!(f1, f0, "no new vector, matrix or scratch in a warm solve");
        assert_eq!(first.channels, second.channels);
    }

    /// Re-entrant use gets its own workspace; the outer one survives.
    #[test]
    fn nested_use_is_safe() {
        with_workspace(|outer| {
            let v = outer.take(4);
            let inner = with_workspace(|inner| inner.take(2).len());
            assert_eq!(inner, 2);
            outer.give(v);
        });
        assert!(with_workspace(|ws| !ws.free.is_empty()));
    }
}
