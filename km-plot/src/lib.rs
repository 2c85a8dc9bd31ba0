//! # km-plot: the charts of the km workspace
//!
//! Every picture the project draws, on plotters: the figures of km-bench's
//! report, `km bsdf --plot`, the fit, field and phase charts of the `km`
//! command. Each chart is drawn once as SVG and rasterised with
//! anti-aliasing into a PNG of the same picture, with an embedded font, so
//! the output is the same on every machine.
//!
//! * [`chart`]: line charts (linear or log axes, also the Pareto charts),
//!   polar plots in the plane of incidence, heat maps; [`chart::write_chart`]
//!   writes `STEM.svg` and `STEM.png` (each under a temporary name, then
//!   renamed) and records where each part was drawn ([`chart::ChartLayout`]).
//! * [`bsdf`]: pictures of a BSDF table (in-plane polar plots, heat maps).
//! * [`check`]: the defects a drawn chart must not have (tick labels,
//!   legend over data, missing error bars, staircase lines), read from its
//!   layout and pixels; tests of every crate that draws charts use it.
//! * [`field`]: the fluence rate and absorbed power density against depth.
//! * [`fit`]: the hiding curves of a Kubelka–Munk drawdown fit.
//! * [`font`]: the embedded font.
//! * [`phase`]: the phase functions of a scene's layers.
#![deny(missing_docs)]

pub mod bsdf;
pub mod chart;
pub mod check;
pub mod field;
pub mod fit;
pub mod font;
pub mod phase;
