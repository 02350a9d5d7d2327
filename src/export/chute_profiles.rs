//! The chute study's z profiles (`chute_fields`, one row per height, with the measurement window
//! and kernel in `chute_summary`) as a field set on a `z` grid, so that they export like the
//! silo's field sets: a line of points along z at x = y = 0.

use rusqlite::{Connection, OptionalExtension};

use crate::store::fields::{FieldArray, FieldSet};

/// The chute observer's kernel cutoff, in widths (truncated Gaussian, cutoff 4 w).
const CUTOFF_WIDTHS: f64 = 4.0;

/// Columns of `chute_fields` exported, with the array's field name and units.
const COLUMNS: [(&str, &str, &str); 5] = [
    ("density_kg_per_m3", "density", "kg/m^3"),
    ("velocity_x_m_per_s", "velocity_x", "m/s"),
    ("shear_rate_per_s", "shear_rate", "1/s"),
    ("stress_xz_pa", "stress_xz", "Pa"),
    ("stress_zz_pa", "stress_zz", "Pa"),
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
    let summary: Option<(f64, f64, i64, f64)> = conn
        .query_row(
            "SELECT measure_start_s, measure_end_s, samples, cg_width_m FROM chute_summary WHERE job_id = ?1",
            [job_id],
            |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?)),
        )
        .optional()?;
    let Some((t_start_s, t_end_s, samples, width)) = summary else {
        return Ok(None);
    };
    let cols: Vec<&str> = COLUMNS.iter().map(|c| c.0).collect();
    let mut q = conn.prepare(&format!(
        "SELECT z_m, {} FROM chute_fields WHERE job_id = ?1 ORDER BY z_m",
        cols.join(", ")
    ))?;
    let rows: Vec<Vec<f64>> = q
        .query_map([job_id], |r| {
            (0..=COLUMNS.len()).map(|k| r.get(k)).collect()
        })?
        .collect::<Result<_, _>>()?;
    if rows.is_empty() {
        return Ok(None);
    }
    let n = rows.len();
    let z0 = rows[0][0];
    let dz = if n > 1 {
        (rows[n - 1][0] - z0) / (n - 1) as f64
    } else {
        0.0
    };
    for (k, r) in rows.iter().enumerate() {
        let expected = z0 + k as f64 * dz;
        anyhow::ensure!(
            (r[0] - expected).abs() <= 1e-9 * dz.abs().max(1e-12),
            "chute_fields of job {job_id}: heights are not evenly spaced (z = {} m at row {k}, expected {expected} m)",
            r[0]
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
        .enumerate()
        .map(|(c, (_, field, units))| FieldArray {
            field: (*field).into(),
            units: (*units).into(),
            components: 1,
            data: rows.iter().map(|r| r[c + 1]).collect(),
        })
        .collect();
    Ok(Some((set, arrays)))
}
