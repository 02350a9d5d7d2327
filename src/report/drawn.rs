//! What drawing one figure produced before render adds the campaign-level notes, and the
//! writing of a figure's files (SVG, PNG, CSV) shared by every paper's figures.

use std::ops::Deref;
use std::path::{Path, PathBuf};

use anyhow::Result;

use super::plot::Figure;
use super::table::Table;

/// One figure's text table and files.
pub(crate) struct Drawn {
    /// The text table.
    pub text: String,
    /// SVG, PNG, CSV.
    pub files: Vec<PathBuf>,
}

/// Where a figure's files go and how they are drawn.
#[derive(Debug, Clone)]
pub struct Output {
    /// Directory of the files.
    pub dir: PathBuf,
    /// Whether figures carry their title (a paper's caption replaces it: `--no-title`).
    pub titles: bool,
    /// Whether chute figures also draw jobs whose flow was not steady (marked as such).
    pub include_unsteady: bool,
}

impl Output {
    /// Files into `dir`, with titles.
    pub fn new(dir: &Path) -> Self {
        Self {
            dir: dir.to_path_buf(),
            titles: true,
            include_unsteady: false,
        }
    }
}

impl Deref for Output {
    type Target = Path;

    fn deref(&self) -> &Path {
        &self.dir
    }
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
