//! A fit's parameter as a statistic's value: the Janda, Beverloo, straight-line and
//! through-the-origin fits, and a trend's value per group when it runs along a fit's parameter.

use super::data::SceneConstants;
use super::spec::FitModel;
use crate::observe::fits::{beverloo_fit, janda_fit, linear_fit};

/// How one group of a series gives its value.
pub(super) enum GroupValue {
    /// The group's one cell.
    One,
    /// A fit over the group's cells (x: their orifice diameters).
    Fit {
        model: FitModel,
        parameter: String,
        d_m: Vec<Vec<f64>>,
        scene: Option<SceneConstants>,
    },
}

/// Group `g`'s value from the cell values `v` (`cells`: its cells' indices).
pub(super) fn group_value(per_group: &GroupValue, g: usize, cells: &[usize], v: &[f64]) -> f64 {
    match per_group {
        GroupValue::One => v[cells[0]],
        GroupValue::Fit {
            model,
            parameter,
            d_m,
            scene,
        } => {
            let q: Vec<f64> = cells.iter().map(|&c| v[c]).collect();
            fit_parameter(*model, parameter, &d_m[g], &q, *scene)
        }
    }
}

/// A model's parameter fitted through (x, y); NaN when the fit fails.
pub(super) fn fit_parameter(
    model: FitModel,
    parameter: &str,
    x: &[f64],
    y: &[f64],
    scene: Option<SceneConstants>,
) -> f64 {
    match model {
        FitModel::Janda => {
            let Some(f) = janda_fit(x, y, None) else {
                return f64::NAN;
            };
            match parameter {
                "c" => f.c,
                "alpha1" => f.alpha1,
                "alpha2_m" => f.alpha2_m,
                "d_min_m" => f.d_min_m.unwrap_or(f64::NAN),
                "d_min_over_d" => match (f.d_min_m, scene) {
                    (Some(d), Some(s)) => d / s.particle_diameter_m,
                    _ => f64::NAN,
                },
                _ => f64::NAN,
            }
        }
        FitModel::Beverloo => {
            let Some(s) = scene else { return f64::NAN };
            let Some(f) = beverloo_fit(
                x,
                y,
                s.particle_diameter_m,
                s.bulk_density_kg_per_m3,
                s.gravity_m_per_s2,
            ) else {
                return f64::NAN;
            };
            match parameter {
                "c" => f.c,
                "k" => f.k,
                _ => f64::NAN,
            }
        }
        FitModel::Line => {
            let Some(l) = linear_fit(x, y) else {
                return f64::NAN;
            };
            match parameter {
                "slope" => l.slope,
                "intercept" => l.intercept,
                "r" => l.r,
                _ => f64::NAN,
            }
        }
        FitModel::Proportional => {
            let sxx: f64 = x.iter().map(|a| a * a).sum();
            let sxy: f64 = x.iter().zip(y).map(|(a, b)| a * b).sum();
            match parameter {
                "slope" if sxx > 0.0 => sxy / sxx,
                "r" => linear_fit(x, y).map_or(f64::NAN, |l| l.r),
                _ => f64::NAN,
            }
        }
    }
}
