//! Replicas of one point combined into one estimate with a 95 % confidence interval.
//!
//! Each replica brings its own mean, the standard error of that mean from its own blocks (or
//! time windows) and the blocks' degrees of freedom. The pooled mean weights replicas by how
//! much they measured (a job run twice as long counts twice). Its standard error comes from the
//! replicas' own errors (pooled blocks, Welch–Satterthwaite degrees of freedom), so a single
//! long run has an interval too. From three replicas on, the spread between them is a second,
//! independent estimate; the wider interval is kept, because blocks of one run that are
//! correlated understate the error and only the replicas can show it.

use super::student_t_975;

/// One replica's measurement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReplicaEstimate {
    /// Its mean (any unit).
    pub mean: f64,
    /// Standard error of `mean` from its own blocks (same unit).
    pub se: f64,
    /// Degrees of freedom of `se` (blocks − 1).
    pub dof: f64,
    /// How much it measured (blocks, or seconds of measurement): its weight in the mean.
    pub weight: f64,
}

impl ReplicaEstimate {
    /// From a mean of `blocks` block values and the half-width of its 95 % CI (t_{n−1} s/√n).
    pub fn from_blocks(mean: f64, ci95: f64, blocks: usize) -> Option<Self> {
        if blocks < 2 || !mean.is_finite() || !ci95.is_finite() {
            return None;
        }
        Some(Self {
            mean,
            se: ci95 / student_t_975(blocks - 1),
            dof: (blocks - 1) as f64,
            weight: blocks as f64,
        })
    }
}

/// Where a pooled interval came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PooledFrom {
    /// The replicas' own block errors (one replica, or replicas that agree with them).
    Blocks,
    /// The spread between ≥ 3 replicas, wider than their block errors say.
    ReplicaSpread,
}

impl PooledFrom {
    pub fn name(self) -> &'static str {
        match self {
            PooledFrom::Blocks => "pooled blocks",
            PooledFrom::ReplicaSpread => "replica spread",
        }
    }
}

/// Replicas combined.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pooled {
    pub mean: f64,
    /// Half-width of the 95 % confidence interval of `mean`.
    pub ci95: f64,
    /// Standard error of `mean` (the one the interval came from).
    pub se: f64,
    /// Degrees of freedom of `se`.
    pub dof: f64,
    pub replicas: usize,
    pub from: PooledFrom,
}

impl Pooled {
    /// `ci95 / |mean|` (infinite for a zero mean).
    pub fn ci95_rel(&self) -> f64 {
        if self.mean == 0.0 {
            f64::INFINITY
        } else {
            self.ci95 / self.mean.abs()
        }
    }
}

/// Two-sided 95 % t quantile at fractional degrees of freedom, rounded down (conservative).
/// A dof within 1e-9 below an integer (Welch–Satterthwaite's 9 computed as 8.999…) counts as
/// that integer.
pub fn t_975(dof: f64) -> f64 {
    let dof = dof + 1e-9;
    if !(dof >= 1.0) {
        return f64::INFINITY;
    }
    student_t_975(dof.floor().min(1e9) as usize)
}

/// Combines replicas (see the module doc). None without a replica or with a weight ≤ 0.
pub fn pool(replicas: &[ReplicaEstimate]) -> Option<Pooled> {
    let total: f64 = replicas.iter().map(|r| r.weight).sum();
    if replicas.is_empty() || total <= 0.0 || replicas.iter().any(|r| r.weight <= 0.0) {
        return None;
    }
    let w = |r: &ReplicaEstimate| r.weight / total;
    let mean: f64 = replicas.iter().map(|r| w(r) * r.mean).sum();
    // Pooled block errors: Var(Σ wᵢ xᵢ) = Σ wᵢ² seᵢ², with Welch–Satterthwaite's dof.
    let var_b: f64 = replicas.iter().map(|r| (w(r) * r.se).powi(2)).sum();
    let denom: f64 = replicas
        .iter()
        .map(|r| (w(r) * r.se).powi(4) / r.dof.max(1.0))
        .sum();
    let dof_b = if denom > 0.0 {
        var_b * var_b / denom
    } else {
        replicas.iter().map(|r| r.dof).sum()
    };
    let se_b = var_b.sqrt();
    let mut out = Pooled {
        mean,
        ci95: t_975(dof_b) * se_b,
        se: se_b,
        dof: dof_b,
        replicas: replicas.len(),
        from: PooledFrom::Blocks,
    };
    let n = replicas.len();
    if n >= 3 {
        // The weighted mean's variance estimated from the replicas themselves.
        let nf = n as f64;
        let var_s: f64 = replicas
            .iter()
            .map(|r| (w(r) * (r.mean - mean)).powi(2))
            .sum::<f64>()
            * nf
            / (nf - 1.0);
        let ci_s = t_975(nf - 1.0) * var_s.sqrt();
        if ci_s > out.ci95 {
            out = Pooled {
                ci95: ci_s,
                se: var_s.sqrt(),
                dof: nf - 1.0,
                from: PooledFrom::ReplicaSpread,
                ..out
            };
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn est(mean: f64, se: f64, blocks: usize) -> ReplicaEstimate {
        ReplicaEstimate {
            mean,
            se,
            dof: (blocks - 1) as f64,
            weight: blocks as f64,
        }
    }

    #[test]
    fn one_replica_keeps_its_own_interval() {
        let r = ReplicaEstimate::from_blocks(2.0, 0.3, 10).unwrap();
        let p = pool(&[r]).unwrap();
        assert_eq!(p.mean, 2.0);
        assert!((p.ci95 - 0.3).abs() < 1e-12, "{}", p.ci95);
        assert_eq!(p.from, PooledFrom::Blocks);
    }

    #[test]
    fn equal_replicas_shrink_the_interval_like_one_longer_run() {
        // Two equal-length replicas with equal errors: se/√2, dof 2(n−1).
        let p = pool(&[est(1.0, 0.1, 10), est(1.2, 0.1, 10)]).unwrap();
        assert!((p.mean - 1.1).abs() < 1e-12);
        assert!((p.se - 0.1 / 2f64.sqrt()).abs() < 1e-12);
        assert!((p.dof - 18.0).abs() < 1e-9, "{}", p.dof);
    }

    #[test]
    fn longer_runs_weigh_more() {
        let p = pool(&[est(1.0, 0.1, 30), est(2.0, 0.2, 10)]).unwrap();
        assert!((p.mean - 1.25).abs() < 1e-12);
    }

    #[test]
    fn replicas_that_disagree_beyond_their_errors_widen_the_interval() {
        let tight = [est(1.0, 0.01, 10), est(1.5, 0.01, 10), est(2.0, 0.01, 10)];
        let p = pool(&tight).unwrap();
        assert_eq!(p.from, PooledFrom::ReplicaSpread);
        // Plain Student t over three equal-weight replicas: t₂ · s/√3 with s = 0.5.
        assert!((p.ci95 - student_t_975(2) * 0.5 / 3f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn the_interval_covers_the_truth_about_95_percent_of_the_time() {
        // Replicas of 8 blocks of N(μ, 1) each; 3 replicas; 4000 trials.
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut normal = || {
            // Box–Muller from a xorshift stream.
            let mut u = || {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            let (a, b) = (u(), u());
            (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
        };
        let trials = 4000;
        let mut covered = 0;
        for _ in 0..trials {
            let reps: Vec<ReplicaEstimate> = (0..3)
                .map(|_| {
                    let xs: Vec<f64> = (0..8).map(|_| 5.0 + normal()).collect();
                    let (m, ci) = super::super::mean_ci95(&xs).unwrap();
                    ReplicaEstimate::from_blocks(m, ci, 8).unwrap()
                })
                .collect();
            let p = pool(&reps).unwrap();
            if (p.mean - 5.0).abs() <= p.ci95 {
                covered += 1;
            }
        }
        let rate = covered as f64 / trials as f64;
        // At least nominal (the wider of two intervals is kept), and not absurdly wide.
        assert!((0.94..0.995).contains(&rate), "coverage {rate}");
    }
}
