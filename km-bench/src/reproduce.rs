//! `km reproduce`: run every recipe, write the charts, the CSV files and
//! `report.md`, and return a short [`Summary`].

use std::fmt;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;

pub use crate::context::{Ctx, Recipe, Size};
use crate::recipes;
use crate::report::{Report, Section, Table};
use km_plot::chart::ChartLayout;

/// `km reproduce`'s request (with the feature `clap`, its flags; also what
/// `km` alone runs): [`ReproduceRequest::options`] makes the
/// [`ReproduceOptions`] of it.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct ReproduceRequest {
    /// Output directory.
    #[cfg_attr(feature = "clap", arg(long, default_value = "out", help = "Output directory"))]
    pub out: PathBuf,
    /// The quick run (the default).
    #[cfg_attr(
        feature = "clap",
        arg(long, conflicts_with = "full", help = "Quick run (under two minutes; the default)")
    )]
    pub quick: bool,
    /// The paper-scale run.
    #[cfg_attr(
        feature = "clap",
        arg(
            long,
            help = "Paper-scale run (10^5 Monte Carlo samples per direction, all directions)"
        )
    )]
    pub full: bool,
    /// Seed of the Monte Carlo runs.
    #[cfg_attr(
        feature = "clap",
        arg(long, default_value_t = 1, help = "Seed of the Monte Carlo runs")
    )]
    pub seed: u64,
    /// No progress on stderr.
    #[cfg_attr(
        feature = "clap",
        arg(long, help = "No progress on stderr (it is also off when stderr is not a terminal)")
    )]
    pub quiet: bool,
    /// One recipe only ([`recipe_names`]).
    #[cfg_attr(
        feature = "clap",
        arg(
            long,
            value_name = "NAME",
            help = "Regenerate one figure or study only (fig3, fig4, fig5, fig6, fig7, fig9, fig10, speedup, dipole, diffusion-limits, pareto, stability, savings, paint, rough-lobes); its section goes to DIR/report-NAME.md"
        )
    )]
    pub only: Option<String>,
}

impl ReproduceRequest {
    /// The options of [`reproduce`] for this request.
    pub fn options(&self) -> ReproduceOptions {
        let out = self.out.clone();
        let base =
            if self.full { ReproduceOptions::full(out) } else { ReproduceOptions::quick(out) };
        ReproduceOptions { seed: self.seed, quiet: self.quiet, only: self.only.clone(), ..base }
    }
}

/// Options of [`reproduce`].
#[derive(Debug, Clone, PartialEq)]
pub struct ReproduceOptions {
    /// Directory for `report.md`, the charts and the CSV files (created if absent).
    pub out_dir: PathBuf,
    /// `true`: the quick run (under two minutes); `false`: the full run.
    pub quick: bool,
    /// Overrides `quick`: the toy size used by the tests.
    pub tiny: bool,
    /// Seed of every Monte Carlo run (each run derives its own from it).
    pub seed: u64,
    /// No progress bar on stderr (it is also off when stderr is not a terminal).
    pub quiet: bool,
    /// Run only the recipe of this name (see [`recipe_names`]); its section
    /// goes to `report-NAME.md`, leaving `report.md` of a full run untouched.
    pub only: Option<String>,
}

impl ReproduceOptions {
    /// Quick run into `out_dir` (seed 1).
    pub fn quick(out_dir: impl Into<PathBuf>) -> Self {
        ReproduceOptions {
            out_dir: out_dir.into(),
            quick: true,
            tiny: false,
            seed: 1,
            quiet: false,
            only: None,
        }
    }
    /// Full (paper-scale) run into `out_dir`.
    pub fn full(out_dir: impl Into<PathBuf>) -> Self {
        ReproduceOptions { quick: false, ..Self::quick(out_dir) }
    }
    /// Toy-size run into `out_dir` (tests).
    pub fn tiny(out_dir: impl Into<PathBuf>) -> Self {
        ReproduceOptions { tiny: true, ..Self::quick(out_dir) }
    }
    /// The effective size.
    pub fn size(&self) -> Size {
        if self.tiny {
            Size::Tiny
        } else if self.quick {
            Size::Quick
        } else {
            Size::Full
        }
    }
}

/// One line of the summary: a recipe, whether it ran, and its key result.
#[derive(Debug, Clone, PartialEq)]
pub struct SummaryRow {
    /// Recipe name (e.g. `fig6`).
    pub item: String,
    /// `ok`, `skipped` or `failed`.
    pub status: String,
    /// Its key numbers, in words.
    pub result: String,
    /// Wall time of the recipe, seconds.
    pub seconds: f64,
    /// Numbers that rest on an extrapolation (kept apart from `result`,
    /// which quotes measured numbers only); empty when none.
    pub extrapolated: String,
}

/// What [`reproduce`] did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Summary {
    /// One row per recipe.
    pub rows: Vec<SummaryRow>,
    /// Path of `report.md`.
    pub report: PathBuf,
    /// Total wall time, seconds.
    pub seconds: f64,
    /// Size name.
    pub size: String,
    /// The layout of every chart written, in order (for checks of the drawing).
    pub charts: Vec<ChartLayout>,
}

impl Summary {
    /// Number of failed recipes.
    pub fn failures(&self) -> usize {
        self.rows.iter().filter(|r| r.status == "failed").count()
    }

    /// `Ok` when no recipe failed.
    ///
    /// # Errors
    /// The number of failed recipes (their reasons are in the report).
    pub fn check(&self) -> anyhow::Result<()> {
        match self.failures() {
            0 => Ok(()),
            n => anyhow::bail!("{n} item(s) of the reproduction failed (see the report)"),
        }
    }
}

impl fmt::Display for Summary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let w = self.rows.iter().map(|r| r.item.len()).max().unwrap_or(4).max(4);
        writeln!(f, "{:<w$}  {:<7}  {:>8}  result", "item", "status", "seconds")?;
        for r in &self.rows {
            writeln!(f, "{:<w$}  {:<7}  {:>8.2}  {}", r.item, r.status, r.seconds, r.result)?;
            if !r.extrapolated.is_empty() {
                writeln!(f, "{:<w$}  {:<7}  {:>8}  extrapolated: {}", "", "", "", r.extrapolated)?;
            }
        }
        writeln!(
            f,
            "{} run: {:.1} s in total; report: {}",
            self.size,
            self.seconds,
            self.report.display()
        )
    }
}

/// A step of [`reproduce_with_progress`], reported to its callback.
#[derive(Debug, Clone, PartialEq)]
pub enum Progress {
    /// Recipe `index` (from 0) of `total` starts.
    Start {
        /// Position of the recipe in this run.
        index: usize,
        /// Number of recipes in this run.
        total: usize,
        /// Recipe name.
        name: String,
    },
    /// Recipe `index` of `total` ended.
    Done {
        /// Position of the recipe in this run.
        index: usize,
        /// Number of recipes in this run.
        total: usize,
        /// Recipe name.
        name: String,
        /// `ok` or `failed`.
        status: String,
        /// Wall time of the recipe, seconds.
        seconds: f64,
    },
}

/// The names `ReproduceOptions::only` accepts, in report order.
pub fn recipe_names() -> Vec<&'static str> {
    recipes::all().iter().map(|r| r.0).collect()
}

/// Run every recipe into `opts.out_dir`, write `report.md`, return the summary.
///
/// Shows a progress bar per figure on stderr (indicatif) unless
/// `opts.quiet` is set or stderr is not a terminal; see
/// [`reproduce_with_progress`] to receive the steps instead.
///
/// # Errors
/// As [`reproduce_with_progress`].
pub fn reproduce(opts: &ReproduceOptions) -> anyhow::Result<Summary> {
    if opts.quiet || !std::io::stderr().is_terminal() {
        return reproduce_with_progress(opts, &mut |_| {});
    }
    let total = if opts.only.is_some() { 1 } else { recipes::all().len() as u64 };
    let bar = indicatif::ProgressBar::new(total);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{prefix} [{bar:30}] {pos}/{len} {msg} ({elapsed})",
        )
        .map_err(|e| anyhow::anyhow!("progress bar template: {e}"))?
        .progress_chars("=> "),
    );
    bar.set_prefix("km reproduce");
    let summary = reproduce_with_progress(opts, &mut |p| match p {
        Progress::Start { index, total, name } => {
            bar.set_length(*total as u64);
            bar.set_position(*index as u64);
            bar.set_message(name.clone());
        }
        Progress::Done { index, name, status, seconds, .. } => {
            bar.set_position(*index as u64 + 1);
            bar.println(format!("{name}: {status} in {seconds:.1} s"));
        }
    });
    bar.finish_and_clear();
    summary
}

/// [`reproduce`] with each recipe's start and end passed to `on_progress`
/// (no progress bar of its own).
///
/// A recipe that fails does not stop the others: its section in the report
/// and its summary row state the error. With `opts.only`, only that recipe
/// runs and its section is written to `report-NAME.md`.
///
/// # Errors
/// `opts.only` names no recipe, the output directory cannot be created or
/// the report cannot be written.
pub fn reproduce_with_progress(
    opts: &ReproduceOptions,
    on_progress: &mut dyn FnMut(&Progress),
) -> anyhow::Result<Summary> {
    let start = Instant::now();
    let mut selected = recipes::all();
    if let Some(only) = &opts.only {
        selected.retain(|r| r.0 == only.as_str());
        if selected.is_empty() {
            anyhow::bail!(
                "no figure or study named \"{only}\"; the names are: {}",
                recipe_names().join(", ")
            );
        }
    }
    // A whole run is written into a staging directory beside the target and
    // renamed into place only when complete, so a killed run, a full disk or
    // a failed write never leaves a half report, and two runs never mix;
    // `--only` adds one item's files to an existing run's directory.
    let target = &opts.out_dir;
    let dir = match &opts.only {
        Some(_) => {
            std::fs::create_dir_all(target)
                .with_context(|| format!("creating {}", target.display()))?;
            target.clone()
        }
        None => staging_dir(target)?,
    };
    // Writable before any computing (a read-only directory was found only
    // after 34-43 s of work): write and remove a probe file.
    let probe = dir.join(".km-write-probe");
    km_core::atomic_file::write_atomic(&probe, b"")
        .and_then(|()| std::fs::remove_file(&probe))
        .with_context(|| format!("{} is not writable", dir.display()))?;
    let run = run_recipes(opts, &dir, selected, on_progress, start);
    match (&opts.only, run) {
        (Some(_), run) => run,
        (None, Ok(summary)) => {
            std::fs::write(dir.join(MANIFEST), manifest(opts, &summary))
                .and_then(|()| replace_dir(&dir, target))
                .with_context(|| format!("moving the finished run into {}", target.display()))
                .inspect_err(|_| {
                    let _ = std::fs::remove_dir_all(&dir);
                })?;
            let mut summary = summary;
            summary.report = target.join("report.md");
            Ok(summary)
        }
        (None, Err(e)) => {
            let _ = std::fs::remove_dir_all(&dir);
            Err(e)
        }
    }
}

/// The file that marks a directory as a complete `km reproduce` run.
pub const MANIFEST: &str = ".km-reproduce";

/// The manifest: size, seed and items of the run.
fn manifest(opts: &ReproduceOptions, summary: &Summary) -> String {
    let items: Vec<String> =
        summary.rows.iter().map(|r| format!("{} {}", r.item, r.status)).collect();
    format!("km reproduce\nsize {}\nseed {}\n{}\n", summary.size, opts.seed, items.join("\n"))
}

/// A new, empty staging directory beside `target` (same file system, so the
/// final rename is atomic); refuses a `target` that exists and is not a
/// directory written by `km reproduce` (nothing of the user's is replaced).
fn staging_dir(target: &Path) -> anyhow::Result<PathBuf> {
    if let Ok(meta) = std::fs::symlink_metadata(target) {
        let ours = meta.is_dir()
            && (target.join(MANIFEST).is_file()
                || target.join("report.md").is_file()
                || std::fs::read_dir(target).is_ok_and(|mut d| d.next().is_none()));
        if !ours {
            anyhow::bail!(
                "{} exists and is not the output of an earlier `km reproduce` (no {MANIFEST} \
                 or report.md in it): choose another --out or remove it",
                target.display()
            );
        }
    }
    let parent = match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    std::fs::create_dir_all(&parent).with_context(|| format!("creating {}", parent.display()))?;
    let name = target.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let staging = parent.join(format!(".{name}.partial-{}", std::process::id()));
    if staging.exists() {
        std::fs::remove_dir_all(&staging)
            .with_context(|| format!("removing the stale {}", staging.display()))?;
    }
    std::fs::create_dir(&staging)
        .with_context(|| format!("{} is not writable", parent.display()))?;
    Ok(staging)
}

/// Put the finished run `staging` at `target`, replacing an earlier run.
fn replace_dir(staging: &Path, target: &Path) -> std::io::Result<()> {
    if target.exists() {
        std::fs::remove_dir_all(target)?;
    }
    std::fs::rename(staging, target)
}

/// Every selected recipe into `dir`, then the report.
fn run_recipes(
    opts: &ReproduceOptions,
    dir: &Path,
    selected: Vec<Recipe>,
    on_progress: &mut dyn FnMut(&Progress),
    start: Instant,
) -> anyhow::Result<Summary> {
    let size = opts.size();
    let mut ctx = Ctx::new(dir, size, opts.seed);
    let mut report = Report {
        title: "km: the seed paper's §4 reproduced, and what accuracy costs in time".into(),
        intro: vec![intro(size, opts.seed)],
        sections: Vec::new(),
    };
    let mut summary = Summary { size: size.name().into(), ..Default::default() };
    let total = selected.len();
    for (index, (name, recipe)) in selected.into_iter().enumerate() {
        on_progress(&Progress::Start { index, total, name: name.into() });
        let t = Instant::now();
        ctx.headline.clear();
        ctx.extrapolated.clear();
        let (status, section) = match recipe(&mut ctx) {
            Ok(sec) => ("ok", sec),
            Err(e) => {
                let mut sec = Section::new(format!("{name} (failed)"));
                sec.text(format!("This item failed at run time: `{e:#}`."));
                ctx.headline = format!("{e:#}");
                ("failed", sec)
            }
        };
        let seconds = t.elapsed().as_secs_f64();
        on_progress(&Progress::Done {
            index,
            total,
            name: name.into(),
            status: status.into(),
            seconds,
        });
        summary.rows.push(SummaryRow {
            item: name.into(),
            status: status.into(),
            result: ctx.headline.clone(),
            seconds,
            extrapolated: ctx.extrapolated.clone(),
        });
        report.sections.push(section);
    }
    summary.seconds = start.elapsed().as_secs_f64();
    summary.charts = std::mem::take(ctx.layouts.get_mut().unwrap_or_else(|e| e.into_inner()));
    // The run's own summary table.
    let mut sec = Section::new("Run summary");
    let mut t = Table::new(&[
        "item",
        "status",
        "seconds",
        "result (measured)",
        "extrapolated (not measured)",
    ]);
    for r in &summary.rows {
        t.push(vec![
            r.item.clone(),
            r.status.clone(),
            format!("{:.2}", r.seconds),
            r.result.clone(),
            r.extrapolated.clone(),
        ]);
    }
    sec.text(format!(
        "Every number in this report was computed by this run ({} size, {:.1} s wall time in total, \
         {} threads available).",
        size.name(),
        summary.seconds,
        rayon::current_num_threads()
    ))
    .table(t);
    // The summary opens the report: each item's key result, then the details.
    report.sections.insert(0, sec);
    summary.report = match &opts.only {
        None => report.write(dir)?,
        Some(name) => report.write_named(dir, &format!("report-{name}.md"))?,
    };
    Ok(summary)
}

fn intro(size: Size, seed: u64) -> String {
    format!(
        "Generated by `km reproduce` ({} size, Monte Carlo base seed {seed}). Every chart is \
         given as PNG (embedded) and SVG, with the CSV of its data (parameters and seed in its \
         header). Every number in this report was computed by the solvers during this run; \
         numbers quoted from the seed paper (Japanese, §4) appear only in columns labelled \
         \"paper\".",
        size.name()
    )
}
