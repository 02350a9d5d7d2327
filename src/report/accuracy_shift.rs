//! The shift of one setting's result against the reference setting's, with its 95 % confidence
//! interval: what the accuracy–cost map (`report::accuracy`) plots for Q (silo) and D (chute),
//! and what `tests/accuracy_replicas.rs` checks on a collision's restitution.
//!
//! Each side is its replicas pooled (`observe::fits::pool`: a mean, its standard error and the
//! error's degrees of freedom). The shift is (mean − mean_ref) / |mean_ref|; its standard error
//! is √(se² + se_ref²) / |mean_ref| (the two sides are independent runs; the reference mean in
//! the denominator is taken as exact, an error of second order), its degrees of freedom
//! Welch–Satterthwaite's, and the half-width t₀.₉₇₅(dof) times that. A setting is "within
//! noise" when the interval covers zero, "shifted" when it does not: its difference from the
//! reference is then larger than its replicas' scatter explains.

use crate::observe::fits::{pool, t_975, Pooled, ReplicaEstimate};

/// A setting's shift against the reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shift {
    /// (mean − mean_ref) / |mean_ref|.
    pub rel: f64,
    /// Half-width of the 95 % confidence interval of `rel`.
    pub ci95_rel: f64,
    /// Welch–Satterthwaite degrees of freedom of the interval.
    pub dof: f64,
    /// Replicas pooled on each side.
    pub replicas: usize,
    pub reference_replicas: usize,
}

impl Shift {
    /// Whether the interval covers zero.
    pub fn within_noise(&self) -> bool {
        self.rel.abs() <= self.ci95_rel
    }

    /// "within noise" or "shifted".
    pub fn verdict(&self) -> &'static str {
        if self.within_noise() {
            "within noise"
        } else {
            "shifted"
        }
    }
}

/// The shift of `setting` against `reference` (see the module doc). None when the reference's
/// mean is zero or either side is not finite.
pub fn shift(setting: &Pooled, reference: &Pooled) -> Option<Shift> {
    let scale = reference.mean.abs();
    if scale == 0.0
        || ![setting.mean, setting.se, reference.mean, reference.se]
            .iter()
            .all(|x| x.is_finite())
    {
        return None;
    }
    let (vs, vr) = (setting.se.powi(2), reference.se.powi(2));
    let var = vs + vr;
    let denom = vs * vs / setting.dof.max(1.0) + vr * vr / reference.dof.max(1.0);
    let dof = if denom > 0.0 {
        var * var / denom
    } else {
        f64::INFINITY
    };
    let half = if var > 0.0 {
        t_975(dof) * var.sqrt()
    } else {
        0.0
    };
    Some(Shift {
        rel: (setting.mean - reference.mean) / scale,
        ci95_rel: half / scale,
        dof,
        replicas: setting.replicas,
        reference_replicas: reference.replicas,
    })
}

/// Pools each side's replicas and compares them (`pool`, then `shift`).
pub fn shift_of_replicas(
    setting: &[ReplicaEstimate],
    reference: &[ReplicaEstimate],
) -> Option<Shift> {
    shift(&pool(setting)?, &pool(reference)?)
}

/// One replica's value measured without an error of its own (a single collision, say): its
/// replicas' spread is then the only error, so pool at least three of them.
pub fn bare_replica(value: f64) -> ReplicaEstimate {
    ReplicaEstimate {
        mean: value,
        se: 0.0,
        dof: 1.0,
        weight: 1.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observe::fits::{student_t_975, PooledFrom};

    fn pooled(mean: f64, se: f64, dof: f64, replicas: usize) -> Pooled {
        Pooled {
            mean,
            ci95: t_975(dof) * se,
            se,
            dof,
            replicas,
            from: PooledFrom::Blocks,
        }
    }

    #[test]
    fn equal_errors_give_welchs_interval() {
        // se 0.1 and 0.1, dof 4 and 4: var 0.02, dof (0.02)² / (2 · 10⁻⁴/4) = 8.
        let s = shift(&pooled(1.1, 0.1, 4.0, 5), &pooled(1.0, 0.1, 4.0, 5)).unwrap();
        assert!((s.rel - 0.1).abs() < 1e-12);
        assert!((s.dof - 8.0).abs() < 1e-9, "{}", s.dof);
        let expect = student_t_975(8) * 0.02f64.sqrt();
        assert!((s.ci95_rel - expect).abs() < 1e-12, "{}", s.ci95_rel);
        assert!(s.within_noise());
        assert_eq!((s.replicas, s.reference_replicas), (5, 5));
    }

    #[test]
    fn a_shift_beyond_both_errors_is_shifted() {
        let s = shift(&pooled(1.5, 0.05, 9.0, 3), &pooled(1.0, 0.05, 9.0, 3)).unwrap();
        assert_eq!(s.verdict(), "shifted");
        let s = shift(&pooled(-0.5, 0.05, 9.0, 3), &pooled(-1.0, 0.05, 9.0, 3)).unwrap();
        assert!(
            (s.rel - 0.5).abs() < 1e-12,
            "relative to |mean_ref|: {}",
            s.rel
        );
    }

    #[test]
    fn bare_replicas_use_their_spread() {
        let a: Vec<_> = [1.0, 1.1, 0.9].map(bare_replica).to_vec();
        let b: Vec<_> = [1.0, 1.2, 0.8].map(bare_replica).to_vec();
        let s = shift_of_replicas(&a, &b).unwrap();
        // se² = s²/n on each side: 0.01/3 and 0.04/3; dof 2 each.
        let (va, vb): (f64, f64) = (0.01 / 3.0, 0.04 / 3.0);
        let dof = (va + vb).powi(2) / (va * va / 2.0 + vb * vb / 2.0);
        assert!((s.dof - dof).abs() < 1e-9);
        assert!((s.ci95_rel - t_975(dof) * (va + vb).sqrt()).abs() < 1e-12);
        assert!(shift(&pool(&a).unwrap(), &pooled(0.0, 0.1, 3.0, 1)).is_none());
    }
}
