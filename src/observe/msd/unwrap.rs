//! A coordinate wrapped into a periodic box made continuous again, particle by particle, for an
//! MSD across the boundary: between consecutive samples a particle moves by the minimum image
//! of its wrapped displacement, d − P round(d/P). That is its true displacement while it moves
//! less than half a period P between samples (in the chute: 8 L = 1 m in 0.05 s, 20 m/s
//! across the flow, where |v_y| stays below ~1 m/s). A particle absent from the previous
//! sample starts again from its wrapped value, as `BlockMsd` starts a new history then.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// Per-particle unwrapping state (checkpointed with its owner).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Unwrapper {
    /// The box length P along the coordinate (m).
    period_m: f64,
    /// Samples taken.
    samples: u64,
    /// Particle id → (index of the last sample it was in, its wrapped and unwrapped value).
    last: BTreeMap<u32, (u64, f64, f64)>,
}

impl Unwrapper {
    /// An unwrapper for a box of length `period_m` > 0.
    ///
    /// # Panics
    /// Unless `period_m` is finite and positive.
    pub fn new(period_m: f64) -> Self {
        assert!(period_m.is_finite() && period_m > 0.0, "period {period_m}");
        Self {
            period_m,
            samples: 0,
            last: BTreeMap::new(),
        }
    }

    /// The continuous values of one sample: particle `ids[i]` at wrapped `wrapped[i]`, any order.
    ///
    /// # Panics
    /// If the slices differ in length.
    pub fn unwrap(&mut self, ids: &[u32], wrapped: &[f64]) -> Vec<f64> {
        assert_eq!(ids.len(), wrapped.len());
        let (n, p) = (self.samples, self.period_m);
        let out = ids
            .iter()
            .zip(wrapped)
            .map(|(&id, &x)| {
                let u = match self.last.get(&id) {
                    Some(&(seen, w, u)) if seen + 1 == n => {
                        let d = x - w;
                        u + (d - p * (d / p).round())
                    }
                    _ => x,
                };
                self.last.insert(id, (n, x, u));
                u
            })
            .collect();
        self.samples += 1;
        out
    }
}

#[cfg(test)]
mod tests {
    use super::Unwrapper;

    /// A walk crossing the boundary many times comes back exactly (to rounding) from its wrapped
    /// values; a gap restarts from the wrapped value.
    #[test]
    fn a_wrapped_walk_is_unwrapped() {
        let mut u = Unwrapper::new(1.0);
        let mut x: f64 = 0.9;
        for k in 0..200 {
            x += if k % 3 == 0 { 0.31 } else { -0.12 };
            let got = u.unwrap(&[7], &[x.rem_euclid(1.0)])[0];
            if k == 0 {
                assert_eq!(got, x.rem_euclid(1.0));
                x = got;
            } else {
                assert!((got - x).abs() < 1e-12, "step {k}: {got} vs {x}");
            }
        }
        // Particle 7 absent from one sample: it restarts from its wrapped value.
        u.unwrap(&[8], &[0.5]);
        assert_eq!(u.unwrap(&[7], &[0.25])[0], 0.25);
    }
}
