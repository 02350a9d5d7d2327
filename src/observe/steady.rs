//! Steady-state detection for the chute (paper §2.3: run until the kinetic energy is constant,
//! and check σ_xz/σ_zz = tan α, Eq. 2). Over a window [t − T_w, t] the flow is steady when
//! - the kinetic energy and the bulk mean velocity V_x have no trend, within a relative
//!   tolerance and within the trend's own batch-means error (`stationarity::trend`), and
//! - the mean bulk stress ratio μ (`coarse_grain::bulk_stress_ratio`, → tan α) is within
//!   `tol_ratio` of tan α, relatively.
//!
//! A bed whose mean V_x over the window is below `min_flow_velocity_m_per_s` is not flowing: no
//! trend test means anything there (a bed at rest on an incline satisfies μ = tan α too).
//!
//! The same check runs on the transient's trailing window (streaming: only the window's samples
//! are kept) and, after the measurement, on the whole measurement window.

use std::collections::VecDeque;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::stationarity::{trend, Trend};
use crate::scene::ChuteParams;

/// Thresholds of the steady-state criteria (recorded with each job through its parameters).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct SteadySettings {
    /// Trailing window T_w (s) while waiting for the steady state.
    pub window_s: f64,
    /// Largest relative change of the kinetic energy over a window.
    pub tol_ke: f64,
    /// Largest relative change of the bulk mean V_x over a window.
    pub tol_vx: f64,
    /// Largest |μ − tan α|/tan α of the window's mean ratio.
    pub tol_ratio: f64,
    /// Batch means per window for the trends' errors.
    pub batches: usize,
    /// Below this mean V_x (m/s) the bed is not flowing.
    pub min_flow_velocity_m_per_s: f64,
    /// The change a trend makes is judged over this span (s) when it is longer than the
    /// window's: waiting for the steady state, the coming measurement's length, so that a flow
    /// passes only if its trend would stay within tolerance while it is measured.
    pub horizon_s: f64,
}

impl SteadySettings {
    /// A chute job's criteria over a window of `window_s` seconds, trends judged over the
    /// measurement's length when it is longer.
    pub fn of_chute(p: &ChuteParams, window_s: f64) -> Self {
        Self {
            horizon_s: p.measure_time_s,
            window_s,
            tol_ke: p.steady_kinetic_tolerance,
            tol_vx: p.steady_velocity_tolerance,
            tol_ratio: p.steady_stress_tolerance,
            batches: p.steady_batches,
            min_flow_velocity_m_per_s: p.min_flow_velocity_m_per_s(),
        }
    }
}

impl Default for SteadySettings {
    fn default() -> Self {
        Self {
            window_s: 20.0,
            tol_ke: 0.02,
            tol_vx: 0.02,
            tol_ratio: 0.05,
            batches: 8,
            min_flow_velocity_m_per_s: 0.0,
            horizon_s: 0.0,
        }
    }
}

/// One sample of the flow: time (s), kinetic energy of the flowing particles (J), their mean
/// V_x (m/s), and the bulk stress ratio when it was sampled.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FlowSample {
    pub t: f64,
    pub ke: f64,
    pub vx: f64,
    pub ratio: Option<f64>,
}

/// The criteria evaluated on one window.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct WindowCheck {
    /// First and last sample times of the window (s).
    pub start_s: f64,
    pub time_s: f64,
    /// Trend of the kinetic energy; None with too few samples for the batches.
    pub ke: Option<Trend>,
    /// Trend of the bulk mean V_x; None likewise, or when its mean is zero.
    pub vx: Option<Trend>,
    /// Mean V_x over the window (m/s).
    pub mean_vx_m_per_s: f64,
    /// Mean μ over the window; None when no ratio was sampled in it.
    pub stress_ratio: Option<f64>,
    /// Whether μ is within tolerance of tan α.
    pub ratio_ok: bool,
    /// Whether the mean V_x reaches `min_flow_velocity_m_per_s`.
    pub flowing: bool,
    /// Flowing, both trends passed, and μ within tolerance.
    pub steady: bool,
}

/// The criteria on `samples` (times increasing), or None when they hold fewer than two samples
/// per batch.
pub fn check_window(
    samples: &[FlowSample],
    settings: &SteadySettings,
    tan_alpha: f64,
) -> Option<WindowCheck> {
    let st = settings;
    let (first, last) = (samples.first()?, samples.last()?);
    if samples.len() < 2 * st.batches {
        return None;
    }
    let t: Vec<f64> = samples.iter().map(|s| s.t).collect();
    let ke: Vec<f64> = samples.iter().map(|s| s.ke).collect();
    let vx: Vec<f64> = samples.iter().map(|s| s.vx).collect();
    let mean_vx = vx.iter().sum::<f64>() / vx.len() as f64;
    let span = last.t - first.t;
    let over_horizon = |tr: Option<Trend>, tol: f64| {
        tr.map(|mut tr| {
            if st.horizon_s > span && span > 0.0 {
                tr.relative_change *= st.horizon_s / span;
                tr.passed = tr.relative_change <= tol && tr.t_statistic <= tr.t_critical;
            }
            tr
        })
    };
    let ke = over_horizon(trend(&t, &ke, st.batches, st.tol_ke), st.tol_ke);
    let vx = over_horizon(trend(&t, &vx, st.batches, st.tol_vx), st.tol_vx);
    let ratios: Vec<f64> = samples.iter().filter_map(|s| s.ratio).collect();
    let ratio = (!ratios.is_empty()).then(|| ratios.iter().sum::<f64>() / ratios.len() as f64);
    let ratio_ok = ratio.is_some_and(|r| ((r - tan_alpha) / tan_alpha).abs() < st.tol_ratio);
    let flowing = mean_vx >= st.min_flow_velocity_m_per_s;
    let passed = |t: Option<Trend>| t.is_some_and(|t| t.passed);
    Some(WindowCheck {
        start_s: first.t,
        time_s: last.t,
        ke,
        vx,
        mean_vx_m_per_s: mean_vx,
        stress_ratio: ratio,
        ratio_ok,
        flowing,
        steady: flowing && passed(ke) && passed(vx) && ratio_ok,
    })
}

/// Streaming detector over the trailing window (checkpointed with its job).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SteadyDetector {
    pub settings: SteadySettings,
    tan_alpha: f64,
    first_time_s: Option<f64>,
    window: VecDeque<FlowSample>,
}

impl SteadyDetector {
    /// A detector for a chute inclined at `inclination_deg`.
    pub fn new(settings: SteadySettings, inclination_deg: f64) -> Self {
        Self {
            settings,
            tan_alpha: inclination_deg.to_radians().tan(),
            first_time_s: None,
            window: VecDeque::new(),
        }
    }

    /// tan α of the chute.
    pub fn tan_alpha(&self) -> f64 {
        self.tan_alpha
    }

    /// Adds a sample (times increasing) and returns the criteria on the trailing window once
    /// the series spans a whole window.
    pub fn push(&mut self, s: FlowSample) -> Option<WindowCheck> {
        self.first_time_s.get_or_insert(s.t);
        self.window.push_back(s);
        let start = s.t - self.settings.window_s;
        // The 10⁻⁹ keeps a sample exactly T_w old despite rounding in t.
        while self
            .window
            .front()
            .is_some_and(|w| w.t < start - 1e-9 * self.settings.window_s)
        {
            self.window.pop_front();
        }
        if s.t - self.first_time_s? < self.settings.window_s * (1.0 - 1e-9) {
            return None;
        }
        check_window(
            self.window.make_contiguous(),
            &self.settings,
            self.tan_alpha,
        )
    }
}

/// The first steady window of a whole series (times increasing).
pub fn first_steady(
    series: &[FlowSample],
    inclination_deg: f64,
    settings: &SteadySettings,
) -> Option<WindowCheck> {
    let mut d = SteadyDetector::new(settings.clone(), inclination_deg);
    series.iter().find_map(|&s| d.push(s).filter(|c| c.steady))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings() -> SteadySettings {
        SteadySettings {
            window_s: 10.0,
            min_flow_velocity_m_per_s: 0.05,
            ..SteadySettings::default()
        }
    }

    fn sample(t: f64, ke: f64, vx: f64) -> FlowSample {
        // μ sampled every tenth sample, at tan 30°.
        let ratio = ((t * 10.0).round() as i64 % 10 == 0).then(|| 30f64.to_radians().tan());
        FlowSample { t, ke, vx, ratio }
    }

    #[test]
    fn a_rising_flow_waits_and_a_constant_one_is_steady() {
        let mut d = SteadyDetector::new(settings(), 30.0);
        let mut first = None;
        for k in 0..400 {
            let t = 0.1 * k as f64;
            // Kinetic energy and V_x rise until t = 20 s, then stay (with a small wobble).
            let level = (t / 20.0).min(1.0);
            let wobble = 1.0 + 0.001 * (3.0 * t).sin();
            if let Some(c) = d.push(sample(t, 100.0 * level * wobble, 2.0 * level * wobble)) {
                if c.steady && first.is_none() {
                    first = Some(c.time_s);
                }
            }
        }
        // The window must lie (almost) past the ramp: at t = 28 s the window's first batch still
        // holds 4 % of ramp, a trend of ~4 % (over the 2 % tolerance); by 30 s none is left.
        let t = first.expect("steady");
        assert!((28.0..=30.0).contains(&t), "steady at {t}");
    }

    #[test]
    fn a_bed_at_rest_is_not_flowing_and_not_steady() {
        let mut d = SteadyDetector::new(settings(), 30.0);
        let mut last = None;
        for k in 0..200 {
            let t = 0.1 * k as f64;
            last = d.push(sample(t, 1e-3, 0.01)).or(last);
        }
        let c = last.unwrap();
        assert!(!c.flowing && !c.steady && c.ratio_ok);
    }

    #[test]
    fn a_trend_is_judged_over_the_coming_measurement() {
        // 1.5 % over a 10 s window: within 2 %, but 6 % over a 40 s measurement.
        let s: Vec<FlowSample> = (0..101)
            .map(|k| {
                let t = 0.1 * k as f64;
                let v = 1.0 + 0.0015 * t;
                sample(t, 10.0 * v, v)
            })
            .collect();
        let tan = 30f64.to_radians().tan();
        let window = check_window(&s, &settings(), tan).unwrap();
        // (A noiseless line is a significant trend: only the tolerance criterion is at stake.)
        assert!(window.vx.unwrap().relative_change < 0.02, "{window:?}");
        let horizon = SteadySettings {
            horizon_s: 40.0,
            ..settings()
        };
        let c = check_window(&s, &horizon, tan).unwrap();
        let vx = c.vx.unwrap();
        assert!((vx.relative_change - 4.0 * window.vx.unwrap().relative_change).abs() < 1e-12);
        assert!(vx.relative_change > 0.02 && !c.steady && !vx.passed);
    }

    #[test]
    fn a_wrong_stress_ratio_is_not_steady() {
        let st = settings();
        let s: Vec<FlowSample> = (0..100)
            .map(|k| FlowSample {
                t: 0.1 * k as f64,
                ke: 10.0,
                vx: 1.0,
                ratio: Some(0.9 * 30f64.to_radians().tan()),
            })
            .collect();
        let c = check_window(&s, &st, 30f64.to_radians().tan()).unwrap();
        assert!(c.flowing && c.ke.unwrap().passed && c.vx.unwrap().passed);
        assert!(!c.ratio_ok && !c.steady);
    }
}
