//! Rows of text cells rendered two ways: fixed-width columns for the terminal and CSV for
//! pandas or a spreadsheet. Cells are formatted by the caller; this file only lays them out.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result};

/// A header row (names carry units, e.g. `Q_kg_per_s`) and rows of preformatted cells.
#[derive(Debug, Clone, Default)]
pub struct Table {
    /// Column names.
    pub headers: Vec<String>,
    /// Cells; each row as long as `headers`.
    pub rows: Vec<Vec<String>>,
}

impl Table {
    /// An empty table with these column names.
    pub fn new<S: AsRef<str>>(headers: &[S]) -> Self {
        Self {
            headers: headers.iter().map(|h| h.as_ref().to_string()).collect(),
            rows: Vec::new(),
        }
    }

    /// Appends one row.
    pub fn push(&mut self, row: Vec<String>) {
        self.rows.push(row);
    }

    /// Right-aligned fixed-width columns separated by two spaces, one line per row.
    pub fn to_text(&self) -> String {
        let mut widths: Vec<usize> = self.headers.iter().map(|h| h.chars().count()).collect();
        for row in &self.rows {
            for (i, cell) in row.iter().enumerate() {
                if i < widths.len() {
                    widths[i] = widths[i].max(cell.chars().count());
                } else {
                    widths.push(cell.chars().count());
                }
            }
        }
        let mut out = String::new();
        let mut line = |cells: &[String]| {
            let mut l = String::new();
            for (cell, w) in cells.iter().zip(&widths) {
                let _ = write!(l, "  {cell:>w$}");
            }
            out.push_str(l.trim_end());
            out.push('\n');
        };
        line(&self.headers);
        for row in &self.rows {
            line(row);
        }
        out
    }

    /// The table as CSV (RFC 4180 quoting), header first.
    pub fn to_csv(&self) -> String {
        let mut out = String::new();
        for row in std::iter::once(&self.headers).chain(&self.rows) {
            let cells: Vec<String> = row.iter().map(|c| csv_cell(c)).collect();
            out.push_str(&cells.join(","));
            out.push('\n');
        }
        out
    }

    /// Writes [`Table::to_csv`] to `path`.
    ///
    /// # Errors
    /// When the file cannot be written.
    pub fn write_csv(&self, path: &Path) -> Result<()> {
        std::fs::write(path, self.to_csv()).with_context(|| format!("writing {}", path.display()))
    }
}

/// Quotes a cell when it holds a separator, a quote or a line break (labels contain commas).
fn csv_cell(cell: &str) -> String {
    if cell.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", cell.replace('"', "\"\""))
    } else {
        cell.to_string()
    }
}

/// A number for a CSV cell: shortest exact representation, empty for a missing value.
pub fn csv_num(v: Option<f64>) -> String {
    match v {
        Some(v) if v.is_finite() => format!("{v}"),
        _ => String::new(),
    }
}

/// A number for a text cell with `decimals` digits, "-" for a missing value.
pub fn fixed(v: Option<f64>, decimals: usize) -> String {
    match v {
        Some(v) if v.is_finite() => format!("{v:.decimals$}"),
        _ => "-".into(),
    }
}

/// A number for a text cell in scientific notation with `decimals` digits, "-" when missing.
pub fn sci(v: Option<f64>, decimals: usize) -> String {
    match v {
        Some(v) if v.is_finite() => format!("{v:.decimals$e}"),
        _ => "-".into(),
    }
}

/// A number with up to three decimals and no trailing zeros, for labels ("0.3", "11.8").
pub fn short(v: f64) -> String {
    let s = format!("{v:.3}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// A length in metres written in millimetres for labels, via [`short`] ("11.8").
pub fn mm(d_m: f64) -> String {
    short(d_m * 1e3)
}

/// `s` with the characters HTML and Markdown tables would read as markup escaped (&, <, >).
pub(super) fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_columns_align_and_csv_quotes_commas() {
        let mut t = Table::new(&["D_mm", "label"]);
        t.push(vec!["28.0".into(), "a=1,b=2".into()]);
        t.push(vec!["8.5".into(), "x".into()]);
        let text = t.to_text();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "  D_mm    label");
        assert_eq!(lines[1], "  28.0  a=1,b=2");
        assert_eq!(lines[2], "   8.5        x");
        assert_eq!(t.to_csv(), "D_mm,label\n28.0,\"a=1,b=2\"\n8.5,x\n");
        assert_eq!(csv_num(Some(0.1)), "0.1");
        assert_eq!(csv_num(None), "");
        assert_eq!(fixed(Some(1.23456), 2), "1.23");
        assert_eq!(sci(Some(2900.0), 3), "2.900e3");
        assert_eq!(
            (short(0.30000000000000004), short(1.0), mm(0.0118)),
            ("0.3".into(), "1".into(), "11.8".into())
        );
    }
}
