//! CSV files of every figure's data, with the parameters and the seed in a
//! header of `#` comment lines, so that a figure can be redrawn or checked
//! without rerunning the solvers.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Context;

/// A table of data with named columns and comment lines.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Csv {
    /// Header comments (parameters, seed, units), one per line, without `#`.
    pub comments: Vec<String>,
    /// Column names.
    pub columns: Vec<String>,
    /// Rows of cells (numbers already rendered, or text).
    pub rows: Vec<Vec<String>>,
}

impl Csv {
    /// An empty CSV with these columns.
    pub fn new(columns: &[&str]) -> Self {
        Csv {
            comments: Vec::new(),
            columns: columns.iter().map(|s| s.to_string()).collect(),
            rows: Vec::new(),
        }
    }

    /// Add a comment line.
    pub fn comment(&mut self, c: impl Into<String>) -> &mut Self {
        self.comments.push(c.into());
        self
    }

    /// Add a row of numbers (full precision, `{:e}` form for round trip).
    pub fn push_nums(&mut self, row: &[f64]) {
        self.rows.push(row.iter().map(|v| num(*v)).collect());
    }

    /// Add a row of text cells.
    pub fn push(&mut self, row: Vec<String>) {
        self.rows.push(row);
    }

    /// The CSV text.
    pub fn render(&self) -> String {
        let mut s = String::new();
        for c in &self.comments {
            for line in c.lines() {
                let _ = writeln!(s, "# {line}");
            }
        }
        let _ =
            writeln!(s, "{}", self.columns.iter().map(|c| quote(c)).collect::<Vec<_>>().join(","));
        for r in &self.rows {
            let _ = writeln!(s, "{}", r.iter().map(|c| quote(c)).collect::<Vec<_>>().join(","));
        }
        s
    }

    /// Write to `dir/stem.csv`.
    ///
    /// # Errors
    /// File errors.
    pub fn write(&self, dir: &Path, stem: &str) -> anyhow::Result<PathBuf> {
        let p = dir.join(format!("{stem}.csv"));
        std::fs::write(&p, self.render()).with_context(|| format!("writing {}", p.display()))?;
        Ok(p)
    }
}

/// A number for a CSV cell: an integral value below 1e15 as an integer
/// (`2`, not `2e0`: settings such as stream counts read as what they are),
/// otherwise the shortest round-trip form (`1e-1`); empty for NaN.
pub fn num(v: f64) -> String {
    if v.is_nan() {
        String::new()
    } else if v.fract() == 0.0 && v.abs() < 1e15 {
        format!("{}", v as i64)
    } else {
        format!("{v:e}")
    }
}

/// Quote a cell when it holds a comma, a quote or a newline (RFC 4180).
fn quote(c: &str) -> String {
    if c.contains([',', '"', '\n']) {
        format!("\"{}\"", c.replace('"', "\"\""))
    } else {
        c.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_has_comments_header_and_round_trip_numbers() {
        let mut c = Csv::new(&["x", "label"]);
        c.comment("seed = 7");
        c.push(vec![num(0.1), "a,b".into()]);
        let s = c.render();
        assert_eq!(s, "# seed = 7\nx,label\n1e-1,\"a,b\"\n");
        assert_eq!("1e-1".parse::<f64>().unwrap(), 0.1);
    }

    #[test]
    fn integers_are_written_as_integers_and_everything_round_trips() {
        assert_eq!(num(2.0), "2");
        assert_eq!(num(-0.0), "0");
        assert_eq!(num(1e6), "1000000");
        assert_eq!(num(1e20), "1e20");
        assert_eq!(num(2.5), "2.5e0");
        assert_eq!(num(f64::NAN), "");
        for v in [2.0, 1e6, 1e20, 2.5, 0.1, -3.0, 1e-300, 123456789012345.0] {
            assert_eq!(num(v).parse::<f64>().unwrap(), v, "{v}");
        }
    }
}
