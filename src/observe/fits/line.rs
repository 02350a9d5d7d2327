//! Least-squares straight lines with standard errors and the correlation coefficient.

use serde::Serialize;

/// Least-squares straight line y = slope · x + intercept.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct LinearFit {
    /// Slope, in units of y per unit of x.
    pub slope: f64,
    /// Intercept, in units of y.
    pub intercept: f64,
    /// Standard error of the slope (NaN when n = 2: no degree of freedom left).
    pub slope_se: f64,
    /// Standard error of the intercept (NaN when n = 2).
    pub intercept_se: f64,
    /// Pearson correlation coefficient R, dimensionless (NaN when y is constant).
    pub r: f64,
    /// Number of points used.
    pub n: usize,
}

/// Ordinary least-squares line through (x, y).
///
/// Returns None when the slices differ in length, hold fewer than 2 points, contain a non-finite
/// value, or when every x is the same.
pub fn linear_fit(x: &[f64], y: &[f64]) -> Option<LinearFit> {
    let n = x.len();
    if n != y.len() || n < 2 || x.iter().chain(y).any(|v| !v.is_finite()) {
        return None;
    }
    let nf = n as f64;
    let x_mean = x.iter().sum::<f64>() / nf;
    let y_mean = y.iter().sum::<f64>() / nf;
    // Centred sums: the uncentred form loses digits when |mean| ≫ spread.
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for (xi, yi) in x.iter().zip(y) {
        let (dx, dy) = (xi - x_mean, yi - y_mean);
        sxx += dx * dx;
        sxy += dx * dy;
        syy += dy * dy;
    }
    if sxx <= 0.0 {
        return None;
    }
    let slope = sxy / sxx;
    let intercept = y_mean - slope * x_mean;
    let (slope_se, intercept_se) = if n > 2 {
        let ssr: f64 = x
            .iter()
            .zip(y)
            .map(|(xi, yi)| (yi - intercept - slope * xi).powi(2))
            .sum();
        let s2 = ssr / (nf - 2.0);
        (
            (s2 / sxx).sqrt(),
            (s2 * (1.0 / nf + x_mean * x_mean / sxx)).sqrt(),
        )
    } else {
        (f64::NAN, f64::NAN)
    };
    let r = if syy > 0.0 {
        sxy / (sxx * syy).sqrt()
    } else {
        f64::NAN
    };
    Some(LinearFit {
        slope,
        intercept,
        slope_se,
        intercept_se,
        r,
        n,
    })
}
