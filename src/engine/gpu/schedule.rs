//! When the host records a list build. The device only finds out after a drift that the lists
//! went stale, and the steps recorded after that are void and redone (engine.rs); so the host
//! predicts the next build from the stale steps it has seen and records it a little early. A
//! build's timing never changes the results (lists are sorted by particle index and hold every
//! pair within the cutoff), only what the chunk costs.

/// Scheduled builds without a stale step before the interval is probed longer.
const PROBE_AFTER: u32 = 16;

/// The build interval, learnt over the engine's life.
#[derive(Clone, Copy, Debug, Default)]
pub struct BuildSchedule {
    /// Steps from one build to the next; None until a stale step has been seen.
    interval: Option<u64>,
    /// Scheduled builds since the last stale step.
    quiet: u32,
}

impl BuildSchedule {
    /// Whether a build is due at step `k` of a chunk whose last build was recorded after the
    /// drift of step `last` (−1: before the chunk's first step).
    pub fn due(&self, k: i64, last: i64) -> bool {
        self.interval.is_some_and(|n| k - last >= n as i64)
    }

    /// A scheduled build was recorded.
    pub fn scheduled(&mut self) {
        self.quiet += 1;
        if let Some(n) = self.interval.as_mut() {
            // Flows slow down (a silo clogs, a chute settles): try a little longer now and then.
            if self.quiet >= PROBE_AFTER {
                *n += *n / 8 + 1;
                self.quiet = 0;
            }
        }
    }

    /// The lists went stale at step `k`, `since` steps after the last build: schedule builds a
    /// quarter earlier than that.
    pub fn stale(&mut self, since: u64) {
        let n = (since - since / 4).max(1);
        self.interval = Some(self.interval.map_or(n, |m| m.min(n)));
        self.quiet = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::BuildSchedule;

    #[test]
    fn builds_are_due_a_quarter_before_the_lists_went_stale() {
        let mut s = BuildSchedule::default();
        assert!(!s.due(1000, -1), "no prediction before a stale step");
        s.stale(40);
        assert!(!s.due(29, 0) && s.due(30, 0));
        s.stale(80);
        assert!(s.due(30, 0), "the shorter interval holds");
        for _ in 0..super::PROBE_AFTER {
            s.scheduled();
        }
        assert!(!s.due(33, 0) && s.due(34, 0), "probed 30 + 30/8 + 1");
    }
}
