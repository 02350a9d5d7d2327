//! Discharge observer: M(t) at a fixed sampling interval after the orifice opens, clogs (no
//! particle out for longer than `clog_after_s`), and Q = the mass flow over flowing intervals with
//! a 95 % confidence interval from block statistics, fitted only where M(t) is linear.
//!
//! Exits are counted at the orifice plane. The engine removes a particle when it has fallen
//! `sink_depth_m` below the plate and reports only that time; the observer dates the crossing
//! of the plane that much earlier by the free-fall time from rest, √(2 h / g). That is the
//! longest the fall can take (a particle leaving with a downward speed falls faster), so every
//! crossing up to `t − √(2h/g)` is known at time t, and clogs start and end at the plane
//! instead of one fall time late.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::fits::{linear_fit, mean_ci95, student_t_975};

/// Q is fitted only while at most this fraction of the initial mass has left a silo that is
/// not refilled: the last quarter drains from a bed too low to discharge at the steady rate.
pub const MAX_DISCHARGED_FRACTION: f64 = 0.75;
/// Q's window is cut from its end while the block rates drift by more than this fraction of Q
/// across the window (and the drift is significant at 95 %): M(t) is then not linear.
pub const MAX_RATE_DRIFT: f64 = 0.15;
/// Fewest blocks Q is averaged over (fewer give no confidence interval worth the name).
const MIN_BLOCKS: usize = 3;

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
    /// (t since opening (s), cumulative mass (kg), cumulative count) at the orifice plane.
    pub samples: Vec<(f64, f64, u64)>,
    /// Every exit: (time it crossed the orifice plane, s since opening; mass, kg).
    pub exits: Vec<(f64, f64)>,
    pub mass_kg: f64,
    pub count: u64,
    /// Free-fall time from the orifice plane to the sink, √(2h/g) (s): a removal reported at
    /// t crossed the plane at t minus this. 0 in a checkpoint of an older sweep, which counted
    /// exits at the sink.
    #[serde(default)]
    pub fall_time_s: f64,
    /// Mass in the silo at opening (kg) when it is not refilled; None when removed particles
    /// are re-inserted (the bed does not run low).
    #[serde(default)]
    pub initial_mass_kg: Option<f64>,
}

/// The result of a discharge.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DischargeSummary {
    pub q_kg_per_s: Option<f64>,
    pub q_ci95_kg_per_s: Option<f64>,
    pub q_method: String,
    /// Blocks Q is the mean of (its CI is t over them): replicas are pooled by it.
    #[serde(default)]
    pub q_blocks: usize,
    pub flowing_time_s: f64,
    pub clogs: Vec<Clog>,
    pub permanently_clogged: bool,
}

impl Discharge {
    /// An observer counting exits at the sink itself (no fall time) of a refilled silo.
    pub fn new(settings: DischargeSettings) -> Self {
        Self {
            settings,
            samples: vec![(0.0, 0.0, 0)],
            exits: Vec::new(),
            mass_kg: 0.0,
            count: 0,
            fall_time_s: 0.0,
            initial_mass_kg: None,
        }
    }

    /// An observer counting exits at the orifice plane of a silo whose sink lies
    /// `sink_depth_m` below it under gravity `g_m_per_s2`; `initial_mass_kg` bounds Q's window
    /// when the silo is not refilled (None when it is).
    pub fn at_orifice(
        settings: DischargeSettings,
        sink_depth_m: f64,
        g_m_per_s2: f64,
        initial_mass_kg: Option<f64>,
    ) -> Self {
        Self {
            fall_time_s: (2.0 * sink_depth_m.max(0.0) / g_m_per_s2).sqrt(),
            initial_mass_kg,
            ..Self::new(settings)
        }
    }

    /// Records a particle removed by the sink at `t_sink` (s since opening): it crossed the
    /// orifice plane one fall time earlier.
    pub fn record_exit(&mut self, t_sink: f64, mass: f64) {
        self.exits
            .push(((t_sink - self.fall_time_s).max(0.0), mass));
        self.mass_kg += mass;
        self.count += 1;
    }

    /// The latest time (s since opening) up to which every crossing of the orifice plane is
    /// known at time `t_now`.
    pub fn known_until(&self, t_now: f64) -> f64 {
        t_now - self.fall_time_s
    }

    /// Records M at the orifice plane as known at time `t_now` (s since opening): every exit
    /// reported so far crossed the plane by `known_until(t_now)`, which dates the sample.
    pub fn sample(&mut self, t_now: f64) {
        let t = self.known_until(t_now);
        if t > 0.0 {
            self.samples.push((t, self.mass_kg, self.count));
        }
    }

    /// Time since the last particle left (or since opening), as known at time `t_now`.
    pub fn quiet_for(&self, t_now: f64) -> f64 {
        self.known_until(t_now) - self.exits.last().map_or(0.0, |e| e.0)
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
        self.flowing_at(t, self.known_until(t_end)).unwrap_or(true)
    }

    /// Whether the silo is permanently clogged at time t.
    pub fn permanently_clogged(&self, t: f64) -> bool {
        self.quiet_for(t) >= self.settings.permanent_clog_after_s
    }

    /// Clogs, flowing intervals and Q at the end time `t_end` (s since opening).
    pub fn summarize(&self, t_end: f64) -> DischargeSummary {
        let st = &self.settings;
        // Crossings are known up to one fall time before the end.
        let horizon = self.known_until(t_end);
        // Gaps between successive exits (and from the last exit to the horizon) longer than the
        // clog time are clogs; everything else after the initial transient is flowing.
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
        let permanently = horizon - prev >= st.permanent_clog_after_s;
        if horizon - prev > st.clog_after_s {
            clogs.push(Clog {
                start_s: prev,
                duration_s: horizon - prev,
                permanent: permanently,
            });
        }
        // Flowing intervals: [skip, horizon] minus clogs.
        let mut intervals: Vec<(f64, f64)> = Vec::new();
        let mut start = st.skip_initial_s;
        for c in &clogs {
            let (a, b) = (c.start_s, c.start_s + c.duration_s);
            if a > start {
                intervals.push((start, a));
            }
            start = start.max(b);
        }
        if horizon > start {
            intervals.push((start, horizon));
        }
        let flowing = intervals.iter().map(|(a, b)| b - a).sum();
        let window_end = self.linear_window_end(horizon);
        let blocks = self.linear_blocks(&intervals, window_end);
        let rates: Vec<f64> = blocks.iter().map(|b| b.1).collect();
        let (q, ci) = match mean_ci95(&rates) {
            Some((m, h)) if rates.len() >= MIN_BLOCKS => (Some(m), Some(h)),
            _ => (None, None),
        };
        let drift = rate_drift(&blocks).map_or_else(|| "-".into(), |d| format!("{d:.3}"));
        let mfrac = self.initial_mass_kg.map_or_else(
            || "refilled".into(),
            |_| format!("0-{MAX_DISCHARGED_FRACTION}"),
        );
        DischargeSummary {
            q_kg_per_s: q,
            q_ci95_kg_per_s: ci,
            // A short code, the same for every row but for its numbers (docs/design.md).
            q_method: format!(
                "blocks:dt={},skip={},clog={},exit=orifice-{:.4}s,mfrac={mfrac},t_end={:.3},drift={drift},n={}",
                st.block_s,
                st.skip_initial_s,
                st.clog_after_s,
                self.fall_time_s,
                blocks.last().map_or(window_end, |b| b.0 + 0.5 * st.block_s),
                rates.len()
            ),
            q_blocks: rates.len(),
            flowing_time_s: flowing,
            clogs,
            permanently_clogged: permanently,
        }
    }

    /// The end of the window where M(t) can be linear: the horizon, or for a silo that is not
    /// refilled the time at which [`MAX_DISCHARGED_FRACTION`] of its mass had left.
    fn linear_window_end(&self, horizon: f64) -> f64 {
        let Some(m0) = self.initial_mass_kg.filter(|m| *m > 0.0) else {
            return horizon;
        };
        let mut m = 0.0;
        for &(t, dm) in &self.exits {
            m += dm;
            if m > MAX_DISCHARGED_FRACTION * m0 {
                return t.min(horizon);
            }
        }
        horizon
    }

    /// Blocks of `block_s` within the flowing `intervals` before `end`, as (midpoint (s), mass
    /// flow rate (kg/s)), then cut from the end while their rates drift (M(t) curved).
    fn linear_blocks(&self, intervals: &[(f64, f64)], end: f64) -> Vec<(f64, f64)> {
        let dt = self.settings.block_s;
        let mut blocks = Vec::new();
        for &(a, b) in intervals {
            let len = b.min(end) - a;
            let nb = if len > 0.0 {
                (len / dt).floor() as usize
            } else {
                0
            };
            for k in 0..nb {
                let (t0, t1) = (a + k as f64 * dt, a + (k + 1) as f64 * dt);
                let m: f64 = self
                    .exits
                    .iter()
                    .filter(|e| e.0 > t0 && e.0 <= t1)
                    .map(|e| e.1)
                    .sum();
                blocks.push((0.5 * (t0 + t1), m / dt));
            }
        }
        while blocks.len() > MIN_BLOCKS && drifts(&blocks) {
            blocks.pop();
        }
        blocks
    }
}

/// The change of the block rates across the window relative to their mean, from a straight
/// line through them: slope × (last − first midpoint) / mean. None with < 3 blocks.
fn rate_drift(blocks: &[(f64, f64)]) -> Option<f64> {
    if blocks.len() < MIN_BLOCKS {
        return None;
    }
    let (t, r): (Vec<f64>, Vec<f64>) = blocks.iter().copied().unzip();
    let fit = linear_fit(&t, &r)?;
    let mean = r.iter().sum::<f64>() / r.len() as f64;
    (mean > 0.0).then(|| fit.slope * (t[t.len() - 1] - t[0]) / mean)
}

/// Whether the block rates drift more than [`MAX_RATE_DRIFT`] and significantly (the slope's
/// 95 % interval excludes 0).
fn drifts(blocks: &[(f64, f64)]) -> bool {
    let (t, r): (Vec<f64>, Vec<f64>) = blocks.iter().copied().unzip();
    let Some(fit) = linear_fit(&t, &r) else {
        return false;
    };
    let significant = fit.slope_se.is_finite()
        && fit.slope.abs() > student_t_975(blocks.len() - 2) * fit.slope_se;
    significant && rate_drift(blocks).is_some_and(|d| d.abs() > MAX_RATE_DRIFT)
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
    fn exits_are_dated_at_the_orifice_plane_by_the_fall_time() {
        let mut d = Discharge::at_orifice(DischargeSettings::default(), 0.05, 9.81, None);
        let fall = (2.0 * 0.05 / 9.81f64).sqrt();
        assert!((d.fall_time_s - fall).abs() < 1e-15);
        // Flow until the sink reports 1.0 s, a 2 s gap at the sink, then flow again.
        for k in 1..=100 {
            d.record_exit(f64::from(k) * 0.01, 1e-3);
        }
        for k in 0..100 {
            d.record_exit(3.0 + f64::from(k) * 0.01, 1e-3);
        }
        let s = d.summarize(4.3);
        assert_eq!(s.clogs.len(), 1);
        let c = s.clogs[0];
        assert!((c.start_s - (1.0 - fall)).abs() < 1e-12, "{c:?}");
        assert!((c.duration_s - 2.0).abs() < 1e-12, "{c:?}");
        // M(t) samples are dated when every crossing up to them is known.
        d.sample(5.0);
        assert!((d.samples.last().expect("sample").0 - (5.0 - fall)).abs() < 1e-12);
        assert!(s
            .q_method
            .starts_with("blocks:dt=0.5,skip=0.5,clog=0.5,exit=orifice-0.1010s"));
    }

    #[test]
    fn q_is_fitted_where_m_is_linear_not_while_the_bed_runs_low() {
        // 1 kg in a silo that is not refilled: 0.1 kg/s until half is out, then slowing down
        // as the bed runs low, to 0.03 kg/s when 85 % is out.
        let settings = DischargeSettings {
            skip_initial_s: 0.5,
            block_s: 0.5,
            ..Default::default()
        };
        let mut d = Discharge::at_orifice(settings, 0.0, 9.81, Some(1.0));
        let (mut t, mut m) = (0.0, 0.0);
        while m < 0.85 {
            let rate = if m < 0.5 {
                0.1
            } else {
                0.1 - 0.07 * (m - 0.5) / 0.35
            };
            t += 1e-3 / rate;
            d.record_exit(t, 1e-3);
            m += 1e-3;
        }
        let s = d.summarize(t);
        let q = s.q_kg_per_s.expect("Q");
        assert!((q - 0.1).abs() < 0.003, "Q = {q}: {}", s.q_method);
        assert!(s.q_method.contains("mfrac=0-0.75"), "{}", s.q_method);
        // Every block to the end would average in the slow tail.
        let all: Vec<f64> = (1..(t / 0.5) as usize)
            .map(|k| {
                let (a, b) = (0.5 * k as f64, 0.5 * (k + 1) as f64);
                d.exits.iter().filter(|e| e.0 > a && e.0 <= b).count() as f64 * 1e-3 / 0.5
            })
            .collect();
        let naive = all.iter().sum::<f64>() / all.len() as f64;
        assert!(naive < 0.09, "the test must tell the two apart: {naive}");
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
