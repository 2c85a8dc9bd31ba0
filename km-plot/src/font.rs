//! The embedded font of every chart.
//!
//! plotters is built without its system-font feature (no fontconfig or
//! freetype at build time), so text is drawn with `ab_glyph` from a font
//! registered in memory. The font is DejaVu Sans (Bitstream Vera licence,
//! text in `assets/DejaVuSans-LICENSE.txt`), embedded in the binary.

use std::sync::OnceLock;

use plotters::style::{FontStyle, register_font};

/// DejaVu Sans, embedded.
static DEJAVU_SANS: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// The embedded font's bytes (for the SVG rasteriser).
pub(crate) static FONT: &[u8] = DEJAVU_SANS;

/// The embedded font's family name.
pub(crate) const FAMILY: &str = "DejaVu Sans";

static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();

/// Register the embedded font under the generic family names plotters uses
/// (`sans-serif`, `serif`, `monospace`), once per process.
///
/// # Errors
/// The embedded font could not be parsed (never expected).
pub fn ensure_registered() -> anyhow::Result<()> {
    let r = REGISTERED.get_or_init(|| {
        for family in ["sans-serif", "serif", "monospace"] {
            for style in [FontStyle::Normal, FontStyle::Bold, FontStyle::Italic, FontStyle::Oblique]
            {
                register_font(family, style, DEJAVU_SANS)
                    .map_err(|_| "embedded DejaVu Sans font is invalid".to_string())?;
            }
        }
        Ok(())
    });
    r.clone().map_err(anyhow::Error::msg)
}
