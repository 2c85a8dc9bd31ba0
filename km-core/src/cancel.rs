//! A cancellation flag shared between the caller of a long computation and
//! the computation ([`Cancel`]).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// A flag the caller raises to stop a computation that is under way: the
/// Monte Carlo tracer reads it between batches and every few thousand
/// photons within one, a batch or a sweep between its points, and the
/// computation then returns its `Cancelled` error (no partial result).
/// Clones share the flag. Never changes a result that is returned.
///
/// ```
/// let c = km_core::Cancel::new();
/// let seen_by_worker = c.clone();
/// assert!(!seen_by_worker.is_cancelled());
/// c.cancel();
/// assert!(seen_by_worker.is_cancelled());
/// ```
#[derive(Clone, Default)]
pub struct Cancel(Arc<AtomicBool>);

impl Cancel {
    /// A flag not raised.
    pub fn new() -> Cancel {
        Cancel::default()
    }

    /// Raise the flag: the computations holding a clone stop at their next check.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    /// Whether the flag is raised.
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

impl std::fmt::Debug for Cancel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Cancel({})", self.is_cancelled())
    }
}

/// Two flags are equal when they are the same flag (clones of one another).
impl PartialEq for Cancel {
    fn eq(&self, other: &Cancel) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

/// Whether `cancel` is given and raised.
pub fn cancelled(cancel: Option<&Cancel>) -> bool {
    cancel.is_some_and(Cancel::is_cancelled)
}
