//! The colour of a computed spectrum as front ends report it (`km solve
//! --colour`, `km sweep --colour`): CIE XYZ and CIELAB under D65 with the
//! CIE 1931 2° observer, and sRGB; as JSON, as a line for people and as
//! table cells.

use serde_json::{Value, json};

use super::{
    ColourError, Illuminant, Lab, Observer, Patch, Spectrum, Xyz, lab, srgb, srgb_u8, white_point,
    xyz,
};

/// The observer of a [`SpectrumColour`].
pub const OBSERVER: Observer = Observer::Cie1931TwoDegree;
/// The illuminant of a [`SpectrumColour`].
pub const ILLUMINANT: Illuminant = Illuminant::D65;

/// The colour of one spectrum (observer [`OBSERVER`], illuminant [`ILLUMINANT`]).
#[derive(Debug, Clone, Copy)]
pub struct SpectrumColour {
    /// Tristimulus values, `Y = 100` for the perfect reflecting diffuser.
    pub xyz: Xyz,
    /// CIELAB relative to that white.
    pub lab: Lab,
    /// sRGB (encoded, unclipped).
    pub srgb: [f64; 3],
}

/// Which part of a colour computation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ColourStage {
    /// The spectrum itself (wavelengths and values).
    Spectrum,
    /// CIELAB from XYZ.
    Lab,
}

/// A colour that could not be computed: the stage and the error
/// (`the spectrum: ...` for the spectrum, the error alone for CIELAB).
#[derive(Debug, Clone, PartialEq)]
pub struct ColourRefusal(pub ColourStage, pub ColourError);

impl std::fmt::Display for ColourRefusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.0 {
            ColourStage::Spectrum => write!(f, "the spectrum: {}", self.1),
            ColourStage::Lab => write!(f, "{}", self.1),
        }
    }
}

impl std::error::Error for ColourRefusal {}

/// The wavelengths of a spectral scene (one per channel), the spectrum
/// whose colour a front end reports.
///
/// # Errors
/// A scene whose channels are not wavelengths, in words that follow the
/// name of the request (`--colour needs a spectral scene ...`).
pub fn spectral_wavelengths(scene: &km_core::Scene) -> Result<Vec<f64>, String> {
    match scene.wavelengths_nm() {
        Some(w) if w.len() == scene.channels().len() => Ok(w.to_vec()),
        _ => Err(format!(
            "needs a spectral scene ([spectrum] wavelengths_nm): the colour is that of a \
             spectrum, and this scene's {} channel(s) have labels, not wavelengths",
            scene.channels().len()
        )),
    }
}

impl SpectrumColour {
    /// The colour of `values` at `wavelengths_nm`.
    ///
    /// # Errors
    /// An invalid spectrum, or XYZ without a CIELAB value, with the stage
    /// that failed.
    pub fn of(wavelengths_nm: &[f64], values: Vec<f64>) -> Result<SpectrumColour, ColourRefusal> {
        let spectrum = Spectrum::new(wavelengths_nm.to_vec(), values)
            .map_err(|e| ColourRefusal(ColourStage::Spectrum, e))?;
        let xyz = xyz(&spectrum, OBSERVER, ILLUMINANT);
        let lab = lab(xyz, white_point(OBSERVER, ILLUMINANT))
            .map_err(|e| ColourRefusal(ColourStage::Lab, e))?;
        Ok(SpectrumColour { xyz, lab, srgb: srgb(xyz) })
    }

    /// A swatch patch of this colour.
    pub fn patch(&self, label: String) -> Patch {
        Patch { label, srgb: self.srgb }
    }

    /// `#rrggbb`: 8-bit sRGB, clipped to the gamut.
    pub fn hex(&self) -> String {
        let [r, g, b] = srgb_u8(self.srgb);
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
        let l = Lab { l: r2(l.l), a: r2(l.a), b: r2(l.b) };
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

    /// The cells of a table row: X, Y, Z, L*, a*, b* to six decimals, and the hex.
    pub fn cells(&self) -> [String; 7] {
        let (x, l) = (self.xyz, self.lab);
        // `+ 0.0` after rounding: no `-0.000000`.
        let six = |v: f64| format!("{:.6}", (v * 1e6).round() / 1e6 + 0.0);
        let [a, b, c, d, e, f] = [x.x, x.y, x.z, l.l, l.a, l.b].map(six);
        [a, b, c, d, e, f, self.hex()]
    }
}

/// The JSON of named colours: the colours by name, the observer and the illuminant.
pub fn colours_json(colours: &[(&str, SpectrumColour)]) -> Value {
    let mut o = serde_json::Map::new();
    o.insert("observer".into(), json!("CIE 1931 2°"));
    o.insert("illuminant".into(), json!("D65"));
    for (name, c) in colours {
        o.insert((*name).into(), c.to_json());
    }
    Value::Object(o)
}

/// Named colours as lines of text, after a heading.
pub fn colours_text(colours: &[(&str, SpectrumColour)]) -> String {
    let mut s = String::from("colour (D65, CIE 1931 2°):\n");
    for (name, c) in colours {
        s.push_str(&format!("  {name:<14}{}\n", c.words()));
    }
    s
}

/// The colours of a solution's reflectance and (when anything is
/// transmitted) transmittance spectra at `wavelengths_nm` (one per
/// channel), named `reflectance`, `transmittance`.
///
/// # Errors
/// Those of [`SpectrumColour::of`].
pub fn solution_colours(
    wavelengths_nm: &[f64],
    sol: &km_core::Solution,
) -> Result<Vec<(&'static str, SpectrumColour)>, ColourRefusal> {
    let r = sol.channels.iter().map(|c| c.reflectance).collect();
    let mut out = vec![("reflectance", SpectrumColour::of(wavelengths_nm, r)?)];
    if sol.channels.iter().any(|c| c.transmittance > 0.0) {
        let t = sol.channels.iter().map(|c| c.transmittance).collect();
        out.push(("transmittance", SpectrumColour::of(wavelengths_nm, t)?));
    }
    Ok(out)
}

/// The colour columns of a sweep's points (`km sweep --colour`): their
/// names, `R_X`, `R_Y`, `R_Z`, `R_L`, `R_a`, `R_b`, `R_hex` and, when some
/// point transmits, the same `T_...`; and per point its cells (empty
/// `T_...` cells for a point that transmits nothing) and the colour of its
/// reflectance. Every point's colours are computed before any is returned.
///
/// # Errors
/// Those of [`solution_colours`], of the first point that has one.
pub fn sweep_colour_columns<'a>(
    wavelengths_nm: &[f64],
    solutions: impl Iterator<Item = &'a km_core::Solution>,
) -> Result<SweepColumns, ColourRefusal> {
    let per_point: Vec<Vec<(&str, SpectrumColour)>> =
        solutions.map(|s| solution_colours(wavelengths_nm, s)).collect::<Result<_, _>>()?;
    let transmits = per_point.iter().any(|c| c.len() > 1);
    let mut names = Vec::new();
    for q in if transmits { &["R", "T"][..] } else { &["R"][..] } {
        names.extend(["X", "Y", "Z", "L", "a", "b", "hex"].map(|k| format!("{q}_{k}")));
    }
    let rows = per_point
        .iter()
        .map(|colours| {
            let mut cells: Vec<String> = colours.iter().flat_map(|(_, c)| c.cells()).collect();
            if transmits && colours.len() == 1 {
                cells.extend(std::iter::repeat_n(String::new(), 7));
            }
            (cells, colours[0].1)
        })
        .collect();
    Ok((names, rows))
}

/// The column names and, per point, the cells and the reflectance's colour
/// ([`sweep_colour_columns`]).
pub type SweepColumns = (Vec<String>, Vec<(Vec<String>, SpectrumColour)>);
