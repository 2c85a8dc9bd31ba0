//! Progress on stderr of a solve (feature `progress`; `km solve`,
//! docs/cli.md): a bar for a solve
//! expected to last more than [`SHOW_ABOVE_S`] seconds, drawn only when
//! stderr is a terminal and `--quiet` is not given, so that nothing is
//! written to a pipe, a file or a log.
//!
//! Monte Carlo counts the photons traced (the tracer's callback); a
//! multi-flux solve is one dense computation without intermediate counts, so
//! its bar runs against the time expected from its work estimate (eq. W1 at
//! [`SECONDS_PER_UNIT`]); a stream search to a `--tolerance` (whose length
//! depends on where the target is met) shows a spinner with the elapsed time
//! once it has lasted [`SHOW_ABOVE_S`].
//!
//! A library's job rather than the command's: when to show progress and
//! against what depends on the solvers (the tracer's callback, the
//! multi-flux work estimate and its calibration), which live here.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// A solve expected to last longer than this, in seconds, shows progress.
pub const SHOW_ABOVE_S: f64 = 2.0;

/// Seconds per multi-flux work unit (eq. W1) for the expected time: the
/// slowest of the calibration (0.7 ns unloaded, 1.5 to 2.6 ns under load;
/// `km-multiflux/src/budget.rs`), so that a loaded machine still shows it.
pub const SECONDS_PER_UNIT: f64 = 2.6e-9;

/// Whether progress may be drawn: stderr is a terminal and `--quiet` is not given.
pub fn wanted(quiet: bool) -> bool {
    !quiet && std::io::stderr().is_terminal()
}

fn style(template: &str) -> ProgressStyle {
    ProgressStyle::with_template(template).unwrap_or_else(|_| ProgressStyle::default_bar())
}

/// The Monte Carlo callback: photons done of the run's, drawn once the run
/// has lasted half a second and its projection (elapsed over the fraction
/// done) exceeds [`SHOW_ABOVE_S`].
pub fn photons() -> crate::Progress {
    let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::hidden());
    let start = Instant::now();
    let shown = Mutex::new(false);
    crate::Progress::new(move |done, total| {
        let mut shown = shown.lock().unwrap_or_else(|e| e.into_inner());
        let elapsed = start.elapsed().as_secs_f64();
        let projected = elapsed * total as f64 / done.max(1) as f64;
        if !*shown && elapsed > 0.5 && projected > SHOW_ABOVE_S && done < total {
            *shown = true;
            bar.set_length(total);
            bar.set_style(style("mc {bar:40} {human_pos}/{human_len} photons, eta {eta}"));
            bar.set_draw_target(ProgressDrawTarget::stderr());
        }
        bar.set_position(done);
        if done >= total {
            bar.finish_and_clear();
        }
    })
}

/// Progress of a solve of `scene` with `options`, on stderr: Monte Carlo's
/// callback set in `options`, or a multi-flux bar returned (drawn until
/// dropped). Call only when progress is [`wanted`].
pub fn attach(scene: &crate::Scene, options: &mut crate::Options) -> Option<Ticker> {
    let tolerance = options.tolerance.is_some();
    match &mut options.method {
        crate::MethodOptions::Mc(o) => {
            o.progress = Some(photons());
            None
        }
        crate::MethodOptions::Multiflux(o) => Ticker::multiflux(scene, o, tolerance),
        _ => None,
    }
}

/// A bar (or spinner) drawn by its own thread until dropped.
pub struct Ticker {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Ticker {
    /// Progress of a multi-flux solve on `scene` with `opts`: a bar against
    /// the expected time when it exceeds [`SHOW_ABOVE_S`] (`None` below),
    /// or with a `tolerance` a spinner shown once the search has lasted
    /// [`SHOW_ABOVE_S`].
    pub fn multiflux(
        scene: &crate::Scene,
        opts: &crate::MultifluxOptions,
        tolerance: bool,
    ) -> Option<Ticker> {
        if tolerance {
            return Some(Ticker::start(None));
        }
        let expected = crate::multiflux_budget::estimate(scene, opts).units * SECONDS_PER_UNIT;
        (expected > SHOW_ABOVE_S).then(|| Ticker::start(Some(expected)))
    }

    fn start(expected: Option<f64>) -> Ticker {
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let thread = std::thread::spawn(move || {
            let start = Instant::now();
            let bar = match expected {
                Some(s) => {
                    let b = ProgressBar::new((s * 1000.0) as u64);
                    b.set_style(style(&format!(
                        "multiflux {{bar:40}} {{elapsed}} of about {s:.0} s (expected from the \
                         work estimate)"
                    )));
                    b
                }
                None => {
                    let b = ProgressBar::new_spinner();
                    b.set_style(style("multiflux {spinner} stream search, {elapsed}"));
                    b
                }
            };
            bar.set_draw_target(ProgressDrawTarget::hidden());
            while !flag.load(Ordering::Relaxed) {
                let t = start.elapsed();
                if expected.is_some() || t.as_secs_f64() > SHOW_ABOVE_S {
                    bar.set_draw_target(ProgressDrawTarget::stderr());
                }
                // The bar stops short of its end: the estimate is only an estimate.
                let len = bar.length().unwrap_or(0);
                bar.set_position((t.as_millis() as u64).min(len.saturating_sub(len / 100)));
                bar.tick();
                std::thread::sleep(Duration::from_millis(100));
            }
            bar.finish_and_clear();
        });
        Ticker { stop, thread: Some(thread) }
    }
}

impl Drop for Ticker {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
