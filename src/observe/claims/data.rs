//! What a claim is evaluated on: the campaign's points, each with its swept parameters and its
//! pooled results (mean, standard error, degrees of freedom), and the results each scene gives.

use std::collections::BTreeMap;

use super::spec::At;

/// A pooled result at one point: its mean, the standard error of the mean and the degrees of
/// freedom of that error (blocks and replicas pooled as the figures pool them).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    pub mean: f64,
    pub se: f64,
    pub dof: f64,
}

/// One point of a campaign: the parameters that tell it from the others, its results by key
/// ([`result_key`]) and what it cost so far.
#[derive(Clone, Debug, PartialEq)]
pub struct PointData {
    /// Its label without `replica=K`.
    pub label: String,
    /// Every numeric parameter of its jobs (scene parameters by name).
    pub params: BTreeMap<String, f64>,
    pub results: BTreeMap<String, Estimate>,
    /// Why it has no results yet (every run clogged; fewer than 3 steady chute replicas), if so.
    pub missing: Option<String>,
    /// Every run of the point clogged for good: it has no flow to measure. Fits and series
    /// leave it out, as the figures do; a `compare` that names it stays undecided.
    pub clogged: bool,
    /// Steady replicas a chute point still lacks before it has results (0 otherwise).
    pub replicas_short: u32,
    /// Particle-steps its jobs ran.
    pub particle_steps: f64,
}

/// Scene constants some tests need (Beverloo's ρ_b, √g; D_min over d).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneConstants {
    pub particle_diameter_m: f64,
    pub bulk_density_kg_per_m3: f64,
    pub gravity_m_per_s2: f64,
}

/// Results a silo point gives: Q (kg/s) and, from the fields observer, ⟨p^k⟩ in the orifice
/// cylinder over the flowing samples (Pa, the paper's Fig. 11) and the ratio of the descent
/// beside the wall to that on the axis just above the orifice (the flow pattern of Figs. 6–8,
/// `pooled::flow_pattern`; at least two replicas).
pub const SILO_RESULTS: &[&str] = &["q", "kinetic_pressure", "wall_to_axis_descent"];

/// Results a chute point gives, each over the central bed (0.3 H < z < 0.7 H, the paper's
/// 6 L < z < 14 L, the mean of its blocks) and in a block ("D@k", heights k L to (k + 1) L):
/// D (m²/s), γ̇ (1/s), D/γ̇ (m²), V_x (m/s), φ, d⊥² (m²), γ̇ d⊥² (m²/s), the skewness of v_z, the
/// correlation length of the velocity fluctuations (m), and the profiles of Figs. 3–4: D/D_max,
/// γ̇/γ̇_max (each replica's profile over its own maximum) and their gap D/D_max − γ̇/γ̇_max.
/// Then the results over part of the bed only ([`CHUTE_BED_ONLY`]).
pub const CHUTE_RESULTS: &[&str] = &[
    "D",
    "shear_rate",
    "D_over_shear_rate",
    "V_x",
    "phi",
    "d_perp2",
    "shear_rate_d_perp2",
    "vz_skewness",
    "correlation_length",
    "D_norm",
    "shear_rate_norm",
    "profile_gap",
    "profile_gap_rms",
    "profile_gap_rms_base",
    "vz_skewness_base",
    "vz_skewness_surface",
];

/// Chute results over a part of the bed, with no value per block: the rms of the profile gap
/// over the central bed and over the base (z < 0.25 H, the paper's z < 5 L), and the skewness
/// of v_z in the lowest block and in the highest full block (under the free surface).
pub const CHUTE_BED_ONLY: &[&str] = &[
    "profile_gap_rms",
    "profile_gap_rms_base",
    "vz_skewness_base",
    "vz_skewness_surface",
];

/// The key of `result` in [`PointData::results`]: the name, or "name@k" in block k.
pub fn result_key(result: &str, block: Option<i64>) -> String {
    match block {
        Some(k) => format!("{result}@{k}"),
        None => result.to_string(),
    }
}

/// Whether two parameter values are one setting (a text round trip's tolerance).
pub fn same_value(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1e-12)
}

/// Whether `p` has every parameter of `at` at its value.
pub fn matches(p: &PointData, at: &At) -> bool {
    at.iter()
        .all(|(k, v)| p.params.get(k).is_some_and(|x| same_value(*x, *v)))
}

/// Indices of the points matching `at`.
pub fn select(points: &[PointData], at: &At) -> Vec<usize> {
    (0..points.len())
        .filter(|&i| matches(&points[i], at))
        .collect()
}
