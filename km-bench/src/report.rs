//! The Markdown report (`report.md`): sections of paragraphs, figures (PNG
//! embedded, SVG linked) and tables, written from the values computed at run
//! time.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Context;

/// A Markdown table.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Table {
    /// Column headers.
    pub headers: Vec<String>,
    /// Rows of cells.
    pub rows: Vec<Vec<String>>,
}

impl Table {
    /// A table with these headers.
    pub fn new(headers: &[&str]) -> Self {
        Table { headers: headers.iter().map(|s| s.to_string()).collect(), rows: Vec::new() }
    }

    /// Add a row.
    pub fn push(&mut self, row: Vec<String>) {
        self.rows.push(row);
    }

    /// The Markdown text (pipes in cells escaped).
    pub fn render(&self) -> String {
        let cell = |c: &str| c.replace('|', "\\|").replace('\n', " ");
        let mut s = String::new();
        let _ = writeln!(
            s,
            "| {} |",
            self.headers.iter().map(|h| cell(h)).collect::<Vec<_>>().join(" | ")
        );
        let _ = writeln!(s, "|{}", "---|".repeat(self.headers.len()));
        for r in &self.rows {
            let mut cells: Vec<String> = r.iter().map(|c| cell(c)).collect();
            cells.resize(self.headers.len(), String::new());
            let _ = writeln!(s, "| {} |", cells.join(" | "));
        }
        s
    }
}

/// One element of a section.
#[derive(Debug, Clone, PartialEq)]
pub enum Block {
    /// A paragraph of Markdown text.
    Text(String),
    /// A chart written as `stem.png` and `stem.svg` next to the report, with a
    /// caption and the stem of the CSV holding its data.
    Figure {
        /// File stem of the chart.
        stem: String,
        /// Caption.
        caption: String,
        /// File stem of its data (`data.csv`).
        data: String,
    },
    /// A table.
    Table(Table),
}

/// A section of the report.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Section {
    /// Heading.
    pub title: String,
    /// Content, in order.
    pub blocks: Vec<Block>,
}

impl Section {
    /// An empty section.
    pub fn new(title: impl Into<String>) -> Self {
        Section { title: title.into(), blocks: Vec::new() }
    }
    /// Append a paragraph.
    pub fn text(&mut self, t: impl Into<String>) -> &mut Self {
        self.blocks.push(Block::Text(t.into()));
        self
    }
    /// Append a figure whose data is `stem.csv`.
    pub fn figure(&mut self, stem: impl Into<String>, caption: impl Into<String>) -> &mut Self {
        let stem = stem.into();
        self.blocks.push(Block::Figure { data: stem.clone(), stem, caption: caption.into() });
        self
    }
    /// Append a figure whose data is in `data.csv`.
    pub fn figure_data(
        &mut self,
        stem: impl Into<String>,
        caption: impl Into<String>,
        data: impl Into<String>,
    ) -> &mut Self {
        self.blocks.push(Block::Figure {
            stem: stem.into(),
            caption: caption.into(),
            data: data.into(),
        });
        self
    }
    /// Append a table.
    pub fn table(&mut self, t: Table) -> &mut Self {
        self.blocks.push(Block::Table(t));
        self
    }
}

/// The whole report.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Report {
    /// Title (level-1 heading).
    pub title: String,
    /// Paragraphs before the first section.
    pub intro: Vec<String>,
    /// Sections.
    pub sections: Vec<Section>,
}

impl Report {
    /// The Markdown text.
    pub fn render(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# {}\n", self.title);
        for p in &self.intro {
            let _ = writeln!(s, "{p}\n");
        }
        if self.sections.len() > 1 {
            let _ = writeln!(s, "## Contents\n");
            for (i, sec) in self.sections.iter().enumerate() {
                let _ = writeln!(s, "{}. [{}](#{})", i + 1, sec.title, anchor(&sec.title));
            }
            let _ = writeln!(s);
        }
        for sec in &self.sections {
            let _ = writeln!(s, "## {}\n", sec.title);
            for b in &sec.blocks {
                match b {
                    Block::Text(t) => {
                        let _ = writeln!(s, "{t}\n");
                    }
                    Block::Figure { stem, caption, data } => {
                        let _ = writeln!(
                            s,
                            "![{caption}]({stem}.png)\n\n*{caption}* ([SVG]({stem}.svg), [data]({data}.csv))\n"
                        );
                    }
                    Block::Table(t) => {
                        let _ = writeln!(s, "{}", t.render());
                    }
                }
            }
        }
        s
    }

    /// Write to `dir/report.md`.
    ///
    /// # Errors
    /// File errors.
    pub fn write(&self, dir: &Path) -> anyhow::Result<PathBuf> {
        self.write_named(dir, "report.md")
    }

    /// Write to `dir/name` (through a temporary file, renamed when complete).
    ///
    /// # Errors
    /// File errors.
    pub fn write_named(&self, dir: &Path, name: &str) -> anyhow::Result<PathBuf> {
        let p = dir.join(name);
        let tmp = dir.join(format!(".{name}.tmp"));
        std::fs::write(&tmp, self.render())
            .and_then(|()| std::fs::rename(&tmp, &p))
            .with_context(|| format!("writing {}", p.display()))?;
        Ok(p)
    }
}

/// GitHub-style heading anchor: lower case, spaces to hyphens, punctuation dropped.
fn anchor(title: &str) -> String {
    title
        .to_lowercase()
        .chars()
        .filter_map(|c| {
            if c.is_alphanumeric() || c == '-' || c == '_' {
                Some(c)
            } else if c == ' ' {
                Some('-')
            } else {
                None
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn report_embeds_figures_and_tables() {
        let mut sec = Section::new("Fig. 6: albedo");
        sec.text("What it shows.").figure("fig6", "R and T").table({
            let mut t = Table::new(&["a", "b"]);
            t.push(vec!["1".into(), "x|y".into()]);
            t
        });
        let r = Report { title: "T".into(), intro: vec![], sections: vec![sec] };
        let md = r.render();
        assert!(md.contains("![R and T](fig6.png)"));
        assert!(md.contains("[SVG](fig6.svg)"));
        assert!(md.contains("| 1 | x\\|y |"));
        assert_eq!(anchor("Fig. 6: albedo"), "fig-6-albedo");
    }
}
