//! `--colour` and `--swatch` of `km solve` and `km sweep`: the colour of a
//! spectral scene's reflectance and transmittance spectra (CIE XYZ and
//! CIELAB under D65 with the CIE 1931 2° observer, sRGB), computed and
//! written by `km_inverse::colour::report` (docs/colour.md), and a swatch
//! of them as SVG.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow};
use km::Solution;
use km_inverse::colour::report::{SpectrumColour, solution_colours, sweep_colour_columns};
pub use km_inverse::colour::report::{colours_json as json, colours_text as table_lines};
use km_inverse::colour::{self, Patch};

/// The colour flags (shared by `km solve` and `km sweep`; no doc comment:
/// it would become the command's about).
#[derive(clap::Args, Debug, Clone)]
pub struct ColourArgs {
    /// Also give the colour of the reflectance (and transmittance) spectrum of a spectral
    /// scene: CIE XYZ, CIELAB (D65, CIE 1931 2°) and sRGB (docs/colour.md).
    #[arg(long)]
    pub colour: bool,
    /// Write the colours as an SVG swatch to this file, atomically (with --colour).
    #[arg(long, value_name = "FILE", requires = "colour")]
    pub swatch: Option<PathBuf>,
}

/// The wavelengths of a spectral scene, or the refusal of `--colour`.
pub fn wavelengths(scene: &km::Scene) -> Result<Vec<f64>> {
    colour::report::spectral_wavelengths(scene).map_err(|e| anyhow!("--colour {e}"))
}

/// The colours of a solution's reflectance and (when anything is
/// transmitted) transmittance spectra, named `reflectance`, `transmittance`.
pub fn of_solution(w: &[f64], sol: &Solution) -> Result<Vec<(&'static str, SpectrumColour)>> {
    solution_colours(w, sol).map_err(|e| anyhow!("--colour: {e}"))
}

/// Write `patches` as an SVG swatch to `path`, atomically, never over one of `inputs`.
pub fn write_swatch(path: &Path, patches: &[Patch], inputs: &[PathBuf]) -> Result<()> {
    let svg = colour::swatch_svg(patches).map_err(|e| anyhow!("--swatch: {e}"))?;
    let opts = km::atomic_file::WriteOptions { inputs: inputs.to_vec(), ..Default::default() };
    km::atomic_file::write_atomic_with(path, svg.as_bytes(), &opts)
        .with_context(|| format!("--swatch: cannot write {}", path.display()))
}

/// `km sweep --colour`: one row per point: the swept values, then the
/// colour columns (`km_inverse::colour::report::sweep_colour_columns`);
/// with the swatch's patches (one per point, reflectance).
pub fn sweep_text(
    axes: &[km::SweepAxis],
    points: &[km::SweepPoint],
    wavelengths: &[f64],
    format: km::SweepFormat,
) -> Result<(String, Vec<Patch>)> {
    let (names, columns) = sweep_colour_columns(wavelengths, points.iter().map(|p| &p.solution))
        .map_err(|e| anyhow!("--colour: {e}"))?;
    let header: Vec<String> = axes.iter().map(|a| a.key.clone()).chain(names).collect();
    let (mut rows, mut patches) = (Vec::new(), Vec::new());
    for (p, (cells, colour)) in points.iter().zip(columns) {
        let label: Vec<String> =
            axes.iter().zip(&p.values).map(|(a, v)| format!("{}={v}", a.key)).collect();
        patches.push(colour.patch(label.join(" ")));
        rows.push(p.values.iter().map(|v| km::text::number(*v)).chain(cells).collect());
    }
    Ok((km::sweep::cells_text(&header, &rows, format, 14), patches))
}
