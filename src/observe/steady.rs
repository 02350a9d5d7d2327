//! Steady-state detection for the chute (paper §2.3: run until the kinetic energy is constant,
//! and check σ_xz/σ_zz = tan α, Eq. 2): the first time t at which, over the trailing window
//! [t − T_w, t],
//! - the kinetic energy's relative change |slope| · T_w / mean (least-squares slope) is below
//!   `tol_ke`, and
//! - the mean bulk stress ratio μ (`coarse_grain::bulk_stress_ratio`, → tan α) is within
//!   `tol_ratio` of tan α, relatively.
//!
//! Streaming: only the window's samples are kept. Once it fires, the detection is kept.

use std::collections::VecDeque;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::fits::linear_fit;

/// Thresholds of the steady-state criteria (recorded with each job).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct SteadySettings {
    /// Trailing window T_w (s). Default 20 s: ~60 √(L/g) at the paper's L = 0.125 m, g = 1 m/s²,
    /// long enough to average the stress ratio's snapshot noise, short against the ~160 s the
    /// paper's flows took to settle.
    pub window_s: f64,
    /// Largest relative change of the kinetic energy over the window. Default 0.02: an
    /// accelerating flow (above α_c2) gains more than that in 20 s.
    pub tol_ke: f64,
    /// Largest |μ − tan α|/tan α of the window's mean ratio. Default 0.05.
    pub tol_ratio: f64,
    /// Fewest kinetic-energy samples the window must hold. Default 5.
    pub min_points: usize,
}

impl Default for SteadySettings {
    fn default() -> Self {
        Self {
            window_s: 20.0,
            tol_ke: 0.02,
            tol_ratio: 0.05,
            min_points: 5,
        }
    }
}

/// The criteria evaluated on one window.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct WindowCheck {
    /// End of the window (s).
    pub time_s: f64,
    /// |slope| · T_w / mean of the kinetic energy.
    pub ke_relative_change: f64,
    /// Mean μ over the window; None when no ratio was sampled in it.
    pub stress_ratio: Option<f64>,
    /// Whether both criteria hold.
    pub steady: bool,
}

/// Streaming detector (checkpointed with its job).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SteadyDetector {
    pub settings: SteadySettings,
    tan_alpha: f64,
    first_time_s: Option<f64>,
    /// (t (s), kinetic energy (J), μ) within the trailing window.
    window: VecDeque<(f64, f64, Option<f64>)>,
    detected: Option<WindowCheck>,
}

impl SteadyDetector {
    /// A detector for a chute inclined at `inclination_deg`.
    pub fn new(settings: SteadySettings, inclination_deg: f64) -> Self {
        Self {
            settings,
            tan_alpha: inclination_deg.to_radians().tan(),
            first_time_s: None,
            window: VecDeque::new(),
            detected: None,
        }
    }

    /// Adds a sample (times increasing) and returns the detection if the state is (or already
    /// was) steady.
    pub fn push(
        &mut self,
        t: f64,
        kinetic_energy_j: f64,
        stress_ratio: Option<f64>,
    ) -> Option<WindowCheck> {
        if self.detected.is_some() {
            return self.detected;
        }
        self.first_time_s.get_or_insert(t);
        self.window.push_back((t, kinetic_energy_j, stress_ratio));
        let start = t - self.settings.window_s;
        // The 10⁻⁹ keeps a sample exactly T_w old despite rounding in t.
        while self
            .window
            .front()
            .is_some_and(|s| s.0 < start - 1e-9 * self.settings.window_s)
        {
            self.window.pop_front();
        }
        let check = self.check()?;
        if check.steady {
            self.detected = Some(check);
        }
        self.detected
    }

    /// The detection, if it fired.
    pub fn detected(&self) -> Option<WindowCheck> {
        self.detected
    }

    /// The criteria on the current window; None until the series spans a whole window with
    /// `min_points` samples, or when the energy's mean is not positive.
    pub fn check(&self) -> Option<WindowCheck> {
        let st = &self.settings;
        let &(t, _, _) = self.window.back()?;
        if t - self.first_time_s? < st.window_s * (1.0 - 1e-9) || self.window.len() < st.min_points
        {
            return None;
        }
        let (ts, ke): (Vec<f64>, Vec<f64>) = self.window.iter().map(|s| (s.0, s.1)).unzip();
        let mean_ke = ke.iter().sum::<f64>() / ke.len() as f64;
        if !(mean_ke > 0.0) {
            return None;
        }
        let change = (linear_fit(&ts, &ke)?.slope * st.window_s / mean_ke).abs();
        let ratios: Vec<f64> = self.window.iter().filter_map(|s| s.2).collect();
        let ratio = (!ratios.is_empty()).then(|| ratios.iter().sum::<f64>() / ratios.len() as f64);
        let ratio_ok =
            ratio.is_some_and(|r| ((r - self.tan_alpha) / self.tan_alpha).abs() < st.tol_ratio);
        Some(WindowCheck {
            time_s: t,
            ke_relative_change: change,
            stress_ratio: ratio,
            steady: change < st.tol_ke && ratio_ok,
        })
    }
}

/// The first steady window of a whole series (t, kinetic energy, μ), times increasing.
pub fn first_steady(
    series: &[(f64, f64, Option<f64>)],
    inclination_deg: f64,
    settings: &SteadySettings,
) -> Option<WindowCheck> {
    let mut d = SteadyDetector::new(settings.clone(), inclination_deg);
    series.iter().find_map(|&(t, ke, r)| d.push(t, ke, r))
}
