//! Discharge observer: M(t) at a fixed sampling interval after the orifice opens, clogs (no
//! particle out for longer than `clog_after_s`), and Q = the mass flow over flowing intervals with
//! a 95 % confidence interval from block statistics.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::fits::mean_ci95;

/// Settings of the discharge observer (recorded with each job).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct DischargeSettings {
    /// Sampling interval of M(t) (s); also the engine's chunk length.
    pub sample_interval_s: f64,
    /// No particle out for longer than this is a clog (s).
    pub clog_after_s: f64,
    /// No particle out for this long ends the job as permanently clogged (s).
    pub permanent_clog_after_s: f64,
    /// Time after opening excluded from Q (start-up transient) (s).
    pub skip_initial_s: f64,
    /// Length of the blocks whose mean flow rates give Q's confidence interval (s).
    pub block_s: f64,
}

impl Default for DischargeSettings {
    fn default() -> Self {
        Self {
            sample_interval_s: 0.01,
            clog_after_s: 0.5,
            permanent_clog_after_s: 5.0,
            skip_initial_s: 0.5,
            block_s: 0.5,
        }
    }
}

/// A clog: an interval with no particle out.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Clog {
    pub start_s: f64,
    pub duration_s: f64,
    pub permanent: bool,
}

/// Streaming state of the observer (checkpointed with the job).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Discharge {
    pub settings: DischargeSettings,
    /// (t since opening (s), cumulative mass (kg), cumulative count).
    pub samples: Vec<(f64, f64, u64)>,
    /// Every removal: (t since opening, mass).
    pub exits: Vec<(f64, f64)>,
    pub mass_kg: f64,
    pub count: u64,
}

/// The result of a discharge.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DischargeSummary {
    pub q_kg_per_s: Option<f64>,
    pub q_ci95_kg_per_s: Option<f64>,
    pub q_method: String,
    pub flowing_time_s: f64,
    pub clogs: Vec<Clog>,
    pub permanently_clogged: bool,
}

impl Discharge {
    pub fn new(settings: DischargeSettings) -> Self {
        Self {
            settings,
            samples: vec![(0.0, 0.0, 0)],
            exits: Vec::new(),
            mass_kg: 0.0,
            count: 0,
        }
    }

    /// Records particles removed at times `t` (s since opening).
    pub fn record_exit(&mut self, t: f64, mass: f64) {
        self.exits.push((t, mass));
        self.mass_kg += mass;
        self.count += 1;
    }

    /// Records a sample of M at time t (s since opening).
    pub fn sample(&mut self, t: f64) {
        self.samples.push((t, self.mass_kg, self.count));
    }

    /// Time since the last particle left (or since opening), at time t.
    pub fn quiet_for(&self, t: f64) -> f64 {
        t - self.exits.last().map_or(0.0, |e| e.0)
    }

    /// Whether time `t` (since opening) lies in a flowing interval, as far as the exits known up
    /// to `known_until` tell: Some(true) flowing, Some(false) inside a clog (a gap between exits
    /// longer than `clog_after_s`, the rule of [`Discharge::summarize`]), None while the gap
    /// around `t` is still open and shorter than that.
    pub fn flowing_at(&self, t: f64, known_until: f64) -> Option<bool> {
        let k = self.exits.partition_point(|e| e.0 <= t);
        let prev = if k == 0 { 0.0 } else { self.exits[k - 1].0 };
        let clog = self.settings.clog_after_s;
        match self.exits.get(k) {
            Some(next) => Some(next.0 - prev <= clog),
            None if known_until - prev > clog => Some(false),
            None => None,
        }
    }

    /// [`Discharge::flowing_at`] once the run has ended at `t_end`: the last gap is a clog only
    /// if it outlasted `clog_after_s`, as in [`Discharge::summarize`].
    pub fn flowing_at_end(&self, t: f64, t_end: f64) -> bool {
        self.flowing_at(t, t_end).unwrap_or(true)
    }

    /// Whether the silo is permanently clogged at time t.
    pub fn permanently_clogged(&self, t: f64) -> bool {
        self.quiet_for(t) >= self.settings.permanent_clog_after_s
    }

    /// Clogs, flowing intervals and Q at the end time `t_end`.
    pub fn summarize(&self, t_end: f64) -> DischargeSummary {
        let st = &self.settings;
        // Gaps between successive exits (and from the last exit to the end) longer than the clog
        // time are clogs; everything else after the initial transient is flowing.
        let mut clogs = Vec::new();
        let mut prev = 0.0;
        for &(t, _) in &self.exits {
            if t - prev > st.clog_after_s {
                clogs.push(Clog {
                    start_s: prev,
                    duration_s: t - prev,
                    permanent: false,
                });
            }
            prev = t;
        }
        let permanently = t_end - prev >= st.permanent_clog_after_s;
        if t_end - prev > st.clog_after_s {
            clogs.push(Clog {
                start_s: prev,
                duration_s: t_end - prev,
                permanent: permanently,
            });
        }
        // Flowing intervals: [skip, t_end] minus clogs.
        let mut intervals: Vec<(f64, f64)> = Vec::new();
        let mut start = st.skip_initial_s;
        for c in &clogs {
            let (a, b) = (c.start_s, c.start_s + c.duration_s);
            if a > start {
                intervals.push((start, a));
            }
            start = start.max(b);
        }
        if t_end > start {
            intervals.push((start, t_end));
        }
        // Cut the flowing time into blocks of about block_s and take the flow rate of each.
        let mut rates = Vec::new();
        let mut flowing = 0.0;
        for &(a, b) in &intervals {
            let len = b - a;
            flowing += len;
            let nb = (len / st.block_s).floor() as usize;
            for k in 0..nb {
                let (t0, t1) = (a + k as f64 * st.block_s, a + (k + 1) as f64 * st.block_s);
                let m: f64 = self
                    .exits
                    .iter()
                    .filter(|e| e.0 > t0 && e.0 <= t1)
                    .map(|e| e.1)
                    .sum();
                rates.push(m / st.block_s);
            }
        }
        let (q, ci) = match mean_ci95(&rates) {
            Some((m, h)) if rates.len() >= 3 => (Some(m), Some(h)),
            _ => (None, None),
        };
        DischargeSummary {
            q_kg_per_s: q,
            q_ci95_kg_per_s: ci,
            q_method: format!(
                "mean of {} block flow rates of {} s over flowing intervals (clog = no exit for > {} s, first {} s skipped); 95 % CI from Student t on the block means",
                rates.len(),
                st.block_s,
                st.clog_after_s,
                st.skip_initial_s
            ),
            flowing_time_s: flowing,
            clogs,
            permanently_clogged: permanently,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steady_flow_gives_its_rate_and_a_clog_is_excluded() {
        let mut d = Discharge::new(DischargeSettings {
            skip_initial_s: 0.0,
            ..Default::default()
        });
        // 100 particles/s of 1 g for 5 s, a 2 s clog, then 5 s more.
        let mut t = 0.0;
        while t < 5.0 {
            t += 0.01;
            d.record_exit(t, 1e-3);
        }
        t += 2.0;
        let t_stop = t + 5.0;
        while t < t_stop {
            t += 0.01;
            d.record_exit(t, 1e-3);
        }
        let s = d.summarize(t);
        assert_eq!(s.clogs.len(), 1);
        assert!((s.clogs[0].duration_s - 2.01).abs() < 0.02);
        let q = s.q_kg_per_s.unwrap();
        assert!((q - 0.1).abs() < 0.003, "Q = {q}");
        assert!(!s.permanently_clogged);
        assert!((s.flowing_time_s - 10.0).abs() < 0.05);
    }

    #[test]
    fn samples_in_a_clog_are_not_flowing_and_open_gaps_wait() {
        let mut d = Discharge::new(DischargeSettings::default());
        for k in 1..=100 {
            d.record_exit(f64::from(k) * 0.01, 1e-3);
        }
        // 1.0 s: last exit; a 1.5 s gap (a clog, > 0.5 s), then flow again.
        assert_eq!(d.flowing_at(0.5, 1.2), Some(true));
        assert_eq!(
            d.flowing_at(1.2, 1.3),
            None,
            "gap still shorter than clog_after_s"
        );
        assert_eq!(d.flowing_at(1.2, 1.6), Some(false), "gap past clog_after_s");
        d.record_exit(2.5, 1e-3);
        assert_eq!(d.flowing_at(1.2, 2.5), Some(false));
        assert_eq!(d.flowing_at(2.49, 2.5), Some(false));
        d.record_exit(2.6, 1e-3);
        assert_eq!(d.flowing_at(2.55, 2.6), Some(true));
        assert!(d.flowing_at_end(2.7, 2.8), "a short last gap is flowing");
        assert!(!d.flowing_at_end(2.7, 3.5), "a long last gap is a clog");
        let s = d.summarize(3.5);
        let in_clog = |t: f64| {
            s.clogs
                .iter()
                .any(|c| t > c.start_s && t < c.start_s + c.duration_s)
        };
        for t in [0.5, 1.2, 2.0, 2.55, 2.7, 3.4] {
            assert_eq!(d.flowing_at_end(t, 3.5), !in_clog(t), "t = {t}");
        }
    }

    #[test]
    fn permanent_clog_is_recorded() {
        let mut d = Discharge::new(DischargeSettings::default());
        d.record_exit(0.1, 1e-3);
        let s = d.summarize(6.0);
        assert!(s.permanently_clogged);
        assert!(s.clogs.last().unwrap().permanent);
        assert!(s.q_kg_per_s.is_none());
    }
}
