//! The chute results a figure reads (Soft Matter 2022 study): the summaries of a campaign's done
//! jobs, their per-block rows, and the per-block curves MSD_z(τ), v_z PDF and C(r), plus the
//! coarse-grained shear-rate profile. Values are returned in the database's SI units; scaling by
//! L is the figures' business. Read-only; no plotting here.

use anyhow::Result;
use rusqlite::{params, Connection};

use super::silo_data::same_value;

/// One done job's chute summary, joined with its campaign label.
#[derive(Debug, Clone)]
pub struct ChuteJob {
    /// jobs.id
    pub job_id: i64,
    /// campaign_jobs.label
    pub label: String,
    /// Aspect ratio ξ = L/d.
    pub aspect_ratio: f64,
    /// Inclination α, degrees.
    pub inclination_deg: f64,
    /// Particle length L = l + d, m: the unit of every length in the figures.
    pub total_length_m: f64,
    /// Bed height H (density at half its bulk value), m.
    pub bed_height_m: f64,
    /// Whether the steady-state criteria held when measurement started.
    pub steady: bool,
    /// Lag range of the MSD fit D = slope / 2, s.
    pub msd_fit_lags_s: (f64, f64),
    /// d_⊥, m.
    pub d_perp_m: f64,
}

/// The chute summaries of the campaign's jobs whose status is 'done', ordered by ξ, α, job id.
/// Jobs not done are left out even with a partial summary (render lists them as missing).
///
/// # Errors
/// On a database error.
pub fn done_chute_jobs(conn: &Connection, campaign_id: i64) -> Result<Vec<ChuteJob>> {
    let mut stmt = conn.prepare(
        "SELECT j.id, cj.label, s.aspect_ratio, s.inclination_deg, s.total_length_m, \
                s.bed_height_m, s.steady, s.msd_fit_min_lag_s, \
                s.msd_fit_max_lag_s, s.d_perp_m \
         FROM campaign_jobs cj \
         JOIN jobs j ON j.id = cj.job_id \
         JOIN chute_summary s ON s.job_id = j.id \
         WHERE cj.campaign_id = ?1 AND j.status = 'done' \
         ORDER BY s.aspect_ratio, s.inclination_deg, j.id",
    )?;
    let rows = stmt
        .query_map(params![campaign_id], |r| {
            Ok(ChuteJob {
                job_id: r.get(0)?,
                label: r.get(1)?,
                aspect_ratio: r.get(2)?,
                inclination_deg: r.get(3)?,
                total_length_m: r.get(4)?,
                bed_height_m: r.get(5)?,
                steady: r.get::<_, i64>(6)? != 0,
                msd_fit_lags_s: (r.get(7)?, r.get(8)?),
                d_perp_m: r.get(9)?,
            })
        })?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    Ok(rows)
}

/// Labels of the campaign's done jobs that have no chute_summary row (not drawn), sorted.
///
/// # Errors
/// On a database error.
pub fn done_without_summary(conn: &Connection, campaign_id: i64) -> Result<Vec<String>> {
    let mut stmt = conn.prepare(
        "SELECT cj.label FROM campaign_jobs cj JOIN jobs j ON j.id = cj.job_id \
         WHERE cj.campaign_id = ?1 AND j.status = 'done' \
           AND NOT EXISTS (SELECT 1 FROM chute_summary s WHERE s.job_id = j.id) \
         ORDER BY cj.label",
    )?;
    let rows = stmt
        .query_map(params![campaign_id], |r| r.get(0))?
        .collect::<rusqlite::Result<Vec<String>>>()?;
    Ok(rows)
}

/// One block of height L of one job (chute_blocks), SI units.
#[derive(Debug, Clone)]
pub struct BlockRow {
    /// Block index k: mean heights in [k L, (k + 1) L).
    pub block: i64,
    /// Block centre, m.
    pub z_m: f64,
    /// D_z, m²/s; None when the block had too few particles.
    pub diffusion_m2_per_s: Option<f64>,
    /// Correlation coefficient of the MSD fit.
    pub msd_fit_r: Option<f64>,
    /// dV_x/dz averaged over the block, 1/s.
    pub shear_rate_per_s: f64,
    /// Standard deviation of v_z, m/s.
    pub vz_std_m_per_s: Option<f64>,
    /// Skewness of v_z.
    pub vz_skewness: Option<f64>,
    /// l from ln C(r)/C(0) = −r/l, m.
    pub correlation_length_m: Option<f64>,
}

/// The blocks of one job, by block index.
///
/// # Errors
/// On a database error.
pub fn blocks(conn: &Connection, job_id: i64) -> Result<Vec<BlockRow>> {
    let mut stmt = conn.prepare(
        "SELECT block, z_m, diffusion_m2_per_s, msd_fit_r, shear_rate_per_s, vz_std_m_per_s, \
                vz_skewness, correlation_length_m \
         FROM chute_blocks WHERE job_id = ?1 ORDER BY block",
    )?;
    let rows = stmt
        .query_map(params![job_id], |r| {
            Ok(BlockRow {
                block: r.get(0)?,
                z_m: r.get(1)?,
                diffusion_m2_per_s: r.get(2)?,
                msd_fit_r: r.get(3)?,
                shear_rate_per_s: r.get(4)?,
                vz_std_m_per_s: r.get(5)?,
                vz_skewness: r.get(6)?,
                correlation_length_m: r.get(7)?,
            })
        })?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    Ok(rows)
}

/// One block's curve y(x), in increasing x.
#[derive(Debug, Clone)]
pub struct BlockCurve {
    /// Block index.
    pub block: i64,
    /// (x, y) in the table's units.
    pub points: Vec<(f64, f64)>,
}

/// Which per-block curve table to read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CurveTable {
    /// chute_msd: (lag_s, msd_m2).
    Msd,
    /// chute_vz_pdf: (x in standard deviations, density).
    VzPdf,
    /// chute_correlation: (r_m, c_m2_per_s2).
    Correlation,
}

/// The per-block curves of one job from `table`, by block index.
///
/// # Errors
/// On a database error.
pub fn block_curves(conn: &Connection, job_id: i64, table: CurveTable) -> Result<Vec<BlockCurve>> {
    // NOTE: the table and column names are constants, never user input.
    let sql = match table {
        CurveTable::Msd => {
            "SELECT block, lag_s, msd_m2 FROM chute_msd WHERE job_id = ?1 ORDER BY block, lag_s"
        }
        CurveTable::VzPdf => {
            "SELECT block, x, density FROM chute_vz_pdf WHERE job_id = ?1 ORDER BY block, x"
        }
        CurveTable::Correlation => {
            "SELECT block, r_m, c_m2_per_s2 FROM chute_correlation WHERE job_id = ?1 \
             ORDER BY block, r_m"
        }
    };
    let mut stmt = conn.prepare(sql)?;
    let rows = stmt
        .query_map(params![job_id], |r| {
            Ok((
                r.get::<_, i64>(0)?,
                r.get::<_, f64>(1)?,
                r.get::<_, f64>(2)?,
            ))
        })?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    let mut out: Vec<BlockCurve> = Vec::new();
    for (block, x, y) in rows {
        match out.last_mut() {
            Some(c) if c.block == block => c.points.push((x, y)),
            _ => out.push(BlockCurve {
                block,
                points: vec![(x, y)],
            }),
        }
    }
    Ok(out)
}

/// The coarse-grained shear rate γ̇(z) of one job (chute_fields) as (z_m, 1/s), for
/// 0 ≤ z ≤ `z_max_m`, in increasing z. Empty when the job has no field rows.
///
/// # Errors
/// On a database error.
pub fn shear_profile(conn: &Connection, job_id: i64, z_max_m: f64) -> Result<Vec<(f64, f64)>> {
    let mut stmt = conn.prepare(
        "SELECT z_m, shear_rate_per_s FROM chute_fields \
         WHERE job_id = ?1 AND z_m >= 0 AND z_m <= ?2 ORDER BY z_m",
    )?;
    let rows = stmt
        .query_map(params![job_id, z_max_m], |r| Ok((r.get(0)?, r.get(1)?)))?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    Ok(rows)
}

/// The value of `values` closest to `target` (ties: the smaller one); None when empty.
pub fn closest(values: impl Iterator<Item = f64>, target: f64) -> Option<f64> {
    values.filter(|v| v.is_finite()).min_by(|a, b| {
        (a - target)
            .abs()
            .total_cmp(&(b - target).abs())
            .then(a.total_cmp(b))
    })
}

/// The job whose ξ is closest to `xi` and, among those, whose α is closest to `alpha_deg`
/// (ties: the lower job id, as `jobs` is ordered).
pub fn closest_job(jobs: &[ChuteJob], xi: f64, alpha_deg: f64) -> Option<&ChuteJob> {
    let xi = closest(jobs.iter().map(|j| j.aspect_ratio), xi)?;
    let at_xi = jobs.iter().filter(|j| same_value(j.aspect_ratio, xi));
    let alpha = closest(at_xi.clone().map(|j| j.inclination_deg), alpha_deg)?;
    at_xi
        .filter(|j| same_value(j.inclination_deg, alpha))
        .min_by_key(|j| j.job_id)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn job(id: i64, xi: f64, alpha: f64) -> ChuteJob {
        ChuteJob {
            job_id: id,
            label: format!("j{id}"),
            aspect_ratio: xi,
            inclination_deg: alpha,
            total_length_m: 0.125,
            bed_height_m: 2.5,
            steady: true,
            msd_fit_lags_s: (1.0, 10.0),
            d_perp_m: 0.1,
        }
    }

    #[test]
    fn closest_prefers_the_smaller_on_ties_and_skips_nan() {
        let v = [1.0, 1.5, 2.0, f64::NAN];
        assert_eq!(closest(v.into_iter(), 1.25), Some(1.0));
        assert_eq!(closest(v.into_iter(), 1.3), Some(1.5));
        assert_eq!(closest(std::iter::empty(), 1.3), None);
    }

    #[test]
    fn closest_job_picks_xi_first_then_alpha_then_id() {
        let jobs = vec![
            job(1, 1.0, 27.0),
            job(2, 1.5, 26.0),
            job(3, 1.5, 28.0),
            job(4, 1.5, 28.0),
            job(5, 2.5, 30.0),
        ];
        assert_eq!(closest_job(&jobs, 1.3, 27.5).map(|j| j.job_id), Some(3));
        assert_eq!(closest_job(&jobs, 2.5, 0.0).map(|j| j.job_id), Some(5));
        assert!(closest_job(&[], 1.3, 27.0).is_none());
    }
}
