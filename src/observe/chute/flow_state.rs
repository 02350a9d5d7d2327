//! How a chute job's flow ended up, and the stationarity criteria behind the verdict: checked on
//! the transient's last window (when measurement started, or at `steady_max_time_s`) and again
//! on the measurement window. Stored in `chute_flow_state` and `chute_stationarity`.
//!
//! The two windows are read differently. Measurement starts only once the transient's trends
//! are small *and* within their error (`stationarity::trend` passes). A measured window is
//! discarded only for a drift, a trend beyond its tolerance *and* significant
//! (`stationarity::is_drift`): in a small bed the mean V_x swings by several per cent over
//! tens of seconds, and a window whose trend those swings could make measures the same flow.

use serde::{Deserialize, Serialize};

use crate::observe::stationarity::is_drift;
use crate::observe::steady::WindowCheck;
use crate::scene::ChuteParams;

/// The verdict on a chute job's flow.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FlowState {
    /// Steady when measurement started and over the whole measurement window.
    Steady,
    /// Steady when measurement started, but the flow drifted while it was measured.
    Drifted,
    /// Never steady before `steady_max_time_s` (measured only with `measure_unsteady`).
    NotSteady,
    /// The bed's mean velocity fell below the flowing threshold: no D(z) is fitted.
    NotFlowing,
    /// Steady, but ordered in layers (`layering`): judged when results are read, from the
    /// stored density profile, never stored; left out of figures and claims like the others.
    Layered,
}

impl FlowState {
    /// The name stored in `chute_flow_state.state`.
    pub fn as_str(self) -> &'static str {
        match self {
            FlowState::Steady => "steady",
            FlowState::Drifted => "drifted",
            FlowState::NotSteady => "not_steady",
            FlowState::NotFlowing => "not_flowing",
            FlowState::Layered => "layered",
        }
    }

    /// Words for a report or a log line.
    pub fn words(self) -> &'static str {
        match self {
            FlowState::Steady => "steady",
            FlowState::Drifted => "drifted while measured",
            FlowState::NotSteady => "not steady by steady_max_time_s",
            FlowState::NotFlowing => "not flowing",
            FlowState::Layered => "steady but in ordered layers",
        }
    }

    /// Parses a stored name.
    pub fn parse(s: &str) -> Option<FlowState> {
        [
            FlowState::Steady,
            FlowState::Drifted,
            FlowState::NotSteady,
            FlowState::NotFlowing,
            FlowState::Layered,
        ]
        .into_iter()
        .find(|f| f.as_str() == s)
    }

    /// The verdict from the transient's last check and, when the job measured, the
    /// measurement window's.
    pub fn judge(
        transient: Option<&WindowCheck>,
        measurement: Option<&WindowCheck>,
        tolerances: TrendTolerances,
    ) -> FlowState {
        let flowing = |c: Option<&WindowCheck>| c.is_none_or(|c| c.flowing);
        if !flowing(transient) || !flowing(measurement) {
            return FlowState::NotFlowing;
        }
        if !transient.is_some_and(|c| c.steady) {
            return FlowState::NotSteady;
        }
        match measurement.map(MeasuredWindow::of) {
            Some(m) if !m.drifted(tolerances) => FlowState::Steady,
            // Too few samples to test the measurement is no evidence of a steady flow.
            _ => FlowState::Drifted,
        }
    }

    /// A stored verdict read under today's rule: a job recorded as drifted by a build that
    /// discarded every window whose trend was not within its tolerance and its error reads as
    /// steady when its stored measurement window (`window`) shows no drift. Other verdicts
    /// stand.
    pub fn rejudged(
        self,
        window: Option<&MeasuredWindow>,
        tolerances: Option<TrendTolerances>,
    ) -> FlowState {
        match (self, window, tolerances) {
            (FlowState::Drifted, Some(w), Some(tol)) if !w.drifted(tol) => FlowState::Steady,
            _ => self,
        }
    }
}

/// The tolerances on the relative change of the kinetic energy and of the mean V_x over a
/// window (`steady_kinetic_tolerance`, `steady_velocity_tolerance`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrendTolerances {
    pub kinetic: f64,
    pub velocity: f64,
}

impl TrendTolerances {
    /// A chute job's tolerances.
    pub fn of_chute(p: &ChuteParams) -> Self {
        Self {
            kinetic: p.steady_kinetic_tolerance,
            velocity: p.steady_velocity_tolerance,
        }
    }
}

/// What a measurement window's verdict rests on, as `chute_stationarity` stores it: each
/// trend's relative change and t statistic (None when infinite), the t quantile, and whether
/// μ was within tolerance of tan α.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeasuredWindow {
    pub ke_change: Option<f64>,
    pub ke_t: Option<f64>,
    pub vx_change: Option<f64>,
    pub vx_t: Option<f64>,
    pub t_critical: Option<f64>,
    pub ratio_ok: bool,
}

impl MeasuredWindow {
    /// The window `check` as it is stored.
    pub fn of(check: &WindowCheck) -> Self {
        let finite = |v: f64| v.is_finite().then_some(v);
        Self {
            ke_change: check.ke.map(|t| t.relative_change),
            ke_t: check.ke.and_then(|t| finite(t.t_statistic)),
            vx_change: check.vx.map(|t| t.relative_change),
            vx_t: check.vx.and_then(|t| finite(t.t_statistic)),
            t_critical: check.ke.or(check.vx).map(|t| t.t_critical),
            ratio_ok: check.ratio_ok,
        }
    }

    /// Whether the measured flow drifted: μ away from tan α, a trend that could not be tested,
    /// or a trend beyond its tolerance and significant. An infinite t statistic (a trend
    /// without scatter) is significant.
    pub fn drifted(&self, tol: TrendTolerances) -> bool {
        let Some(t_critical) = self.t_critical else {
            return true;
        };
        let drifts = |change: Option<f64>, t: Option<f64>, tol: f64| {
            change.is_none_or(|c| is_drift(c, t.unwrap_or(f64::INFINITY), t_critical, tol))
        };
        !self.ratio_ok
            || drifts(self.ke_change, self.ke_t, tol.kinetic)
            || drifts(self.vx_change, self.vx_t, tol.velocity)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TOL: TrendTolerances = TrendTolerances {
        kinetic: 0.1,
        velocity: 0.05,
    };

    fn window(vx_change: f64, vx_t: f64) -> MeasuredWindow {
        MeasuredWindow {
            ke_change: Some(0.01),
            ke_t: Some(0.5),
            vx_change: Some(vx_change),
            vx_t: Some(vx_t),
            t_critical: Some(2.776),
            ratio_ok: true,
        }
    }

    #[test]
    fn a_window_drifts_only_beyond_its_tolerance_and_its_error() {
        // 6.6 % with t = 2.06 (job 58 of the chute store): the swings could make it.
        assert!(!window(0.066, 2.06).drifted(TOL));
        // 3.5 % with t = 7.5: real, but within the tolerance.
        assert!(!window(0.035, 7.5).drifted(TOL));
        // 9.6 % with t = 4.9: a drift.
        assert!(window(0.096, 4.9).drifted(TOL));
        // A trend without scatter (t infinite, stored as None) beyond the tolerance.
        let mut w = window(0.06, 0.0);
        w.vx_t = None;
        assert!(w.drifted(TOL));
        // The kinetic energy's trend counts as the velocity's does.
        let mut w = window(0.0, 0.0);
        (w.ke_change, w.ke_t) = (Some(0.15), Some(3.0));
        assert!(w.drifted(TOL));
    }

    #[test]
    fn an_untested_window_or_a_wrong_stress_ratio_drifted() {
        let mut w = window(0.0, 0.0);
        w.vx_change = None;
        assert!(w.drifted(TOL));
        let mut w = window(0.0, 0.0);
        w.t_critical = None;
        assert!(w.drifted(TOL));
        let mut w = window(0.0, 0.0);
        w.ratio_ok = false;
        assert!(w.drifted(TOL));
    }

    #[test]
    fn only_a_drifted_verdict_is_read_again() {
        let quiet = window(0.066, 2.06);
        let moving = window(0.096, 4.9);
        let d = FlowState::Drifted;
        assert_eq!(d.rejudged(Some(&quiet), Some(TOL)), FlowState::Steady);
        assert_eq!(d.rejudged(Some(&moving), Some(TOL)), FlowState::Drifted);
        assert_eq!(d.rejudged(None, Some(TOL)), FlowState::Drifted);
        assert_eq!(d.rejudged(Some(&quiet), None), FlowState::Drifted);
        for s in [
            FlowState::Steady,
            FlowState::NotSteady,
            FlowState::NotFlowing,
            FlowState::Layered,
        ] {
            assert_eq!(s.rejudged(Some(&moving), Some(TOL)), s);
        }
    }
}

/// What a chute job records about its flow besides the measured profiles.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FlowRecord {
    pub state: FlowState,
    /// Whether the observer measured (profiles and D(z) stored).
    pub measured: bool,
    /// The flowing threshold on the bed's mean V_x (m/s).
    pub min_flow_velocity_m_per_s: f64,
    /// The criteria on the transient's last window.
    pub transient: Option<WindowCheck>,
    /// The criteria on the measurement window.
    pub measurement: Option<WindowCheck>,
}
