//! # km-bench: the seed paper reproduced, and what accuracy costs in time
//!
//! [`reproduce()`] runs every recipe of [`recipes`] and writes, into one
//! directory, `report.md` with every chart (PNG and SVG) and table, and the
//! CSV of every chart's data. `km reproduce [--quick | --full]` calls it.
//!
//! * charts: the chart crate's ([`km_plot::chart`]: line charts, polar
//!   plots, heat maps, each drawn as SVG and PNG with an embedded font).
//! * [`data`]: CSV files with the parameters and the seed in their header.
//! * [`report`]: the Markdown report.
//! * [`context`]: what every recipe gets (output directory, run size, seed).
//! * [`km_models`]: two-flux, four-flux and the dipole against converged multi-flux on a grid.
//! * [`methods`]: a method at a setting ([`methods::Setting`]) through the library's solver interface.
//! * [`scenes`]: the scenes of the recipes (the seed's §4.4 example, study scenes).
//! * [`seed`]: the seed's §4.4 example, loaded from `examples/seed-three-layers.toml`,
//!   its three layers alone and combined, and its truncation study.
//! * [`recipes`]: one function per figure of the seed's §4 and per study.
#![deny(missing_docs)]

pub mod context;
pub mod data;
pub mod km_models;
pub mod methods;
pub mod recipes;
pub mod report;
pub mod reproduce;
pub mod scenes;
pub mod seed;

pub use reproduce::{
    Progress, ReproduceOptions, ReproduceRequest, Size, Summary, SummaryRow, recipe_names,
    reproduce, reproduce_with_progress,
};
