//! Small fits used to read physical rates off sampled trajectories.

use std::f64::consts::PI;

/// Least-squares slope of y(x).
pub fn slope(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
    sxy / sxx
}

/// Removes the 2π jumps of a sequence of angles.
pub fn unwrap(a: &[f64]) -> Vec<f64> {
    let mut out: Vec<f64> = Vec::with_capacity(a.len());
    for &x in a {
        let mut x = x;
        if let Some(&prev) = out.last() {
            x += 2.0 * PI * ((prev - x) / (2.0 * PI)).round();
        }
        out.push(x);
    }
    out
}

/// Least-squares circle through the points: centre and radius.
pub fn fit_circle(x: &[f64], y: &[f64]) -> (f64, f64, f64) {
    // Normal equations of [x y 1] [2a 2b c]ᵀ = x² + y².
    let mut m = [[0.0; 3]; 3];
    let mut r = [0.0; 3];
    for (&xi, &yi) in x.iter().zip(y) {
        let row = [xi, yi, 1.0];
        let rhs = xi * xi + yi * yi;
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] += row[i] * row[j];
            }
            r[i] += row[i] * rhs;
        }
    }
    let s = solve3(m, r);
    let (a, b) = (s[0] / 2.0, s[1] / 2.0);
    (a, b, (s[2] + a * a + b * b).sqrt())
}

/// Solves a 3×3 system by Cramer's rule.
fn solve3(m: [[f64; 3]; 3], r: [f64; 3]) -> [f64; 3] {
    let det = |a: [[f64; 3]; 3]| {
        a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
            - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
            + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
    };
    let d = det(m);
    std::array::from_fn(|k| {
        let mut a = m;
        for (row, &rhs) in a.iter_mut().zip(&r) {
            row[k] = rhs;
        }
        det(a) / d
    })
}
