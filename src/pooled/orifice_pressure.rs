//! ⟨p^k⟩ in the orifice cylinder r ≤ D/2, |z| ≤ D/4 (the silo paper's Fig. 11), per job over its
//! flowing samples and per point over its replicas: what fig11 draws and what the claims on
//! `kinetic_pressure` read.

use anyhow::Result;
use rusqlite::Connection;

use crate::observe::coarse_grain::FieldSet;
use crate::observe::fits::{mean_ci95, t_975};
use crate::observe::silo_fields::ORIFICE_KINETIC_PRESSURE;
use crate::store::fields::load_flagged_series;
use crate::store::silo_reads::{clog_intervals, DischargeRow};

/// What ⟨p^k⟩ needs of a done job.
pub struct PkJob {
    pub job_id: i64,
    pub d_m: f64,
    pub f_hz: f64,
    /// The job's flow rate; None when it clogged before one could be measured.
    pub q_kg_per_s: Option<f64>,
    /// Whether some (r, z) grid point of its field sets lies in the orifice cylinder.
    pub reaches_cylinder: bool,
    /// Whether it has field sets at all (a run without the fields observer has no ⟨p^k⟩).
    pub has_fields: bool,
}

impl PkJob {
    /// The job of a discharge row with its field `sets`.
    pub fn with_sets(row: &DischargeRow, sets: &[FieldSet]) -> Self {
        Self {
            job_id: row.job_id,
            d_m: row.orifice_diameter_m,
            f_hz: row.rotation_frequency_hz,
            q_kg_per_s: row.q_kg_per_s,
            reaches_cylinder: reaches_orifice_cylinder(row.orifice_diameter_m, sets),
            has_fields: !sets.is_empty(),
        }
    }
}

/// Whether some (r, z) grid point of `sets` lies in the cylinder r ≤ R, |z| ≤ R/2 (R = D/2) over
/// which ⟨p^k⟩ averages.
pub fn reaches_orifice_cylinder(d_m: f64, sets: &[FieldSet]) -> bool {
    let r = 0.5 * d_m;
    sets.iter().filter(|s| s.grid_kind == "rz").any(|s| {
        let inside = |axis: usize, lo: f64, hi: f64| {
            (0..s.shape[axis]).any(|i| {
                let c = s.coordinate(axis, i);
                c >= lo - 1e-12 && c <= hi + 1e-12
            })
        };
        inside(0, 0.0, r) && inside(1, -0.5 * r, 0.5 * r)
    })
}

/// What one job gives.
pub enum JobPk {
    /// ⟨p^k⟩ over the flowing samples (Pa), the 95 % CI of the mean from batch means, the
    /// number of samples.
    Value(f64, Option<f64>, usize),
    /// The run has no Q or no flowing sample: clogged.
    Clogged,
    /// No (r, z) grid point in the orifice cylinder (or no fields): nothing was averaged.
    NoGridPoint,
}

/// Batches of a job's samples for the error of its mean: samples 0.05 s apart are correlated.
const BATCHES: usize = 10;

/// One job's ⟨p^k⟩ in the orifice cylinder over its flowing samples, with the 95 % CI of the
/// mean from [`BATCHES`] contiguous batch means. Samples inside a clog (their stored flag) are
/// left out: the paper averages flowing states.
///
/// # Errors
/// Database errors.
pub fn orifice_pk(conn: &Connection, job: &PkJob) -> Result<JobPk> {
    if !job.has_fields || !job.reaches_cylinder {
        return Ok(JobPk::NoGridPoint);
    }
    if job.q_kg_per_s.is_none() {
        return Ok(JobPk::Clogged);
    }
    let series = load_flagged_series(conn, job.job_id, ORIFICE_KINETIC_PRESSURE)?;
    if series.is_empty() {
        return Ok(JobPk::Clogged);
    }
    // Each sample's stored flag; rows of an older sweep have none: the clogs table decides.
    let clogs = clog_intervals(conn, job.job_id)?;
    let in_clog = |t: f64| {
        clogs
            .iter()
            .any(|c| t >= c.start_s && t <= c.start_s + c.duration_s)
    };
    let flowing: Vec<f64> = series
        .iter()
        .filter(|s| s.flowing.unwrap_or_else(|| !in_clog(s.t_s)))
        .map(|s| s.value)
        .collect();
    if flowing.is_empty() {
        return Ok(JobPk::Clogged);
    }
    let n = flowing.len();
    let batches = BATCHES.min(n);
    let means: Vec<f64> = (0..batches)
        .map(|b| {
            let part = &flowing[b * n / batches..(b + 1) * n / batches];
            part.iter().sum::<f64>() / part.len() as f64
        })
        .collect();
    let mean = flowing.iter().sum::<f64>() / n as f64;
    Ok(JobPk::Value(mean, mean_ci95(&means).map(|m| m.1), n))
}

/// A point's ⟨p^k⟩ over its replicas.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PkPoint {
    /// The replicas' mean (Pa).
    pub mean: f64,
    /// Its 95 % CI: from the replicas' spread when there are several, else the one job's
    /// batch means; its standard error and degrees of freedom, for the claims.
    pub ci95: Option<f64>,
    pub se: Option<f64>,
    pub dof: f64,
    pub jobs: usize,
    pub samples: usize,
    pub clogged_runs: usize,
}

/// The replicas' ⟨p^k⟩ combined, how many of them clogged, and whether one had no grid point in
/// the orifice cylinder. None when no replica has a value.
///
/// # Errors
/// Database errors.
pub fn point_pk(conn: &Connection, jobs: &[&PkJob]) -> Result<(Option<PkPoint>, usize, bool)> {
    let mut per_job = Vec::new();
    let mut samples = 0;
    let mut clogged_runs = 0;
    let mut no_grid = false;
    for j in jobs {
        match orifice_pk(conn, j)? {
            JobPk::Value(m, ci, n) => {
                per_job.push((m, ci));
                samples += n;
            }
            JobPk::Clogged => clogged_runs += 1,
            JobPk::NoGridPoint => no_grid = true,
        }
    }
    if per_job.is_empty() {
        return Ok((None, clogged_runs, no_grid));
    }
    let values: Vec<f64> = per_job.iter().map(|p| p.0).collect();
    let (mean, ci95, dof) = match mean_ci95(&values) {
        Some((m, ci)) => (m, Some(ci), (values.len() - 1) as f64),
        None => (values[0], per_job[0].1, (BATCHES - 1) as f64),
    };
    let point = PkPoint {
        mean,
        ci95,
        se: ci95.map(|c| c / t_975(dof)),
        dof,
        jobs: per_job.len(),
        samples,
        clogged_runs,
    };
    Ok((Some(point), clogged_runs, no_grid))
}
