//! Errors of the Monte Carlo tracer: one enum, every message names the offending value.

use thiserror::Error;

/// An error of the Monte Carlo library.
#[derive(Debug, Error)]
pub enum McError {
    /// The scene is invalid (see [`km_core::CoreError`]).
    #[error(transparent)]
    Scene(#[from] km_core::CoreError),
    /// An option outside its domain.
    #[error("invalid option {name} = {value}: {reason}")]
    Option {
        /// Option name (as in [`crate::McOptions`]).
        name: &'static str,
        /// The offending value, printed.
        value: String,
        /// What the domain is.
        reason: &'static str,
    },
    /// A shard request `index/count` that does not exist.
    #[error("invalid shard {index}/{count}: need count >= 1 and 0 <= index < count")]
    Shard {
        /// Requested shard index (0-based).
        index: u64,
        /// Requested number of shards.
        count: u64,
    },
    /// Partial tallies that cannot be merged.
    #[error("cannot merge partial tallies: {0}")]
    Merge(String),
    /// The run would exceed its work budget (`McOptions::max_events`).
    #[error(
        "refused: this run needs about {expected_events:.3e} photon steps (budget {budget:.3e}), \
         about {expected_seconds:.0} s on one core at the measured rate; {hint}"
    )]
    TooExpensive {
        /// Projected number of photon steps for the whole run.
        expected_events: f64,
        /// The budget that was exceeded.
        budget: f64,
        /// Projected single-core time, seconds.
        expected_seconds: f64,
        /// What to change.
        hint: String,
    },
    /// The run's tallies would exceed their memory budget (`McOptions::max_tally_bytes`).
    #[error("refused: the tallies need about {bytes:.3e} bytes (budget {budget:.3e}); {hint}")]
    TooMuchMemory {
        /// Projected bytes of tallies.
        bytes: f64,
        /// The budget.
        budget: f64,
        /// What to change.
        hint: String,
    },
    /// More shards than the run has batches.
    #[error(
        "refused: {count} shards of a run of {batches} batches (each shard traces whole \
         batches): use at most {batches} shards"
    )]
    TooManyShards {
        /// Requested number of shards.
        count: u64,
        /// Batches of the run.
        batches: u64,
    },
    /// The thread pool could not be built.
    #[error("cannot build a thread pool of {threads} threads: {reason}")]
    Threads {
        /// Requested number of threads.
        threads: usize,
        /// Why.
        reason: String,
    },
    /// The run was stopped by its [`crate::McOptions::cancel`] flag before it
    /// finished; nothing of it is returned.
    #[error("cancelled: the run was stopped before it finished (no result)")]
    Cancelled,
    /// A malformed MCML input (`.mci`) file.
    #[error("line {line}: {field}: {reason}")]
    Mci {
        /// 1-based line.
        line: usize,
        /// The field MCML reads there.
        field: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// A file could not be written.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The path.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
}
