//! Where a figure's files go and how they are drawn.

use std::ops::Deref;
use std::path::{Path, PathBuf};

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
