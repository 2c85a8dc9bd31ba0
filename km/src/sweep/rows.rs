//! The rows of `km sweep` (docs/cli.md): the swept values, the channel, the
//! totals and the BRDF/BTDF columns, as a table, CSV or JSON lines.

use super::{SweepAxis, SweepPoint};

/// How [`sweep_text`] lays out the rows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum SweepFormat {
    /// Aligned columns (22 characters each).
    #[cfg_attr(feature = "clap", value(help = "Aligned columns"))]
    Table,
    /// Comma-separated values with a header.
    Csv,
    /// One JSON object per line.
    Jsonl,
}

/// The five totals of a sweep row, by name.
const SWEEP_QUANTITIES: [&str; 5] =
    ["reflectance", "reflectance_specular", "transmittance", "transmittance_direct", "absorptance"];

/// The columns of a sweep's rows after the swept values and the channel:
/// the totals, their standard errors (Monte Carlo), the BRDF/BTDF values at
/// the scene's `[output]` directions and their standard errors.
struct Columns {
    /// Monte Carlo: standard error columns.
    mc: bool,
    /// BRDF values per row.
    n_brdf: usize,
    /// BTDF values per row (0 when nothing is transmitted at any point).
    n_btdf: usize,
}

impl Columns {
    fn of(points: &[SweepPoint]) -> Columns {
        let sols = || points.iter().map(|p| &p.solution);
        let most = |f: fn(&km_core::ChannelResult) -> usize| {
            sols().flat_map(|s| s.channels.iter().map(f)).max().unwrap_or(0)
        };
        let opaque = sols().all(crate::text::btdf_is_empty);
        Columns {
            mc: sols().any(|s| s.channels.iter().any(|c| c.stderr.is_some())),
            n_brdf: most(|c| c.brdf.len()),
            n_btdf: if opaque { 0 } else { most(|c| c.btdf.len()) },
        }
    }

    fn names(&self) -> Vec<String> {
        let mut h: Vec<String> = SWEEP_QUANTITIES.iter().map(|q| q.to_string()).collect();
        if self.mc {
            h.extend(SWEEP_QUANTITIES.iter().map(|q| format!("stderr_{q}")));
        }
        h.extend((0..self.n_brdf).map(|i| format!("brdf_{i}")));
        h.extend((0..self.n_btdf).map(|i| format!("btdf_{i}")));
        if self.mc {
            h.extend((0..self.n_brdf).map(|i| format!("stderr_brdf_{i}")));
            h.extend((0..self.n_btdf).map(|i| format!("stderr_btdf_{i}")));
        }
        h
    }

    /// The numbers of one channel in the order of [`Columns::names`] (NaN
    /// where a value is missing).
    fn values(&self, c: &km_core::ChannelResult) -> Vec<f64> {
        let mut v =
            vec![c.reflectance, c.reflectance_specular, c.transmittance, c.transmittance_direct];
        v.push(c.absorptance);
        let u = c.stderr.clone().unwrap_or_default();
        if self.mc {
            let se = [
                u.reflectance,
                u.reflectance_specular,
                u.transmittance,
                u.transmittance_direct,
                u.absorptance,
            ];
            v.extend(se.iter().map(|e| e.unwrap_or(f64::NAN)));
        }
        fn list(x: &[f64], n: usize) -> impl Iterator<Item = f64> + '_ {
            (0..n).map(move |i| x.get(i).copied().unwrap_or(f64::NAN))
        }
        v.extend(list(&c.brdf, self.n_brdf));
        v.extend(list(&c.btdf, self.n_btdf));
        if self.mc {
            v.extend(list(u.brdf.as_deref().unwrap_or(&[]), self.n_brdf));
            v.extend(list(u.btdf.as_deref().unwrap_or(&[]), self.n_btdf));
        }
        v
    }
}

/// The rows of `km sweep` (docs/cli.md): the swept values, the channel (for
/// spectral scenes), the five totals, then for Monte Carlo their standard
/// errors, the BRDF/BTDF values at the scene's `[output]` directions
/// (`brdf_I`, `btdf_I`; no BTDF columns when nothing is transmitted) and, for
/// Monte Carlo, theirs; one row per point and channel in grid order, with a
/// header for the table and CSV. Numbers are written as
/// [`crate::text::number`] writes them (round trip, exponent form for small
/// magnitudes).
///
/// ```
/// let text = "[[layer]]\ntau = 1\nalbedo = 0.9\n";
/// let axes = [km::SweepAxis::parse("layer[1].g=0:0.5:2").unwrap()];
/// let pts = km::sweep(text, &[], &axes, &km::Options::new(km::Method::Km)).unwrap();
/// let csv = km::sweep_text(&axes, &pts, km::SweepFormat::Csv);
/// assert_eq!(csv.lines().count(), 3);
/// assert!(csv.starts_with("layer[1].g,reflectance,"));
/// ```
pub fn sweep_text(axes: &[SweepAxis], points: &[SweepPoint], format: SweepFormat) -> String {
    let mut out = String::new();
    let mut line = |l: String| {
        out.push_str(&l);
        out.push('\n');
    };
    let spectral = points.first().is_some_and(|p| p.solution.channels.len() > 1);
    let cols = Columns::of(points);
    let mut header: Vec<String> = axes.iter().map(|a| a.key.clone()).collect();
    if spectral {
        header.push("channel".into());
    }
    let names = cols.names();
    header.extend(names.iter().cloned());
    let column =
        |cells: &[String]| cells.iter().map(|c| format!("{c:>22}")).collect::<Vec<_>>().join(" ");
    match format {
        SweepFormat::Csv => line(header.join(",")),
        SweepFormat::Table => line(column(&header)),
        SweepFormat::Jsonl => {}
    }
    for p in points {
        for (c, ch) in p.solution.channels.iter().enumerate() {
            let nums = cols.values(ch);
            let label = p.solution.labels.get(c).cloned().unwrap_or_default();
            if format == SweepFormat::Jsonl {
                let mut o = serde_json::Map::new();
                for (a, v) in axes.iter().zip(&p.values) {
                    o.insert(a.key.clone(), (*v).into());
                }
                if spectral {
                    o.insert("channel".into(), label.into());
                }
                for (q, v) in names.iter().zip(nums) {
                    o.insert(
                        q.clone(),
                        if v.is_nan() { serde_json::Value::Null } else { v.into() },
                    );
                }
                line(serde_json::Value::Object(o).to_string());
                continue;
            }
            let mut cells: Vec<String> = p.values.iter().map(|v| crate::text::number(*v)).collect();
            if spectral {
                cells.push(label);
            }
            cells.extend(
                nums.iter()
                    .map(|v| if v.is_nan() { String::new() } else { crate::text::number(*v) }),
            );
            line(if format == SweepFormat::Csv { cells.join(",") } else { column(&cells) });
        }
    }
    out
}

/// Rows of text cells under a header, laid out as [`sweep_text`] lays out
/// its own: columns of `width` characters, CSV, or JSON lines (a cell that
/// reads as a number is one, an empty cell is null); one row per line
/// (`km sweep --colour`).
pub fn cells_text(
    header: &[String],
    rows: &[Vec<String>],
    format: SweepFormat,
    width: usize,
) -> String {
    let column = |cells: &[String]| {
        cells.iter().map(|c| format!("{c:>width$}")).collect::<Vec<_>>().join(" ")
    };
    let mut out = match format {
        SweepFormat::Csv => header.join(",") + "\n",
        SweepFormat::Table => column(header) + "\n",
        SweepFormat::Jsonl => String::new(),
    };
    for cells in rows {
        out.push_str(&match format {
            SweepFormat::Csv => cells.join(","),
            SweepFormat::Table => column(cells),
            SweepFormat::Jsonl => {
                let mut o = serde_json::Map::new();
                for (h, c) in header.iter().zip(cells) {
                    let v = c.parse::<f64>().map_or_else(|_| c.as_str().into(), |x| x.into());
                    o.insert(h.clone(), if c.is_empty() { serde_json::Value::Null } else { v });
                }
                serde_json::Value::Object(o).to_string()
            }
        });
        out.push('\n');
    }
    out
}
