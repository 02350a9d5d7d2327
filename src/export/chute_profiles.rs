//! The chute study's z profiles (`chute_fields`, one row per height, with the measurement window
//! and kernel in `chute_summary`) as a field set on a `z` grid, so that they export like the
//! silo's field sets: a line of points along z at x = y = 0.

use rusqlite::Connection;

use crate::store::chute_reads::{chute_profile, chute_window, ChuteProfileRow, ChuteWindow};
use crate::store::fields::{FieldArray, FieldSet};

/// The chute observer's kernel cutoff, in widths (truncated Gaussian, cutoff 4 w).
const CUTOFF_WIDTHS: f64 = 4.0;

/// A column of `chute_fields` exported.
type Column = fn(&ChuteProfileRow) -> f64;

/// Columns of `chute_fields` exported, with the array's field name and units.
const COLUMNS: [(Column, &str, &str); 5] = [
    (|r| r.density_kg_per_m3, "density", "kg/m^3"),
    (|r| r.velocity_x_m_per_s, "velocity_x", "m/s"),
    (|r| r.shear_rate_per_s, "shear_rate", "1/s"),
    (|r| r.stress_xz_pa, "stress_xz", "Pa"),
    (|r| r.stress_zz_pa, "stress_zz", "Pa"),
];

/// The z profiles of chute job `job_id` as the set `chute_profile`, or None when the job has
/// none (not a chute job, or not finished).
///
/// # Errors
/// Database errors, or heights that are not evenly spaced (an image needs a uniform grid).
pub fn chute_profile_set(
    conn: &Connection,
    job_id: i64,
) -> anyhow::Result<Option<(FieldSet, Vec<FieldArray>)>> {
    let Some(ChuteWindow {
        measure_start_s: t_start_s,
        measure_end_s: t_end_s,
        samples,
        cg_width_m: width,
    }) = chute_window(conn, job_id)?
    else {
        return Ok(None);
    };
    let rows = chute_profile(conn, job_id)?;
    if rows.is_empty() {
        return Ok(None);
    }
    let n = rows.len();
    let z0 = rows[0].z_m;
    let dz = if n > 1 {
        (rows[n - 1].z_m - z0) / (n - 1) as f64
    } else {
        0.0
    };
    for (k, r) in rows.iter().enumerate() {
        let expected = z0 + k as f64 * dz;
        anyhow::ensure!(
            (r.z_m - expected).abs() <= 1e-9 * dz.abs().max(1e-12),
            "chute_fields of job {job_id}: heights are not evenly spaced (z = {} m at row {k}, expected {expected} m)",
            r.z_m
        );
    }
    let set = FieldSet {
        id: 0,
        job_id,
        name: "chute_profile".into(),
        grid_kind: "z".into(),
        origin_m: [0.0, 0.0, z0],
        spacing_m: [0.0, 0.0, dz],
        shape: [1, 1, n],
        kernel_width_m: width,
        cutoff_widths: CUTOFF_WIDTHS,
        t_start_s,
        t_end_s,
        samples,
    };
    let arrays = COLUMNS
        .iter()
        .map(|(column, field, units)| FieldArray {
            field: (*field).into(),
            units: (*units).into(),
            components: 1,
            data: rows.iter().map(column).collect(),
        })
        .collect();
    Ok(Some((set, arrays)))
}
