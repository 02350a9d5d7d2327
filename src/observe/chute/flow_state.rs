//! How a chute job's flow ended up, and the stationarity criteria behind the verdict: checked on
//! the transient's last window (when measurement started, or at `steady_max_time_s`) and again
//! on the measurement window. Stored in `chute_flow_state` and `chute_stationarity`.

use serde::{Deserialize, Serialize};

use crate::observe::steady::WindowCheck;

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
    pub fn judge(transient: Option<&WindowCheck>, measurement: Option<&WindowCheck>) -> FlowState {
        let flowing = |c: Option<&WindowCheck>| c.is_none_or(|c| c.flowing);
        if !flowing(transient) || !flowing(measurement) {
            return FlowState::NotFlowing;
        }
        if !transient.is_some_and(|c| c.steady) {
            return FlowState::NotSteady;
        }
        match measurement {
            Some(m) if m.steady => FlowState::Steady,
            // Too few samples to test the measurement is no evidence of a steady flow.
            _ => FlowState::Drifted,
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
