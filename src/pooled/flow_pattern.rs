//! The flow pattern of a silo job as one number (the paper's Figs. 6–8: funnel flow at f = 0,
//! mass flow under rotation): how fast the material beside the wall descends against the
//! material on the axis, both just above the orifice. In funnel flow the wall material stands
//! (near 0); in mass flow everything descends (towards 1). From each job's mean map over its
//! flowing samples; a point's value is its replicas' mean with the error of their spread.

use anyhow::Result;
use rusqlite::Connection;

use crate::observe::coarse_grain::{FieldArray, FieldSet};
use crate::observe::fits::{mean_ci95, t_975};
use crate::observe::silo_fields::MEAN_FLOWING;
use crate::store::fields::load_field_arrays;

/// The claims' name of the result.
pub const WALL_TO_AXIS_DESCENT: &str = "wall_to_axis_descent";

/// Where the two descents are read, in particle diameters d: the band 1.5 d < z < 3 d above the
/// orifice plane (low enough to stay in a draining bed); the wall annulus R_c − 2.5 d < r <
/// R_c − d (a coarse-grained field within d of the wall is cut by it), the axis r < 1.5 d.
const BAND_D: [f64; 2] = [1.5, 3.0];
const WALL_D: [f64; 2] = [2.5, 1.0];
const AXIS_D: f64 = 1.5;

/// The mean downward momentum density −P_z (kg m⁻² s⁻¹) over the rz grid points of `set` in
/// `r_range` × `z_range`; None without such a point.
fn mean_descent(
    set: &FieldSet,
    momentum: &FieldArray,
    r_range: [f64; 2],
    z_range: [f64; 2],
) -> Option<f64> {
    let (nr, nz) = (set.shape[0], set.shape[1]);
    let mut sum = 0.0;
    let mut n = 0usize;
    for jz in 0..nz {
        let z = set.coordinate(1, jz);
        if z < z_range[0] || z > z_range[1] {
            continue;
        }
        for ir in 0..nr {
            let r = set.coordinate(0, ir);
            if r < r_range[0] || r > r_range[1] {
                continue;
            }
            // Point (ir, jz) of the rz grid, axis 0 fastest; component 2 is z.
            sum -= momentum.at(jz * nr + ir, 2);
            n += 1;
        }
    }
    (n > 0).then(|| sum / n as f64)
}

/// The wall-to-axis descent ratio of one mean map; None when the grid misses either region or
/// the axis does not descend.
pub fn wall_to_axis_descent(
    set: &FieldSet,
    arrays: &[FieldArray],
    silo_radius_m: f64,
    particle_d_m: f64,
) -> Option<f64> {
    let momentum = arrays.iter().find(|a| a.field == "momentum")?;
    let band = [BAND_D[0] * particle_d_m, BAND_D[1] * particle_d_m];
    let wall = [
        silo_radius_m - WALL_D[0] * particle_d_m,
        silo_radius_m - WALL_D[1] * particle_d_m,
    ];
    let axis = mean_descent(set, momentum, [0.0, AXIS_D * particle_d_m], band)?;
    let side = mean_descent(set, momentum, wall, band)?;
    (axis > 0.0).then(|| side / axis)
}

/// One job's ratio from its flowing mean map among its field `sets`; None without one (no
/// fields, clogged throughout) or where the grid misses a region.
///
/// # Errors
/// Database errors.
pub fn job_wall_to_axis(
    conn: &Connection,
    sets: &[FieldSet],
    silo_radius_m: f64,
    particle_d_m: f64,
) -> Result<Option<f64>> {
    let Some(set) = sets
        .iter()
        .find(|s| s.name == MEAN_FLOWING && s.grid_kind == "rz")
    else {
        return Ok(None);
    };
    let arrays = load_field_arrays(conn, set.id)?;
    Ok(wall_to_axis_descent(
        set,
        &arrays,
        silo_radius_m,
        particle_d_m,
    ))
}

/// The replicas' mean, its standard error and degrees of freedom (from their spread); None with
/// fewer than two values.
pub fn replicas_estimate(values: &[f64]) -> Option<(f64, f64, f64)> {
    let (mean, ci) = mean_ci95(values)?;
    let dof = (values.len() - 1) as f64;
    Some((mean, ci / t_975(dof), dof))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 10 × 10 rz grid (spacing 1 cm from r = 0, z = 0) whose −P_z is `f(r, z)`.
    fn map(f: impl Fn(f64, f64) -> f64) -> (FieldSet, Vec<FieldArray>) {
        let set = FieldSet {
            id: 0,
            job_id: 0,
            name: MEAN_FLOWING.into(),
            grid_kind: "rz".into(),
            origin_m: [0.0, 0.0, 0.0],
            spacing_m: [0.01, 0.01, 0.0],
            shape: [10, 10, 1],
            kernel_width_m: 0.003,
            cutoff_widths: 3.0,
            t_start_s: 0.0,
            t_end_s: 1.0,
            samples: 10,
        };
        let mut data = Vec::new();
        for jz in 0..10 {
            for ir in 0..10 {
                data.extend([0.0, 0.0, -f(ir as f64 * 0.01, jz as f64 * 0.01)]);
            }
        }
        let a = FieldArray {
            field: "momentum".into(),
            units: "kg/(m^2 s)".into(),
            components: 3,
            data,
        };
        (set, vec![a])
    }

    #[test]
    fn plug_flow_gives_one_and_a_stagnant_wall_zero() {
        // R_c = 9.45 cm, d = 1 cm: band z in [1.5, 3] cm, wall r in [6.95, 8.45] cm, axis
        // r < 1.5 cm.
        let (set, a) = map(|_, _| 2.0);
        let plug = wall_to_axis_descent(&set, &a, 0.0945, 0.01).unwrap();
        assert!((plug - 1.0).abs() < 1e-12, "{plug}");
        let (set, a) = map(|r, _| if r < 0.05 { 3.0 } else { 0.0 });
        assert_eq!(wall_to_axis_descent(&set, &a, 0.0945, 0.01), Some(0.0));
        // Descent falling linearly from the axis (3) to the wall: wall points r = 7, 8 cm give
        // 3 (1 − r/0.1) = 0.9, 0.6; axis points r = 0, 1 cm give 3, 2.7.
        let (set, a) = map(|r, _| 3.0 * (1.0 - r / 0.1));
        let got = wall_to_axis_descent(&set, &a, 0.0945, 0.01).unwrap();
        assert!((got - 0.75 / 2.85).abs() < 1e-12, "{got}");
        // A grid that misses the wall annulus gives nothing.
        assert_eq!(wall_to_axis_descent(&set, &a, 0.3, 0.01), None);
    }

    #[test]
    fn replicas_give_the_student_t_error_of_their_spread() {
        let (m, se, dof) = replicas_estimate(&[0.2, 0.4]).unwrap();
        assert!((m - 0.3).abs() < 1e-12 && (se - 0.1).abs() < 1e-12 && dof == 1.0);
        assert!(replicas_estimate(&[0.2]).is_none());
    }
}
