//! Reading a chute job's results back (`chute_summary`, `chute_fields`) for the exporters.

use rusqlite::{Connection, OptionalExtension};

/// The measurement window and kernel of a chute job's profiles (from `chute_summary`).
#[derive(Clone, Copy, Debug)]
pub struct ChuteWindow {
    pub measure_start_s: f64,
    pub measure_end_s: f64,
    pub samples: i64,
    /// Coarse-graining kernel width (m).
    pub cg_width_m: f64,
}

/// The measurement window of chute job `job_id`, or `None` when it has no summary (not a chute
/// job, or not finished).
///
/// # Errors
/// Database errors.
pub fn chute_window(conn: &Connection, job_id: i64) -> anyhow::Result<Option<ChuteWindow>> {
    Ok(conn
        .query_row(
            "SELECT measure_start_s, measure_end_s, samples, cg_width_m FROM chute_summary WHERE job_id = ?1",
            [job_id],
            |r| {
                Ok(ChuteWindow {
                    measure_start_s: r.get(0)?,
                    measure_end_s: r.get(1)?,
                    samples: r.get(2)?,
                    cg_width_m: r.get(3)?,
                })
            },
        )
        .optional()?)
}

/// One height of a chute job's z profiles (`chute_fields`).
#[derive(Clone, Copy, Debug)]
pub struct ChuteProfileRow {
    pub z_m: f64,
    pub density_kg_per_m3: f64,
    pub velocity_x_m_per_s: f64,
    pub shear_rate_per_s: f64,
    pub stress_xz_pa: f64,
    pub stress_zz_pa: f64,
}

/// The z profiles of chute job `job_id`, lowest first (empty when it has none).
///
/// # Errors
/// Database errors.
pub fn chute_profile(conn: &Connection, job_id: i64) -> anyhow::Result<Vec<ChuteProfileRow>> {
    let mut q = conn.prepare(
        "SELECT z_m, density_kg_per_m3, velocity_x_m_per_s, shear_rate_per_s, stress_xz_pa, stress_zz_pa FROM chute_fields WHERE job_id = ?1 ORDER BY z_m",
    )?;
    let rows = q
        .query_map([job_id], |r| {
            Ok(ChuteProfileRow {
                z_m: r.get(0)?,
                density_kg_per_m3: r.get(1)?,
                velocity_x_m_per_s: r.get(2)?,
                shear_rate_per_s: r.get(3)?,
                stress_xz_pa: r.get(4)?,
                stress_zz_pa: r.get(5)?,
            })
        })?
        .collect::<Result<_, _>>()?;
    Ok(rows)
}
