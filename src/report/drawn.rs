//! What drawing one figure produced before render adds the campaign-level notes, and the
//! writing of a figure's files (SVG, PNG, CSV) shared by every paper's figures.

use std::path::PathBuf;

use anyhow::Result;

pub(crate) use super::output::Output;
use super::plot::Figure;
use super::table::Table;

/// One figure's text table and files.
pub(crate) struct Drawn {
    /// The text table.
    pub text: String,
    /// SVG, PNG, CSV.
    pub files: Vec<PathBuf>,
}

/// Writes `<stem>.svg`, `<stem>.png` and `<stem>.csv` into `out_dir`; returns their paths.
pub(crate) fn write_all(
    fig: &Figure,
    csv: &Table,
    out_dir: &Output,
    stem: &str,
) -> Result<Vec<PathBuf>> {
    let mut files = fig.write(out_dir, stem)?;
    let csv_path = out_dir.join(format!("{stem}.csv"));
    csv.write_csv(&csv_path)?;
    files.push(csv_path);
    Ok(files)
}
