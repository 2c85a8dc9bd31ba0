//! What every recipe gets ([`Ctx`]: where to write, how big a run, the
//! seed) and what a recipe is ([`Recipe`]).

use std::path::PathBuf;

use crate::data::Csv;
use crate::report::Section;
use km_plot::chart::{Chart, ChartLayout, write_chart_layout};

/// How much work a run does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Size {
    /// Seconds: the CI size (every recipe runs, at toy resolution).
    Tiny,
    /// Under two minutes on a 2-core machine (`km reproduce --quick`).
    Quick,
    /// The paper's scale: Monte Carlo at 10^5 samples per direction over
    /// all directions, studies up to 10^8 samples (`km reproduce --full`).
    Full,
}

impl Size {
    /// Name used in the report.
    pub fn name(&self) -> &'static str {
        match self {
            Size::Tiny => "tiny",
            Size::Quick => "quick",
            Size::Full => "full",
        }
    }

    /// Pick a value by size.
    pub fn pick<T>(&self, tiny: T, quick: T, full: T) -> T {
        match self {
            Size::Tiny => tiny,
            Size::Quick => quick,
            Size::Full => full,
        }
    }
}

/// What every recipe gets: where to write, how big, and the seed.
#[derive(Debug)]
pub struct Ctx {
    /// Output directory.
    pub out_dir: PathBuf,
    /// Run size.
    pub size: Size,
    /// Base seed of the Monte Carlo runs.
    pub seed: u64,
    /// Key result of the current recipe for the summary (set by the recipe).
    pub headline: String,
    /// Numbers of the current recipe that rest on an extrapolation (set by
    /// the recipe), reported apart from the headline.
    pub extrapolated: String,
    /// The layout of every chart written so far.
    pub layouts: std::sync::Mutex<Vec<ChartLayout>>,
}

impl Ctx {
    /// A context writing into `out_dir` (which must exist).
    pub fn new(out_dir: impl Into<PathBuf>, size: Size, seed: u64) -> Self {
        Ctx {
            out_dir: out_dir.into(),
            size,
            seed,
            headline: String::new(),
            extrapolated: String::new(),
            layouts: Default::default(),
        }
    }

    /// Write a chart as `stem.svg` and `stem.png`.
    ///
    /// # Errors
    /// Drawing or file errors.
    pub fn chart(&self, stem: &str, chart: &impl Chart) -> anyhow::Result<()> {
        let (_, layout) = write_chart_layout(&self.out_dir, stem, chart)?;
        self.layouts.lock().unwrap_or_else(|e| e.into_inner()).push(layout);
        Ok(())
    }

    /// Write `stem.csv`, adding the run size and seed to its header.
    ///
    /// # Errors
    /// File errors.
    pub fn csv(&self, stem: &str, csv: &mut Csv) -> anyhow::Result<()> {
        csv.comment(format!("run size = {}, base seed = {}", self.size.name(), self.seed));
        csv.write(&self.out_dir, stem).map(|_| ())
    }
}

/// A recipe: a name and the function that computes, draws and describes it.
pub type Recipe = (&'static str, fn(&mut Ctx) -> anyhow::Result<Section>);
