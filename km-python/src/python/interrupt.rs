//! Long calls that Ctrl-C stops ([`interruptible`]), and parallel work that
//! survives a `fork` ([`fork_safe`]).
//!
//! **Interrupts.** Python runs its signal handlers on the main thread, and
//! only while it holds the GIL. A call that released the GIL for minutes
//! would therefore see Ctrl-C only when it returns. [`interruptible`],
//! called on the main thread, hands the work to the thread pool (a job of
//! a rayon scope: no thread is started for it, so a call costs no thread
//! stack or allocator arena of its own); the calling thread waits with the
//! GIL released, takes it back every [`POLL`] to run the signal handlers
//! (`PyErr_CheckSignals`), and when one raises (`KeyboardInterrupt`, or any
//! exception a handler raises) raises the work's cancel flag
//! ([`km::Cancel`]), waits for the work to stop (the Monte Carlo tracer
//! looks at the flag every few thousand photons, a batch before each of its
//! points), and raises that exception. Nothing of the call is left running.
//!
//! **Fork.** rayon's global pool is made once per process; a process forked
//! from one whose pool has started inherits the pool's state but not its
//! threads, and work sent to it would wait forever. In a process other than
//! the one that imported the module, the work runs on a pool of that
//! process (built at its first call, kept for the next ones: [`fork_safe`],
//! and [`interruptible`]'s scope), so a fork-context `multiprocessing` pool
//! works as a spawn-context one does.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::Duration;

use pyo3::prelude::*;

use super::py_err;
use crate::error::Error;

/// How often a waiting call takes the GIL back to look for a signal.
pub(crate) const POLL: Duration = Duration::from_millis(20);

/// The process that imported the module (0 before it is imported).
static HOME_PID: AtomicU32 = AtomicU32::new(0);

/// A forked process's own rayon pool, with its process id.
static FORKED_POOL: Mutex<Option<(u32, &'static rayon::ThreadPool)>> = Mutex::new(None);

/// Record the importing process (module initialisation).
pub(crate) fn init() {
    HOME_PID.store(std::process::id(), Ordering::Relaxed);
}

/// Run `f`, on a rayon pool of this process when it was forked from the one
/// that imported the module (see the module's documentation).
///
/// # Errors
/// A pool that cannot be built in a forked process.
pub(crate) fn fork_safe<T: Send>(f: impl FnOnce() -> Result<T, Error> + Send) -> Result<T, Error> {
    match own_pool()? {
        None => f(),
        Some(pool) => pool.install(f),
    }
}

/// The pool parallel work must run on: `None` for rayon's global pool in
/// the process that imported the module, else the pool of this process.
///
/// # Errors
/// A pool that cannot be built in a forked process.
fn own_pool() -> Result<Option<&'static rayon::ThreadPool>, Error> {
    let pid = std::process::id();
    let home = HOME_PID.load(Ordering::Relaxed);
    if home == 0 || home == pid { Ok(None) } else { forked_pool(pid).map(Some) }
}

/// The pool of the forked process `pid`, built at its first call. A pool of
/// another process (the parent's, inherited by a fork of a fork) is left
/// alone: its threads are not in this process, and dropping it would send
/// them messages.
fn forked_pool(pid: u32) -> Result<&'static rayon::ThreadPool, Error> {
    let mut slot = FORKED_POOL.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((p, pool)) = *slot
        && p == pid
    {
        return Ok(pool);
    }
    let pool =
        rayon::ThreadPoolBuilder::new().thread_name(|i| format!("km-forked-{i}")).build().map_err(
            |e| Error::Internal(format!("cannot build a thread pool in a forked process: {e}")),
        )?;
    let pool: &'static rayon::ThreadPool = Box::leak(Box::new(pool));
    *slot = Some((pid, pool));
    Ok(pool)
}

/// `f`, with a panic turned into [`Error::Internal`].
pub(crate) fn caught<T>(f: impl FnOnce() -> Result<T, Error>) -> Result<T, Error> {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|p| {
        let msg = p
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_else(|| "panic".into());
        Err(Error::Internal(msg))
    })
}

/// Whether the worker has finished, and the wake-up of the waiting caller.
#[derive(Default)]
struct Done {
    flag: Mutex<bool>,
    wake: Condvar,
}

impl Done {
    fn set(&self) {
        *self.flag.lock().unwrap_or_else(|e| e.into_inner()) = true;
        self.wake.notify_all();
    }

    /// Wait up to `timeout` (forever when `None`); whether the worker is done.
    fn wait(&self, timeout: Option<Duration>) -> bool {
        let done = self.flag.lock().unwrap_or_else(|e| e.into_inner());
        let done = match timeout {
            Some(t) => {
                self.wake.wait_timeout_while(done, t, |d| !*d).unwrap_or_else(|e| e.into_inner()).0
            }
            None => self.wake.wait_while(done, |d| !*d).unwrap_or_else(|e| e.into_inner()),
        };
        *done
    }
}

/// Whether the calling thread is Python's main thread, the only one that
/// runs signal handlers (`False` when it cannot be told).
fn on_main_thread(py: Python<'_>) -> bool {
    let main = || -> PyResult<bool> {
        let threading = py.import("threading")?;
        let current = threading.call_method0("current_thread")?;
        Ok(current.is(&threading.call_method0("main_thread")?))
    };
    main().unwrap_or(false)
}

/// Run `f` with the GIL released as a job of the thread pool, stoppable by
/// Ctrl-C (see the module's documentation): `f` gets the cancel flag to
/// hand to the library. A panic becomes [`Error::Internal`]. Called from
/// a thread other than Python's main thread (which no signal handler runs
/// on), `f` runs on the calling thread as [`super::guarded`] runs it.
///
/// # Errors
/// The exception a signal handler raised (`KeyboardInterrupt`), after the
/// work has stopped; `f`'s error as a `km.KmError`.
pub(crate) fn interruptible<T: Send>(
    py: Python<'_>,
    f: impl FnOnce(&km::Cancel) -> Result<T, Error> + Send,
) -> PyResult<T> {
    let cancel = km::Cancel::new();
    if !on_main_thread(py) {
        return py.detach(|| caught(|| fork_safe(|| f(&cancel)))).map_err(|e| py_err(py, e));
    }
    let pool = own_pool().map_err(|e| py_err(py, e))?;
    let done = Done::default();
    let result: Mutex<Option<Result<T, Error>>> = Mutex::new(None);
    let (c, d, r) = (&cancel, &done, &result);
    // The scope ends when its job has (the job has set `done`: at once).
    let interrupt = match pool {
        None => rayon::in_place_scope(|s| watch(s, py, f, c, d, r)),
        Some(p) => p.in_place_scope(|s| watch(s, py, f, c, d, r)),
    };
    if let Some(e) = interrupt {
        return Err(e);
    }
    let outcome = result.into_inner().unwrap_or_else(|e| e.into_inner());
    outcome
        .unwrap_or_else(|| Err(Error::Internal("the work ended without a result".into())))
        .map_err(|e| py_err(py, e))
}

/// Spawn `f` on `scope` and wait for it, running the signal handlers every
/// [`POLL`]; the exception of a handler, after the work has stopped.
fn watch<'scope, T: Send + 'scope>(
    scope: &rayon::Scope<'scope>,
    py: Python<'_>,
    f: impl FnOnce(&km::Cancel) -> Result<T, Error> + Send + 'scope,
    cancel: &'scope km::Cancel,
    done: &'scope Done,
    result: &'scope Mutex<Option<Result<T, Error>>>,
) -> Option<PyErr> {
    scope.spawn(move |_| {
        let r = caught(|| f(cancel));
        *result.lock().unwrap_or_else(|e| e.into_inner()) = Some(r);
        done.set();
    });
    while !py.detach(|| done.wait(Some(POLL))) {
        if let Err(e) = py.check_signals() {
            cancel.cancel();
            py.detach(|| done.wait(None));
            return Some(e);
        }
    }
    None
}
