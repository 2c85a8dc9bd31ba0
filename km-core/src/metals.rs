//! Named metals: spectral complex refractive index `n + i k` of Al, Ag, Au,
//! Cu and Cr, from a cited table (`km-core/data/metals_nk.csv`: the Luxpop
//! compilation of Palik's *Handbook of Optical Constants of Solids*, the
//! tables Mitsuba 3's conductor presets use), interpolated linearly in
//! wavelength (docs/rough.md §5).

use std::sync::OnceLock;

use crate::error::CoreError;

/// The table, embedded at build time (rows `metal,wavelength_nm,n,k`).
const TABLE: &str = include_str!("../data/metals_nk.csv");

/// The metals of the table, in the scene file's spelling.
pub const METALS: [&str; 5] = ["Al", "Ag", "Au", "Cu", "Cr"];

/// One metal's rows: wavelength (nm, ascending), n, k.
type Rows = Vec<(f64, f64, f64)>;

fn table() -> &'static Vec<(&'static str, Rows)> {
    static PARSED: OnceLock<Vec<(&'static str, Rows)>> = OnceLock::new();
    PARSED.get_or_init(|| {
        let mut out: Vec<(&'static str, Rows)> = METALS.iter().map(|m| (*m, Vec::new())).collect();
        for line in TABLE.lines().filter(|l| !l.starts_with('#') && !l.starts_with("metal")) {
            let f: Vec<&str> = line.split(',').collect();
            let (Some(slot), [_, w, n, k]) = (out.iter_mut().find(|(m, _)| *m == f[0]), &f[..])
            else {
                continue;
            };
            // The table is part of the source: a malformed row is a build defect
            // caught by the tests below, skipped here rather than panicking.
            if let (Ok(w), Ok(n), Ok(k)) = (w.parse(), n.parse(), k.parse()) {
                slot.1.push((w, n, k));
            }
        }
        for (_, rows) in &mut out {
            rows.sort_by(|a, b| a.0.total_cmp(&b.0));
        }
        out
    })
}

/// The wavelength range (nm) of a metal's table, `None` for an unknown name.
pub fn range_nm(metal: &str) -> Option<(f64, f64)> {
    let rows = &table().iter().find(|(m, _)| *m == metal)?.1;
    Some((rows.first()?.0, rows.last()?.0))
}

/// Complex index `(n, k)` of `metal` at `wavelength_nm`, linear between the
/// table's rows.
///
/// # Errors
/// A [`CoreError::Invalid`] for an unknown metal or a wavelength outside the
/// table's range (no extrapolation).
///
/// ```
/// let (n, k) = km_core::metals::nk("Au", 551.040771).unwrap();
/// assert!((n - 0.3455).abs() < 1e-9 && (k - 2.730625).abs() < 1e-9);
/// assert!(km_core::metals::nk("Au", 100.0).is_err());
/// assert!(km_core::metals::nk("Pt", 500.0).is_err());
/// ```
pub fn nk(metal: &str, wavelength_nm: f64) -> Result<(f64, f64), CoreError> {
    let Some((_, rows)) = table().iter().find(|(m, _)| *m == metal) else {
        return Err(CoreError::scene(
            "substrate.metal",
            None,
            format!("unknown metal \"{metal}\" (known: {})", METALS.join(", ")),
        ));
    };
    let (lo, hi) = (rows[0].0, rows[rows.len() - 1].0);
    if !(wavelength_nm >= lo && wavelength_nm <= hi) {
        return Err(CoreError::invalid(
            "spectrum.wavelengths_nm",
            wavelength_nm,
            "outside the metal table's range (about 299-886 nm, docs/rough.md §5)",
        ));
    }
    // The first row at or beyond the wavelength, and its predecessor.
    let j = rows.partition_point(|r| r.0 < wavelength_nm).clamp(1, rows.len() - 1);
    let (a, b) = (rows[j - 1], rows[j]);
    let t = if b.0 > a.0 { (wavelength_nm - a.0) / (b.0 - a.0) } else { 0.0 };
    Ok((a.1 + t * (b.1 - a.1), a.2 + t * (b.2 - a.2)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_metal_has_a_sorted_visible_table() {
        for m in METALS {
            let rows = &table().iter().find(|(x, _)| *x == m).unwrap().1;
            assert!(rows.len() >= 25, "{m}: {} rows", rows.len());
            let (lo, hi) = range_nm(m).unwrap();
            assert!(lo < 380.0 && hi > 780.0, "{m}: {lo}-{hi}");
            assert!(rows.iter().all(|r| r.1 > 0.0 && r.2 > 0.0));
        }
        // Spot values (rows of the table, Palik via Luxpop): silver is a good
        // mirror in the visible (n << k), chromium is not.
        let (n, k) = nk("Ag", 600.0).unwrap();
        assert!(n < 0.2 && k > 3.0, "{n} {k}");
        let (n, k) = nk("Cr", 600.0).unwrap();
        assert!(n > 2.5 && k > 3.0, "{n} {k}");
    }

    #[test]
    fn interpolation_is_linear_between_rows() {
        let rows = &table().iter().find(|(x, _)| *x == "Cu").unwrap().1;
        let (a, b) = (rows[10], rows[11]);
        let mid = 0.5 * (a.0 + b.0);
        let (n, k) = nk("Cu", mid).unwrap();
        assert!((n - 0.5 * (a.1 + b.1)).abs() < 1e-12);
        assert!((k - 0.5 * (a.2 + b.2)).abs() < 1e-12);
    }
}
