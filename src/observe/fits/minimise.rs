//! One-dimensional minimisation (a grid, then golden sections) and the RMS residual of a model.

pub(super) fn rms_residual(x: &[f64], y: &[f64], model: impl Fn(f64) -> f64) -> f64 {
    let ss: f64 = x
        .iter()
        .zip(y)
        .map(|(&xi, &yi)| (yi - model(xi)).powi(2))
        .sum();
    (ss / x.len() as f64).sqrt()
}

/// Minimises `f` on [lo, hi]: the best of `points` log-spaced grid values, then golden section
/// between its neighbours. None when `f` is infinite everywhere on the grid.
pub(super) fn grid_then_golden(
    f: impl Fn(f64) -> f64,
    lo: f64,
    hi: f64,
    points: usize,
) -> Option<f64> {
    let step = (hi - lo) / (points - 1) as f64;
    let (best, best_val) = (0..points).map(|i| (i, f(lo + step * i as f64))).fold(
        (0, f64::INFINITY),
        |acc, (i, v)| if v < acc.1 { (i, v) } else { acc },
    );
    if !best_val.is_finite() {
        return None;
    }
    let a = lo + step * best.saturating_sub(1) as f64;
    let b = lo + step * (best + 1).min(points - 1) as f64;
    Some(golden_min(&f, a, b, 1e-12))
}

/// Golden-section minimisation of a unimodal `f` on [a, b], to an interval width of
/// `tol` · (1 + |x|).
pub(super) fn golden_min(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64, tol: f64) -> f64 {
    let inv_phi = (5f64.sqrt() - 1.0) / 2.0;
    let mut c = b - inv_phi * (b - a);
    let mut d = a + inv_phi * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..200 {
        if (b - a).abs() <= tol * (1.0 + c.abs()) {
            break;
        }
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - inv_phi * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + inv_phi * (b - a);
            fd = f(d);
        }
    }
    if fc < fd {
        c
    } else {
        d
    }
}
