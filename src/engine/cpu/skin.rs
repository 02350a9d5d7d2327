//! When the half lists need a rebuild, without measuring every particle's displacement every
//! step. The lists stay valid while no particle has moved more than half the skin since they
//! were built. Measuring that exactly costs a pass over the build positions per step (a fifth of
//! the per-particle pass); instead the step reports its fastest particle, and an upper bound on
//! every displacement grows by that speed times dt. Only when the bound nears half the skin is
//! the exact measurement taken; it either asks for the rebuild or tightens the bound to the
//! measured largest displacement. The bound is conservative, so a rebuild happens at exactly the
//! step where the exact test, taken every step, would have asked for it: the run's bits do not
//! change.

/// An upper bound on how far any particle has moved since the lists were built.
#[derive(Clone, Copy, Debug)]
pub(super) struct DisplacementBound {
    /// The bound (m).
    moved: f64,
    /// Where the exact measurement is taken: 0.9 of half the skin, so that rounding in the
    /// exact test (relative 1e-7 in f32) can never make it report a displacement the bound
    /// missed.
    limit: f64,
    /// Rounding a step can add to a displacement: half a unit in the last place of the largest
    /// coordinate for the drift's addition and for a periodic wrap, doubled for margin.
    slack: f64,
    /// The largest coordinate magnitude the slack assumes, the skin, and the precision's
    /// spacing of numbers just above one.
    scale: f64,
    skin: f64,
    epsilon: f64,
}

impl DisplacementBound {
    /// A bound for lists with skin `skin`, positions of magnitude up to `scale` and precision
    /// `epsilon` (the spacing of numbers just above one), the particles having moved at most
    /// `moved` since the build.
    pub(super) fn new(skin: f64, moved: f64, scale: f64, epsilon: f64) -> Self {
        let mut b = Self {
            moved: 0.0,
            limit: 0.45 * skin,
            slack: 0.0,
            scale: 0.0,
            skin,
            epsilon,
        };
        b.measured(moved, scale + skin);
        b
    }

    /// The lists were just rebuilt. Until the next exact measurement the particles may move up
    /// to half the skin more, so the coordinates the slack assumes grow by the skin.
    pub(super) fn rebuilt(&mut self) {
        self.moved = 0.0;
        self.scale += self.skin;
        self.slack = 2.0 * self.scale * self.epsilon;
    }

    /// A drift by `dt` with fastest speed `v_max`. Returns whether the exact measurement is
    /// due.
    pub(super) fn drifted(&mut self, v_max: f64, dt: f64) -> bool {
        // 1e-6: the speed and the product are rounded in the run's precision.
        self.moved += v_max * dt * (1.0 + 1e-6) + self.slack;
        self.moved >= self.limit
    }

    /// The exact measurement found no particle beyond half the skin: `moved` is the largest
    /// displacement, `scale` the largest coordinate magnitude (plus the skin, which no particle
    /// leaves before the next rebuild).
    pub(super) fn measured(&mut self, moved: f64, scale: f64) {
        self.scale = scale;
        self.slack = 2.0 * scale * self.epsilon;
        self.moved = moved * (1.0 + 1e-6) + self.slack;
    }
}

#[cfg(test)]
mod tests {
    use super::DisplacementBound;

    /// The bound asks for the exact measurement before a particle moving at the fastest speed
    /// can have crossed half the skin, and not long before.
    #[test]
    fn the_exact_measurement_comes_before_half_the_skin_is_crossed() {
        let (skin, v, dt) = (1e-3, 0.7, 1e-6);
        let mut b = DisplacementBound::new(skin, 0.0, 0.1, f32::EPSILON as f64);
        let mut steps = 0u32;
        while !b.drifted(v, dt) {
            steps += 1;
            assert!(
                f64::from(steps) * v * dt < 0.5 * skin,
                "step {steps}: past half the skin"
            );
        }
        // 0.9 of half the skin at v dt per step, less the rounding slack (here 2 × 0.101 m ×
        // 1.2e-7 = 2.4e-8 m a step, 3.4 % of v dt).
        let ideal = 0.45 * skin / (v * dt);
        assert!(
            f64::from(steps) > 0.95 * ideal,
            "{steps} steps of an ideal {ideal:.0}"
        );
        b.measured(0.1 * skin, 0.1);
        assert!(!b.drifted(v, dt));
        b.rebuilt();
        assert!(!b.drifted(v, dt));
    }
}
