//! Time cells for window statistics when the measurement's length is not known in advance.
//!
//! Samples are binned in consecutive cells of `len` samples. There are at most 2 R M cells (M
//! windows, R = `CELLS_PER_WINDOW`); when sample 2 R M · len arrives, neighbouring cells are
//! merged pairwise and `len` doubles. At the end the K ∈ (R M, 2 R M] cells in use (fewer only
//! in a short measurement) are split into M windows of ⌊K/M⌋ or ⌈K/M⌉ consecutive cells, so
//! windows differ in length by at most one cell (≤ 1/R); the error estimate weights them by
//! their data. Sums binned per cell are merged by addition, so memory stays bounded however long
//! the measurement.

use std::ops::{Add, Range};

use serde::{Deserialize, Serialize};

/// Cells per window before a merge halves them.
pub(super) const CELLS_PER_WINDOW: usize = 4;

/// The cell layout (checkpointed with its owner).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(super) struct TimeCells {
    /// Samples per cell (a power of 2).
    len: u64,
    /// Most cells held: 2 R M.
    max: usize,
    /// Windows M.
    windows: usize,
}

/// One window: its cells and how many samples they hold.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct TimeWindow {
    pub cells: Range<usize>,
    pub samples: u64,
}

impl TimeCells {
    /// Cells for `windows` ≥ 1 windows.
    pub fn new(windows: usize) -> Self {
        assert!(windows >= 1);
        Self {
            len: 1,
            max: 2 * CELLS_PER_WINDOW * windows,
            windows,
        }
    }

    /// Most cells held: the stride of per-cell storage.
    pub fn max(&self) -> usize {
        self.max
    }

    /// The cell of sample `n` (samples arrive in order 0, 1, 2, …), and whether every holder of
    /// per-cell sums must merge its cells (`merge_cells`) before adding to it.
    pub fn cell_of(&mut self, n: u64) -> (usize, bool) {
        let merged = n / self.len >= self.max as u64;
        if merged {
            self.len *= 2;
        }
        ((n / self.len) as usize, merged)
    }

    /// The M windows after `samples` samples; None while fewer cells than windows are in use.
    pub fn windows(&self, samples: u64) -> Option<Vec<TimeWindow>> {
        let used = samples.div_ceil(self.len) as usize;
        if used < self.windows {
            return None;
        }
        let size = |c: usize| self.len.min(samples - c as u64 * self.len);
        Some(
            (0..self.windows)
                .map(|j| {
                    let cells = j * used / self.windows..(j + 1) * used / self.windows;
                    TimeWindow {
                        samples: cells.clone().map(size).sum(),
                        cells,
                    }
                })
                .collect(),
        )
    }
}

/// Merges `cells` (`max` cells of `size` values each, cell c at c·size) pairwise: new cell j =
/// old 2j + old 2j + 1, the upper half zeroed. In place: cell j is written after cells 2j and
/// 2j + 1 (both ≥ j) are read, and no cell ≥ j has been written yet.
pub(super) fn merge_cells<T: Copy + Default + Add<Output = T>>(cells: &mut [T], size: usize) {
    let max = cells.len() / size;
    for j in 0..max / 2 {
        for e in 0..size {
            cells[j * size + e] = cells[2 * j * size + e] + cells[(2 * j + 1) * size + e];
        }
    }
    cells[max / 2 * size..].fill(T::default());
}
