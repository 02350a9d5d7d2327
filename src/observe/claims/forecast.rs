//! How much more work an undecided claim needs: the claim decided again on its present means,
//! with every result as it would be after k times the work. A result's standard error falls as
//! 1/√k and its degrees of freedom grow with its blocks or replicas, (dof + 1)·k − 1. The
//! second matters where an interval rests on few replicas: there the t tails at a look's high
//! level, not the standard error, set most of its width, and a forecast from the width alone
//! overstates the work many times over.

use super::data::{Estimate, PointData};
use super::statistic::Statistic;
use super::verdict::{decide, Decision};

/// Beyond this multiple of the work already done the forecast gives up.
const MAX_FACTOR: f64 = 1e4;

/// The results of `points` as they would be after `k` times their work, their means kept.
fn after_work(points: &[PointData], k: f64) -> Vec<PointData> {
    points
        .iter()
        .map(|p| {
            let mut p = p.clone();
            for e in p.results.values_mut() {
                *e = Estimate {
                    mean: e.mean,
                    se: e.se / k.sqrt(),
                    dof: (e.dof + 1.0) * k - 1.0,
                };
            }
            p
        })
        .collect()
}

/// The smallest multiple k ≥ 1 of the work its points ran at which `stat` would be decided at
/// `level` (either way) if every mean stayed where it is, to about 1 %; None when even
/// [`MAX_FACTOR`] would not (a value on its bound). Uses `decide`'s draws, seeded by `seed`.
pub fn work_to_decide(
    stat: &Statistic,
    points: &[PointData],
    level: f64,
    seed: u64,
) -> Option<f64> {
    let decided =
        |k: f64| decide(stat, &after_work(points, k), level, seed).decision != Decision::Undecided;
    if decided(1.0) {
        return Some(1.0);
    }
    if !decided(MAX_FACTOR) {
        return None;
    }
    // Bisection on ln k: undecided at `lo`, decided at `hi`.
    let (mut lo, mut hi) = (0.0_f64, MAX_FACTOR.ln());
    while hi - lo > 0.01 {
        let mid = 0.5 * (lo + hi);
        if decided(mid.exp()) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Some(hi.exp())
}
