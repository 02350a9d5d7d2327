//! The MSD's pieces with exact answers: time cells, the fit as lag weights, the window error.

use super::cells::{merge_cells, TimeCells, CELLS_PER_WINDOW};
use super::fit::FitLags;
use super::window_stderr;
use crate::observe::fits::linear_fit;

/// The windows partition the samples, in order, into M parts whose lengths differ by at most
/// one cell (≤ 1/R of a window once cells have merged), for every length up to 5000 samples.
#[test]
fn time_windows_partition_the_samples() {
    for m in [2usize, 4, 7] {
        let mut cells = TimeCells::new(m);
        for n in 0..5000u64 {
            cells.cell_of(n);
            let samples = n + 1;
            let Some(w) = cells.windows(samples) else {
                assert!(samples < m as u64);
                continue;
            };
            assert_eq!(w.len(), m);
            assert_eq!(w.iter().map(|x| x.samples).sum::<u64>(), samples);
            assert!(w.windows(2).all(|p| p[0].cells.end == p[1].cells.start));
            let lens: Vec<usize> = w.iter().map(|x| x.cells.len()).collect();
            let (lo, hi) = (lens.iter().min().unwrap(), lens.iter().max().unwrap());
            assert!(hi - lo <= 1, "{m} windows at {samples}: {lens:?}");
            if samples > (2 * CELLS_PER_WINDOW * m) as u64 {
                assert!(
                    *lo >= CELLS_PER_WINDOW,
                    "{m} windows at {samples}: {lens:?}"
                );
            }
        }
    }
}

/// Merging adds neighbouring cells and zeroes the upper half; every sample lands in the cell
/// that, after all merges, holds its index range.
#[test]
fn merged_cells_hold_the_sums_of_their_samples() {
    let mut cells = TimeCells::new(1);
    let mut per_cell = vec![0u64; cells.max()];
    let mut sums = vec![0u64; cells.max()];
    for n in 0..1000u64 {
        let (c, merge) = cells.cell_of(n);
        if merge {
            merge_cells(&mut per_cell, 1);
            merge_cells(&mut sums, 1);
        }
        per_cell[c] += 1;
        sums[c] += n;
    }
    let w = cells.windows(1000).unwrap();
    assert_eq!(w[0].samples, 1000);
    // 1000 samples in 8 max cells: 128 each after 4 merges, the last partial.
    let len = 128u64;
    for (c, (&count, &sum)) in per_cell.iter().zip(&sums).enumerate() {
        let range = (c as u64 * len)..((c as u64 + 1) * len).min(1000);
        assert_eq!(count, range.clone().count() as u64, "cell {c}");
        assert_eq!(sum, range.sum::<u64>(), "cell {c}");
    }
}

/// Σ c_k y_k is the least-squares slope of y over the fitted lags, to rounding.
#[test]
fn lag_weights_give_the_least_squares_slope() {
    let (dt, window) = (0.05, 101);
    let fit = FitLags::new(dt, window, 1.0, 5.0).unwrap();
    assert_eq!((fit.lo, fit.hi, fit.len()), (20, 100, 81));
    let y: Vec<f64> = (0..window)
        .map(|k| 0.3 * k as f64 + (k as f64 * 1.7).sin())
        .collect();
    let slope: f64 = (0..window).map(|k| fit.weights[k] * y[k]).sum();
    let x: Vec<f64> = (fit.lo..=fit.hi).map(|k| k as f64 * dt).collect();
    let line = linear_fit(&x, &y[fit.lo..=fit.hi]).unwrap();
    assert!((slope - line.slope).abs() < 1e-12 * line.slope.abs());
    assert!(
        FitLags::new(dt, window, 1.0, 1.05).is_none(),
        "3 lags needed"
    );
    assert_eq!(FitLags::new(dt, window, 1.0, 1.1).map(|f| f.len()), Some(3));
}

/// Equal weights: std(D_j)/√M with the sample std; constant D: 0; weights scale out.
#[test]
fn window_stderr_is_std_over_root_m() {
    let d = [1.0, 2.0, 4.0, 5.0];
    let mean = 3.0;
    let std = (d.iter().map(|x: &f64| (x - mean).powi(2)).sum::<f64>() / 3.0).sqrt();
    let se = window_stderr(&d, &[7.0; 4]).unwrap();
    assert!((se - std / 2.0).abs() < 1e-15);
    assert_eq!(window_stderr(&[2.0; 3], &[1.0, 2.0, 3.0]), Some(0.0));
    assert!(window_stderr(&[1.0], &[1.0]).is_none());
    assert!(window_stderr(&[1.0, f64::NAN], &[1.0, 1.0]).is_none());
    let (a, b) = (
        window_stderr(&d, &[1.0, 2.0, 3.0, 4.0]).unwrap(),
        window_stderr(&d, &[10.0, 20.0, 30.0, 40.0]).unwrap(),
    );
    assert!((a - b).abs() < 1e-15);
}
