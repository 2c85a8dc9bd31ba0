//! Swatches: labelled sRGB patches as an SVG image.

use std::fmt::Write as _;

use super::{ColourError, invalid};

/// One labelled patch of a swatch: an sRGB colour as from [`srgb`](super::srgb).
#[derive(Debug, Clone, PartialEq)]
pub struct Patch {
    /// Caption under the patch (plain text; escaped for SVG).
    pub label: String,
    /// sRGB values; clipped to `[0, 1]` and rounded to 8 bits for display.
    pub srgb: [f64; 3],
}

/// 8-bit sRGB of a patch, clipped to the gamut (`NaN` becomes 0).
pub fn srgb_u8(rgb: [f64; 3]) -> [u8; 3] {
    rgb.map(|c| if c.is_nan() { 0 } else { (c.clamp(0.0, 1.0) * 255.0).round() as u8 })
}

fn escape_xml(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for ch in s.chars() {
        match ch {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            c => out.push(c),
        }
    }
    out
}

/// The most patches of a swatch ([`swatch_svg`]).
pub const MAX_PATCHES: usize = 64;

/// A small SVG image: one 96 x 96 px square per patch in a row, its label
/// and its 8-bit hex colour underneath. A patch outside the sRGB gamut is
/// clipped and marked `(clipped)`.
///
/// # Errors
/// No patch, or more than 64 (a swatch is small by design).
///
/// ```
/// use km_inverse::colour::{Patch, swatch_svg};
/// let svg = swatch_svg(&[Patch { label: "white".into(), srgb: [1.0, 1.0, 1.0] }]).unwrap();
/// assert!(svg.starts_with("<svg") && svg.contains("#ffffff"));
/// ```
pub fn swatch_svg(patches: &[Patch]) -> Result<String, ColourError> {
    const SIZE: usize = 96;
    const GAP: usize = 8;
    if patches.is_empty() || patches.len() > MAX_PATCHES {
        return Err(invalid("patches", patches.len() as f64, "a swatch has 1 to 64 patches"));
    }
    let width = patches.len() * (SIZE + GAP) + GAP;
    let height = SIZE + 2 * GAP + 36;
    let mut s = String::new();
    // Writing to a String cannot fail.
    let _ = writeln!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{width}\" height=\"{height}\" \
         viewBox=\"0 0 {width} {height}\" font-family=\"sans-serif\" font-size=\"11\">"
    );
    let _ = writeln!(s, "<rect width=\"{width}\" height=\"{height}\" fill=\"#ffffff\"/>");
    for (i, p) in patches.iter().enumerate() {
        let [r, g, b] = srgb_u8(p.srgb);
        let hex = format!("#{r:02x}{g:02x}{b:02x}");
        let clipped = p.srgb.iter().any(|c| !(0.0..=1.0).contains(c));
        let x = GAP + i * (SIZE + GAP);
        let _ = writeln!(
            s,
            "<rect x=\"{x}\" y=\"{GAP}\" width=\"{SIZE}\" height=\"{SIZE}\" fill=\"{hex}\" \
             stroke=\"#808080\"/>"
        );
        let ty = GAP + SIZE + 14;
        let _ = writeln!(s, "<text x=\"{x}\" y=\"{ty}\">{}</text>", escape_xml(&p.label));
        let note = if clipped { " (clipped)" } else { "" };
        let _ =
            writeln!(s, "<text x=\"{x}\" y=\"{}\" fill=\"#404040\">{hex}{note}</text>", ty + 14);
    }
    s.push_str("</svg>\n");
    Ok(s)
}
