//! Reading chute results back: a job's measurement window and z profiles for the exporters;
//! a campaign's done jobs, their per-block rows and curves and the shear-rate profile for the
//! figures (`pooled::chute_jobs`). Values in the database's SI units.

use anyhow::Result;
use rusqlite::{params, Connection, OptionalExtension};

use super::chute_flow_reads::judged_flow_states;
use super::targets::RUNNING_ON_OR_DONE;
use crate::observe::chute::{density_layering, is_layered, FlowState};

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

/// One ended job's chute summary, joined with its campaign label.
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
    /// Whether the flow was steady (`chute_flow_state`; before schema 7, whether the criteria
    /// held when measurement started).
    pub steady: bool,
    /// `chute_flow_state.state`; None for a job from before schema 7.
    pub flow_state: Option<String>,
    /// Lag range of the MSD fit D = slope / 2, s.
    pub msd_fit_lags_s: (f64, f64),
    /// d_⊥, m.
    pub d_perp_m: f64,
    /// jobs.params_json (its `campaign::point_key` groups replicas).
    pub params_json: String,
    /// Length of the measurement, measure_end_s − measure_start_s, s.
    pub measure_s: f64,
    /// The central bed's density variation (`observe::chute::density_layering`) from the stored
    /// profile; None without one. A layered job is not `steady`.
    pub layering: Option<f64>,
    /// Set while a round runs the job on (`jobs.extended_to_s`, s): the rows are then the job's
    /// earlier end, which stay stored until it ends again.
    pub running_on_to_s: Option<f64>,
}

/// The chute summaries of the campaign's done jobs whose flow was steady (`chute_flow_state`
/// under today's rule, `judged_flow_states`; before schema 7, `chute_summary.steady`) and whose
/// density profile shows no ordered layers (`observe::chute::layering`), by ξ, α, job id. Jobs
/// not done are left out (render lists them as missing); done jobs that were not steady, or
/// layered, are listed by `left_out_chute_jobs`.
///
/// # Errors
/// On a database error.
pub fn done_chute_jobs(
    conn: &Connection,
    campaign_id: i64,
    include_unsteady: bool,
) -> Result<Vec<ChuteJob>> {
    chute_jobs(conn, campaign_id, include_unsteady, "j.status = 'done'")
}

/// [`done_chute_jobs`] and, for each job a round is running on, its earlier end, marked by
/// [`ChuteJob::running_on_to_s`]: what a figure draws, so that extending a job does not take it
/// off the figure until it ends again.
///
/// # Errors
/// On a database error.
pub fn drawable_chute_jobs(
    conn: &Connection,
    campaign_id: i64,
    include_unsteady: bool,
) -> Result<Vec<ChuteJob>> {
    chute_jobs(conn, campaign_id, include_unsteady, RUNNING_ON_OR_DONE)
}

/// The chute summaries of the campaign's jobs that satisfy `filter` (SQL over `j`, a constant
/// string), judged and ordered as [`done_chute_jobs`] says.
fn chute_jobs(
    conn: &Connection,
    campaign_id: i64,
    include_unsteady: bool,
    filter: &str,
) -> Result<Vec<ChuteJob>> {
    let mut stmt = conn.prepare(&format!(
        "SELECT j.id, cj.label, s.aspect_ratio, s.inclination_deg, s.total_length_m, \
                s.bed_height_m, s.steady, s.msd_fit_min_lag_s, \
                s.msd_fit_max_lag_s, s.d_perp_m, f.state, j.params_json, \
                s.measure_end_s - s.measure_start_s, \
                CASE WHEN j.status = 'done' THEN NULL ELSE j.extended_to_s END \
         FROM campaign_jobs cj \
         JOIN jobs j ON j.id = cj.job_id \
         JOIN chute_summary s ON s.job_id = j.id \
         LEFT JOIN chute_flow_state f ON f.job_id = j.id \
         WHERE cj.campaign_id = ?1 AND {filter} \
         ORDER BY s.aspect_ratio, s.inclination_deg, j.id"
    ))?;
    let rows = stmt
        .query_map(params![campaign_id], |r| {
            let flow_state: Option<String> = r.get(10)?;
            Ok(ChuteJob {
                job_id: r.get(0)?,
                label: r.get(1)?,
                aspect_ratio: r.get(2)?,
                inclination_deg: r.get(3)?,
                total_length_m: r.get(4)?,
                bed_height_m: r.get(5)?,
                steady: flow_state
                    .as_deref()
                    .map_or(r.get::<_, i64>(6)? != 0, |f| f == "steady"),
                flow_state,
                msd_fit_lags_s: (r.get(7)?, r.get(8)?),
                d_perp_m: r.get(9)?,
                params_json: r.get(11)?,
                measure_s: r.get(12)?,
                layering: None,
                running_on_to_s: r.get(13)?,
            })
        })?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    let judged = judged_flow_states(conn, campaign_id)?;
    let mut jobs = Vec::with_capacity(rows.len());
    for mut job in rows {
        if let Some(state) = judged.get(&job.job_id) {
            job.steady = *state == FlowState::Steady.as_str();
            job.flow_state = Some(state.clone());
        }
        let profile = chute_profile(conn, job.job_id)?;
        let z: Vec<f64> = profile.iter().map(|p| p.z_m).collect();
        let rho: Vec<f64> = profile.iter().map(|p| p.density_kg_per_m3).collect();
        job.layering = density_layering(&z, &rho, job.bed_height_m);
        if is_layered(job.layering) {
            job.steady = false;
        }
        if include_unsteady || job.steady {
            jobs.push(job);
        }
    }
    Ok(jobs)
}

/// Every done job of the campaign as (job id, label, params_json), by job id: what groups
/// a chute campaign's jobs into points (with or without a summary).
///
/// # Errors
/// On a database error.
pub fn done_campaign_jobs(
    conn: &Connection,
    campaign_id: i64,
) -> Result<Vec<(i64, String, String)>> {
    let mut stmt = conn.prepare(
        "SELECT j.id, cj.label, j.params_json FROM campaign_jobs cj \
         JOIN jobs j ON j.id = cj.job_id \
         WHERE cj.campaign_id = ?1 AND j.status = 'done' ORDER BY j.id",
    )?;
    let rows = stmt
        .query_map(params![campaign_id], |r| {
            Ok((r.get(0)?, r.get(1)?, r.get(2)?))
        })?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    Ok(rows)
}

/// A done chute job the figures leave out, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct LeftOut {
    pub label: String,
    /// `chute_flow_state.state`, or "not_steady" for a job from before schema 7 whose
    /// transient criteria failed.
    pub state: String,
    /// Whether its profiles were measured (and stored) all the same.
    pub measured: bool,
}

/// The campaign's done chute jobs whose flow was not steady, or steady but layered (state
/// "layered"), sorted by label.
///
/// # Errors
/// On a database error.
pub fn left_out_chute_jobs(conn: &Connection, campaign_id: i64) -> Result<Vec<LeftOut>> {
    let mut stmt = conn.prepare(
        "SELECT j.id, cj.label, COALESCE(f.state, 'not_steady'), \
                COALESCE(f.measured, s.job_id IS NOT NULL) \
         FROM campaign_jobs cj JOIN jobs j ON j.id = cj.job_id \
         LEFT JOIN chute_flow_state f ON f.job_id = j.id \
         LEFT JOIN chute_summary s ON s.job_id = j.id \
         WHERE cj.campaign_id = ?1 AND j.status = 'done' \
           AND (f.state <> 'steady' OR (f.state IS NULL AND s.steady = 0)) \
         ORDER BY cj.label",
    )?;
    let judged = judged_flow_states(conn, campaign_id)?;
    let steady = FlowState::Steady.as_str();
    let rows = stmt
        .query_map(params![campaign_id], |r| {
            Ok((
                r.get::<_, i64>(0)?,
                LeftOut {
                    label: r.get(1)?,
                    state: r.get(2)?,
                    measured: r.get::<_, i64>(3)? != 0,
                },
            ))
        })?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    // A stored "drifted" that today's rule reads as steady is not left out.
    let mut rows: Vec<LeftOut> = rows
        .into_iter()
        .filter(|(id, _)| judged.get(id).is_none_or(|s| s != steady))
        .map(|(_, row)| row)
        .collect();
    for job in done_chute_jobs(conn, campaign_id, true)? {
        let was_steady = job.flow_state.as_deref().is_none_or(|s| s == steady);
        if was_steady && is_layered(job.layering) {
            rows.push(LeftOut {
                label: job.label,
                state: FlowState::Layered.as_str().into(),
                measured: true,
            });
        }
    }
    rows.sort_by(|a, b| a.label.cmp(&b.label));
    Ok(rows)
}

/// Labels of the campaign's done jobs that have no chute_summary row and no flow verdict that
/// explains it (not drawn), sorted.
///
/// # Errors
/// On a database error.
pub fn done_without_summary(conn: &Connection, campaign_id: i64) -> Result<Vec<String>> {
    let mut stmt = conn.prepare(
        "SELECT cj.label FROM campaign_jobs cj JOIN jobs j ON j.id = cj.job_id \
         WHERE cj.campaign_id = ?1 AND j.status = 'done' \
           AND NOT EXISTS (SELECT 1 FROM chute_summary s WHERE s.job_id = j.id) \
           AND NOT EXISTS (SELECT 1 FROM chute_flow_state f WHERE f.job_id = j.id) \
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
    /// Standard error of D_z from the measurement's `msd_error_windows` time windows, m²/s;
    /// None when a window was shorter than the longest fitted lag.
    pub diffusion_stderr_m2_per_s: Option<f64>,
    /// Correlation coefficient of the MSD fit.
    pub msd_fit_r: Option<f64>,
    /// dV_x/dz averaged over the block, 1/s.
    pub shear_rate_per_s: f64,
    /// V_x averaged over the block, m/s.
    pub velocity_x_m_per_s: f64,
    /// Solid fraction φ averaged over the block.
    pub solid_fraction: f64,
    /// Standard deviation of v_z, m/s.
    pub vz_std_m_per_s: Option<f64>,
    /// Skewness of v_z.
    pub vz_skewness: Option<f64>,
    /// l from ln C(r)/C(0) = −r/l, m.
    pub correlation_length_m: Option<f64>,
    /// Nematic order S2 of the block's rods; None for spheres and rows before schema 13.
    pub nematic_order: Option<f64>,
    /// ⟨|cos θ|⟩ of the block's rods to the flow direction; None as `nematic_order`.
    pub mean_abs_cos_flow: Option<f64>,
    /// D_y, m²/s; None with too few particles and for rows before schema 13.
    pub diffusion_y_m2_per_s: Option<f64>,
    /// Standard error of D_y from the time windows, m²/s.
    pub diffusion_y_stderr_m2_per_s: Option<f64>,
}

/// The blocks of one job, by block index.
///
/// # Errors
/// On a database error.
pub fn blocks(conn: &Connection, job_id: i64) -> Result<Vec<BlockRow>> {
    let mut stmt = conn.prepare(
        "SELECT block, z_m, diffusion_m2_per_s, msd_fit_r, shear_rate_per_s, vz_std_m_per_s, \
                vz_skewness, correlation_length_m, diffusion_stderr_m2_per_s, \
                velocity_x_m_per_s, solid_fraction, nematic_order_s2, mean_abs_cos_flow, \
                diffusion_y_m2_per_s, diffusion_y_stderr_m2_per_s \
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
                diffusion_stderr_m2_per_s: r.get(8)?,
                velocity_x_m_per_s: r.get(9)?,
                solid_fraction: r.get(10)?,
                nematic_order: r.get(11)?,
                mean_abs_cos_flow: r.get(12)?,
                diffusion_y_m2_per_s: r.get(13)?,
                diffusion_y_stderr_m2_per_s: r.get(14)?,
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

/// The bed height H of one job, m (`chute_summary`).
///
/// # Errors
/// On a database error, among them no summary for the job.
pub fn bed_height(conn: &Connection, job_id: i64) -> Result<f64> {
    Ok(conn.query_row(
        "SELECT bed_height_m FROM chute_summary WHERE job_id = ?1",
        [job_id],
        |r| r.get(0),
    )?)
}

/// One block's diffusivity and shear rate, as the accuracy map compares them.
#[derive(Debug, Clone, Copy)]
pub struct BlockTransport {
    /// Block index.
    pub block: u32,
    /// Block centre, m.
    pub z_m: f64,
    /// D_z, m²/s; None when the block had too few particles.
    pub diffusion_m2_per_s: Option<f64>,
    /// Standard error of D_z from the `msd_error_windows` time windows, m²/s; None when a
    /// window was shorter than the longest fitted lag.
    pub diffusion_stderr_m2_per_s: Option<f64>,
    /// dV_x/dz averaged over the block, 1/s.
    pub shear_rate_per_s: f64,
}

/// The blocks of one job with their D_z and γ̇, by block index.
///
/// # Errors
/// On a database error.
pub fn block_transport(conn: &Connection, job_id: i64) -> Result<Vec<BlockTransport>> {
    let mut st = conn.prepare(
        "SELECT block, z_m, diffusion_m2_per_s, diffusion_stderr_m2_per_s, shear_rate_per_s \
         FROM chute_blocks WHERE job_id = ?1 ORDER BY block",
    )?;
    let rows = st
        .query_map([job_id], |r| {
            Ok(BlockTransport {
                block: r.get(0)?,
                z_m: r.get(1)?,
                diffusion_m2_per_s: r.get(2)?,
                diffusion_stderr_m2_per_s: r.get(3)?,
                shear_rate_per_s: r.get(4)?,
            })
        })?
        .collect::<rusqlite::Result<Vec<_>>>()?;
    Ok(rows)
}

/// A chute job's flow verdict, for `sweep status`.
#[derive(Debug, Clone, PartialEq)]
pub struct FlowVerdict {
    pub state: String,
    pub measured: bool,
    pub min_flow_velocity_m_per_s: f64,
    /// The criteria of the window that decided ('measurement' sorts before 'transient', so it
    /// wins when there was one).
    pub criteria: Option<DecidingWindow>,
}

/// The stationarity criteria of one window (`chute_stationarity`).
#[derive(Debug, Clone, PartialEq)]
pub struct DecidingWindow {
    pub phase: String,
    pub mean_vx_m_per_s: f64,
    pub ke_change: Option<f64>,
    pub vx_change: Option<f64>,
    pub stress_ratio: Option<f64>,
    /// The trends' t statistics (None when infinite) and the t quantile they are held to.
    pub ke_t: Option<f64>,
    pub vx_t: Option<f64>,
    pub t_critical: Option<f64>,
}

/// The flow verdicts of the campaign's chute jobs, by job id; a done steady job whose stored
/// profile shows ordered layers reads "layered".
///
/// # Errors
/// On a database error.
pub fn flow_verdicts(
    conn: &Connection,
    campaign_id: i64,
) -> Result<std::collections::BTreeMap<i64, FlowVerdict>> {
    let mut stmt = conn.prepare(
        "SELECT f.job_id, f.state, f.measured, f.min_flow_velocity_m_per_s, \
                s.phase, s.vx_mean_m_per_s, s.ke_change, s.vx_change, s.stress_ratio, \
                s.ke_t, s.vx_t, s.t_critical \
         FROM campaign_jobs cj JOIN chute_flow_state f ON f.job_id = cj.job_id \
         LEFT JOIN chute_stationarity s ON s.job_id = f.job_id AND s.phase = \
             (SELECT MIN(phase) FROM chute_stationarity x WHERE x.job_id = f.job_id) \
         WHERE cj.campaign_id = ?1",
    )?;
    let mut rows: std::collections::BTreeMap<i64, FlowVerdict> = stmt
        .query_map(params![campaign_id], |r| {
            let phase: Option<String> = r.get(4)?;
            Ok((
                r.get::<_, i64>(0)?,
                FlowVerdict {
                    state: r.get(1)?,
                    measured: r.get::<_, i64>(2)? != 0,
                    min_flow_velocity_m_per_s: r.get(3)?,
                    criteria: match phase {
                        Some(phase) => Some(DecidingWindow {
                            phase,
                            mean_vx_m_per_s: r.get(5)?,
                            ke_change: r.get(6)?,
                            vx_change: r.get(7)?,
                            stress_ratio: r.get(8)?,
                            ke_t: r.get(9)?,
                            vx_t: r.get(10)?,
                            t_critical: r.get(11)?,
                        }),
                        None => None,
                    },
                },
            ))
        })?
        .collect::<rusqlite::Result<_>>()?;
    for (id, state) in judged_flow_states(conn, campaign_id)? {
        if let Some(v) = rows.get_mut(&id) {
            v.state = state;
        }
    }
    // A steady flow in ordered layers is left out as the others are; say so.
    let steady = FlowState::Steady.as_str();
    for job in done_chute_jobs(conn, campaign_id, true)? {
        if let Some(v) = rows.get_mut(&job.job_id) {
            if v.state == steady && is_layered(job.layering) {
                v.state = FlowState::Layered.as_str().into();
            }
        }
    }
    Ok(rows)
}
