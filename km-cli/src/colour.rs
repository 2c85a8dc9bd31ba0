//! `--colour` and `--swatch` of `km solve` and `km sweep`: the colour of a
//! spectral scene's reflectance and transmittance spectra (CIE XYZ and
//! CIELAB under D65 with the CIE 1931 2° observer, sRGB), computed by
//! `km_inverse::colour` (docs/colour.md), and a swatch of them as SVG.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow, bail};
use km::Solution;
use km_inverse::colour::{self, Illuminant, Observer, Patch, Spectrum, Xyz};
use serde_json::{Value, json};

/// The observer and illuminant of `--colour`.
const OBSERVER: Observer = Observer::Cie1931TwoDegree;
const ILLUMINANT: Illuminant = Illuminant::D65;

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

/// The colour of one spectrum.
#[derive(Debug, Clone, Copy)]
pub struct Colour {
    /// Tristimulus values, `Y = 100` for the perfect reflecting diffuser.
    pub xyz: Xyz,
    /// CIELAB relative to that white.
    pub lab: colour::Lab,
    /// sRGB (encoded, unclipped).
    pub srgb: [f64; 3],
}

impl Colour {
    /// The colour of `values` at `wavelengths_nm`.
    pub fn of(wavelengths_nm: &[f64], values: Vec<f64>) -> Result<Colour> {
        let spectrum = Spectrum::new(wavelengths_nm.to_vec(), values)
            .map_err(|e| anyhow!("--colour: the spectrum: {e}"))?;
        let xyz = colour::xyz(&spectrum, OBSERVER, ILLUMINANT);
        let lab = colour::lab(xyz, colour::white_point(OBSERVER, ILLUMINANT))
            .map_err(|e| anyhow!("--colour: {e}"))?;
        Ok(Colour { xyz, lab, srgb: colour::srgb(xyz) })
    }

    /// `#rrggbb`: 8-bit sRGB, clipped to the gamut.
    pub fn hex(&self) -> String {
        let [r, g, b] = colour::srgb_u8(self.srgb);
        format!("#{r:02x}{g:02x}{b:02x}")
    }

    /// Whether the sRGB lies outside `[0, 1]` by more than half an 8-bit
    /// step (clipping changes the hex; the D65 white, 1.00004 in red, is not).
    pub fn clipped(&self) -> bool {
        let half = 0.5 / 255.0;
        self.srgb.iter().any(|c| !(-half..=1.0 + half).contains(c))
    }

    /// The JSON object: `xyz`, `lab`, `srgb` (the three values), `hex`, `clipped`.
    pub fn to_json(self) -> Value {
        let x = self.xyz;
        let l = self.lab;
        json!({
            "xyz": [x.x, x.y, x.z],
            "lab": [l.l, l.a, l.b],
            "srgb": self.srgb,
            "hex": self.hex(),
            "clipped": self.clipped(),
        })
    }

    /// One line for people.
    pub fn words(&self) -> String {
        let (x, l) = (self.xyz, self.lab);
        // Rounded first, then `+ 0.0`: no `-0.00`.
        let r2 = |v: f64| (v * 100.0).round() / 100.0 + 0.0;
        let l = colour::Lab { l: r2(l.l), a: r2(l.a), b: r2(l.b) };
        format!(
            "XYZ ({:.3}, {:.3}, {:.3})  L*a*b* ({:.2}, {:.2}, {:.2})  sRGB {}{}",
            x.x,
            x.y,
            x.z,
            l.l,
            l.a,
            l.b,
            self.hex(),
            if self.clipped() { " (clipped)" } else { "" }
        )
    }
}

/// The wavelengths of a spectral scene, or the refusal of `--colour`.
pub fn wavelengths(scene: &km::Scene) -> Result<Vec<f64>> {
    match scene.wavelengths_nm() {
        Some(w) if w.len() == scene.channels().len() => Ok(w.to_vec()),
        _ => bail!(
            "--colour needs a spectral scene ([spectrum] wavelengths_nm): the colour is that of \
             a spectrum, and this scene's {} channel(s) have labels, not wavelengths",
            scene.channels().len()
        ),
    }
}

/// The colours of a solution's reflectance and (when anything is
/// transmitted) transmittance spectra, named `reflectance`, `transmittance`.
pub fn of_solution(wavelengths: &[f64], sol: &Solution) -> Result<Vec<(&'static str, Colour)>> {
    let r = sol.channels.iter().map(|c| c.reflectance).collect();
    let mut out = vec![("reflectance", Colour::of(wavelengths, r)?)];
    if sol.channels.iter().any(|c| c.transmittance > 0.0) {
        let t = sol.channels.iter().map(|c| c.transmittance).collect();
        out.push(("transmittance", Colour::of(wavelengths, t)?));
    }
    Ok(out)
}

/// The JSON key `colour` of `km solve`: the colours by name, the observer
/// and the illuminant.
pub fn json(colours: &[(&'static str, Colour)]) -> Value {
    let mut o = serde_json::Map::new();
    o.insert("observer".into(), json!("CIE 1931 2°"));
    o.insert("illuminant".into(), json!("D65"));
    for (name, c) in colours {
        o.insert((*name).into(), c.to_json());
    }
    Value::Object(o)
}

/// The lines of the text table.
pub fn table_lines(colours: &[(&'static str, Colour)]) -> String {
    let mut s = String::from("colour (D65, CIE 1931 2°):\n");
    for (name, c) in colours {
        s.push_str(&format!("  {name:<14}{}\n", c.words()));
    }
    s
}

/// Write `patches` as an SVG swatch to `path`, atomically, never over one of `inputs`.
pub fn write_swatch(path: &Path, patches: &[Patch], inputs: &[PathBuf]) -> Result<()> {
    let svg = colour::swatch_svg(patches).map_err(|e| anyhow!("--swatch: {e}"))?;
    let opts = km::atomic_file::WriteOptions { inputs: inputs.to_vec(), ..Default::default() };
    km::atomic_file::write_atomic_with(path, svg.as_bytes(), &opts)
        .with_context(|| format!("--swatch: cannot write {}", path.display()))
}

/// A swatch patch of a colour.
pub fn patch(label: String, c: &Colour) -> Patch {
    Patch { label, srgb: c.srgb }
}

/// `km sweep --colour`: one row per point: the swept values, then the
/// colour of the reflectance spectrum (`R_X`, `R_Y`, `R_Z`, `R_L`, `R_a`,
/// `R_b`, `R_hex`) and, when some point transmits, the transmittance's
/// (`T_...`); with the swatch's patches (one per point, reflectance).
pub fn sweep_text(
    axes: &[km::SweepAxis],
    points: &[km::SweepPoint],
    wavelengths: &[f64],
    format: km::SweepFormat,
) -> Result<(String, Vec<Patch>)> {
    let per_point: Vec<Vec<(&'static str, Colour)>> =
        points.iter().map(|p| of_solution(wavelengths, &p.solution)).collect::<Result<_>>()?;
    let transmits = per_point.iter().any(|c| c.len() > 1);
    let mut header: Vec<String> = axes.iter().map(|a| a.key.clone()).collect();
    for q in if transmits { &["R", "T"][..] } else { &["R"][..] } {
        header.extend(["X", "Y", "Z", "L", "a", "b", "hex"].map(|k| format!("{q}_{k}")));
    }
    let mut out = String::new();
    match format {
        km::SweepFormat::Csv => out.push_str(&(header.join(",") + "\n")),
        km::SweepFormat::Table => out.push_str(&(column(&header) + "\n")),
        km::SweepFormat::Jsonl => {}
    }
    let mut patches = Vec::new();
    for (p, colours) in points.iter().zip(&per_point) {
        let mut cells: Vec<String> = p.values.iter().map(|v| km::text::number(*v)).collect();
        for (_, c) in colours {
            let (x, l) = (c.xyz, c.lab);
            // `+ 0.0` after rounding: no `-0.000000`.
            let six = |v: f64| format!("{:.6}", (v * 1e6).round() / 1e6 + 0.0);
            cells.extend([x.x, x.y, x.z, l.l, l.a, l.b].map(six));
            cells.push(c.hex());
        }
        if transmits && colours.len() == 1 {
            cells.extend(std::iter::repeat_n(String::new(), 7));
        }
        let label: Vec<String> =
            axes.iter().zip(&p.values).map(|(a, v)| format!("{}={v}", a.key)).collect();
        patches.push(patch(label.join(" "), &colours[0].1));
        out.push_str(&match format {
            km::SweepFormat::Csv => cells.join(","),
            km::SweepFormat::Table => column(&cells),
            km::SweepFormat::Jsonl => {
                let mut o = serde_json::Map::new();
                for (h, c) in header.iter().zip(&cells) {
                    let v = c.parse::<f64>().map_or_else(|_| json!(c), |x| json!(x));
                    o.insert(h.clone(), if c.is_empty() { Value::Null } else { v });
                }
                Value::Object(o).to_string()
            }
        });
        out.push('\n');
    }
    Ok((out, patches))
}

fn column(cells: &[String]) -> String {
    cells.iter().map(|c| format!("{c:>14}")).collect::<Vec<_>>().join(" ")
}
