//! Settings of the silo's coarse-grained field observer (`observers.fields` of a silo campaign),
//! each recorded with the job, and their check against the job's silo.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::observe::discharge::DischargeSettings;
use crate::scene::silo::SiloParams;

/// Coarse-grained fields of a silo job: φ, P, V, σᵏ (and σᶜ on request) on an (r, z) grid
/// averaged over θ, snapshot-averaged around `map_times_s`, averaged over the whole discharge
/// from `mean_start_s`, and ⟨p^k⟩ in the orifice cylinder per sample.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct SiloFieldSettings {
    /// Gaussian width w (m); absent: the mean particle radius (the paper's choice).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kernel_width_m: Option<f64>,
    /// Cutoff c in widths (the kernel is 0 beyond c·w). 3 keeps the jump at the cut at
    /// e^{−4.5} = 1 % of the peak and costs (3/4)² of the chute's 4 in (r, z) points.
    pub cutoff_widths: f64,
    /// Grid spacing in r and z (m); absent: w (the fields vary on the scale w, so a finer grid
    /// adds cost and no information).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spacing_m: Option<f64>,
    /// Lowest z of the grid (m, < 0: below the orifice plate); absent: −D (the orifice
    /// diameter), where the falling jet has left the free-fall arch. Rounded down to a multiple
    /// of the spacing so that a row of points lies on z = 0 (fig9's orifice profiles).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub z_min_m: Option<f64>,
    /// Highest z of the grid (m); absent: the cylinder height.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub z_max_m: Option<f64>,
    /// Time between samples (s); a multiple of `observers.discharge.sample_interval_s` (samples
    /// are taken at chunk boundaries so a resumed run takes the same ones). 0.05 s as the chute.
    pub sample_interval_s: f64,
    /// Centres of the snapshot maps (s after opening): the paper's fig6–8 show t = 3, 6, 9, 11 s;
    /// a short campaign scales them into its `discharge_time_s`.
    pub map_times_s: Vec<f64>,
    /// Each map averages the samples within ± half this window of its time (s); one sample
    /// interval gives a single snapshot.
    pub map_window_s: f64,
    /// The whole-run mean (fig9, fig10) and the orifice series start here (s after opening): the
    /// start-up transient is left out, as Q's `skip_initial_s`.
    pub mean_start_s: f64,
    /// Also compute the contact stress σᶜ (needs the engine's contact list at each sample:
    /// costlier; fig6–11 need only the kinetic stress).
    pub contact_stress: bool,
    /// Also average the fields on a Cartesian grid of this spacing (m) over the silo's box (for
    /// 3-D viewing); absent: none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cartesian_spacing_m: Option<f64>,
}

impl Default for SiloFieldSettings {
    fn default() -> Self {
        Self {
            kernel_width_m: None,
            cutoff_widths: 3.0,
            spacing_m: None,
            z_min_m: None,
            z_max_m: None,
            sample_interval_s: 0.05,
            map_times_s: vec![3.0, 6.0, 9.0, 11.0],
            map_window_s: 0.25,
            mean_start_s: 0.5,
            contact_stress: false,
            cartesian_spacing_m: None,
        }
    }
}

impl SiloFieldSettings {
    /// Every out-of-range setting on its own, as (field, message).
    pub fn problems(&self) -> Vec<(String, String)> {
        let mut p = Vec::new();
        let mut positive = |field: &str, v: f64, unit: &str| {
            if !(v > 0.0 && v.is_finite()) {
                p.push((field.to_string(), format!("expected {unit} > 0, got {v}")));
            }
        };
        positive("cutoff_widths", self.cutoff_widths, "widths");
        positive("sample_interval_s", self.sample_interval_s, "seconds");
        positive("map_window_s", self.map_window_s, "seconds");
        for (f, v) in [
            ("kernel_width_m", self.kernel_width_m),
            ("spacing_m", self.spacing_m),
            ("cartesian_spacing_m", self.cartesian_spacing_m),
        ] {
            if let Some(v) = v {
                positive(f, v, "metres");
            }
        }
        if !(self.mean_start_s >= 0.0 && self.mean_start_s.is_finite()) {
            p.push((
                "mean_start_s".into(),
                format!("expected seconds >= 0, got {}", self.mean_start_s),
            ));
        }
        for (k, t) in self.map_times_s.iter().enumerate() {
            if !(*t >= 0.0 && t.is_finite()) {
                p.push((
                    format!("map_times_s[{k}]"),
                    format!("expected seconds >= 0 after opening, got {t}"),
                ));
            }
        }
        if let (Some(lo), Some(hi)) = (self.z_min_m, self.z_max_m) {
            if !(hi > lo) {
                p.push((
                    "z_max_m".into(),
                    format!("expected more than z_min_m = {lo} m, got {hi}"),
                ));
            }
        }
        if let Some(z) = self.z_min_m {
            if !(z <= 0.0) {
                p.push((
                    "z_min_m".into(),
                    format!("expected metres <= 0 (the orifice plate is z = 0), got {z}"),
                ));
            }
        }
        p
    }

    /// Problems of these settings with one job's silo and discharge observer, as (field,
    /// message).
    pub fn problems_with(
        &self,
        silo: &SiloParams,
        discharge: &DischargeSettings,
    ) -> Vec<(String, String)> {
        let mut p = Vec::new();
        let ratio = self.sample_interval_s / discharge.sample_interval_s;
        if (ratio - ratio.round()).abs() > 1e-6 || ratio.round() < 1.0 {
            p.push((
                "sample_interval_s".into(),
                format!(
                    "expected a whole multiple of observers.discharge.sample_interval_s = {} s (samples fall on chunk boundaries), got {}",
                    discharge.sample_interval_s, self.sample_interval_s
                ),
            ));
        }
        for (k, t) in self.map_times_s.iter().enumerate() {
            if *t > silo.discharge_time_s {
                p.push((
                    format!("map_times_s[{k}]"),
                    format!(
                        "expected a time within discharge_time_s = {} s, got {t}",
                        silo.discharge_time_s
                    ),
                ));
            }
        }
        if self.mean_start_s >= silo.discharge_time_s {
            p.push((
                "mean_start_s".into(),
                format!(
                    "expected less than discharge_time_s = {} s, got {}",
                    silo.discharge_time_s, self.mean_start_s
                ),
            ));
        }
        p
    }

    /// Kernel width w (m) for `silo`.
    pub fn width_m(&self, silo: &SiloParams) -> f64 {
        self.kernel_width_m
            .unwrap_or(0.5 * silo.particle_diameter_m)
    }

    /// Grid spacing (m) for `silo`.
    pub fn spacing_for(&self, silo: &SiloParams) -> f64 {
        self.spacing_m.unwrap_or_else(|| self.width_m(silo))
    }
}
