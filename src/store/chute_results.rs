//! Results of a chute job: the rows of `ChuteResults` (when it measured), the verdict on its
//! flow with the stationarity criteria, and the flow's series, written for one job in one
//! transaction. Each table's rows for the job are deleted first, so a retried
//! commit replaces rather than duplicates. `ChuteJobResults::commit` writes them in the same
//! transaction that marks the job done.

use anyhow::Context;
use rusqlite::{params, Connection, Transaction, TransactionBehavior};

use crate::observe::chute::{ChuteResults, FlowRecord};
use crate::observe::steady::{FlowSample, WindowCheck};

/// What a finished chute job stores.
#[derive(Clone, Debug)]
pub struct ChuteJobResults {
    /// What the observer measured; None when the job measured nothing (not flowing, or not
    /// steady by `steady_max_time_s`).
    pub results: Option<ChuteResults>,
    pub flow: FlowRecord,
    /// The run's series, into `chute_series`.
    pub series: Vec<FlowSample>,
    pub wall_time_s: f64,
    pub particle_steps: u64,
    pub sim_time_s: f64,
    /// Time step and the running numerical record of the run.
    pub dt_s: f64,
    pub numerics: super::JobNumerics,
}

impl ChuteJobResults {
    /// Writes every result row and marks the job done, in one transaction; a job already done
    /// (another process finished it) is left alone and nothing is written twice. Returns whether
    /// it wrote.
    ///
    /// # Errors
    /// Database errors, or a non-finite value bound for a NOT NULL column.
    pub fn commit(&self, conn: &mut Connection, job_id: i64) -> anyhow::Result<bool> {
        let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
        let status: String =
            tx.query_row("SELECT status FROM jobs WHERE id = ?1", [job_id], |r| {
                r.get(0)
            })?;
        let write = status != "done";
        if write {
            match &self.results {
                Some(r) => r.write(&tx, job_id)?,
                None => clear(&tx, job_id, RESULT_TABLES)?,
            }
            write_series(&tx, job_id, &self.series)?;
            self.flow.write(&tx, job_id)?;
            self.numerics.write(&tx, job_id, self.dt_s)?;
            tx.execute(
                "UPDATE jobs SET status = 'done', lease_owner = NULL, progress = 1.0, sim_time_s = ?2, wall_time_s = ?3, particle_steps = ?4,
                    finished_at = strftime('%Y-%m-%dT%H:%M:%fZ', 'now') WHERE id = ?1",
                params![job_id, self.sim_time_s, self.wall_time_s, self.particle_steps as i64],
            )?;
        }
        tx.commit()?;
        Ok(write)
    }
}

/// The tables of `ChuteResults`.
const RESULT_TABLES: &[&str] = &[
    "chute_summary",
    "chute_blocks",
    "chute_msd",
    "chute_fields",
    "chute_vz_pdf",
    "chute_correlation",
];

fn clear(conn: &Connection, job_id: i64, tables: &[&str]) -> anyhow::Result<()> {
    for table in tables {
        conn.execute(&format!("DELETE FROM {table} WHERE job_id = ?1"), [job_id])
            .with_context(|| format!("clearing {table} for job {job_id}"))?;
    }
    Ok(())
}

/// Writes `series` into `chute_series`, replacing the job's rows.
fn write_series(conn: &Connection, job_id: i64, series: &[FlowSample]) -> anyhow::Result<()> {
    clear(conn, job_id, &["chute_series"])?;
    // A repeated time (a resumed run re-sampling its checkpoint's instant) keeps the later row.
    let mut ins = conn.prepare(
        "INSERT OR REPLACE INTO chute_series (job_id, t_s, kinetic_energy_j, stress_ratio, mean_vx_m_per_s)
         VALUES (?1, ?2, ?3, ?4, ?5)",
    )?;
    for s in series {
        anyhow::ensure!(
            s.t.is_finite() && s.ke.is_finite() && s.vx.is_finite(),
            "chute series: a sample at t = {} has kinetic energy {} and mean V_x {}",
            s.t,
            s.ke,
            s.vx
        );
        ins.execute(params![
            job_id,
            s.t,
            s.ke,
            s.ratio.filter(|r| r.is_finite()),
            s.vx
        ])?;
    }
    Ok(())
}

impl FlowRecord {
    /// Writes `chute_flow_state` and `chute_stationarity` for `job_id`, replacing its rows.
    ///
    /// # Errors
    /// Database errors.
    pub fn write(&self, conn: &Connection, job_id: i64) -> anyhow::Result<()> {
        clear(conn, job_id, &["chute_flow_state", "chute_stationarity"])?;
        conn.execute(
            "INSERT INTO chute_flow_state (job_id, state, measured, min_flow_velocity_m_per_s)
             VALUES (?1, ?2, ?3, ?4)",
            params![
                job_id,
                self.state.as_str(),
                i64::from(self.measured),
                self.min_flow_velocity_m_per_s
            ],
        )?;
        for (phase, check) in [
            ("transient", &self.transient),
            ("measurement", &self.measurement),
        ] {
            if let Some(c) = check {
                write_check(conn, job_id, phase, c)?;
            }
        }
        Ok(())
    }
}

fn write_check(conn: &Connection, job_id: i64, phase: &str, c: &WindowCheck) -> anyhow::Result<()> {
    let fin = |v: f64| v.is_finite().then_some(v);
    conn.execute(
        "INSERT INTO chute_stationarity (job_id, phase, start_s, end_s, ke_mean_j, ke_change, ke_t,
            vx_mean_m_per_s, vx_change, vx_t, t_critical, stress_ratio, ratio_ok, flowing, steady)
         VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15)",
        params![
            job_id,
            phase,
            c.start_s,
            c.time_s,
            c.ke.map(|t| t.mean),
            c.ke.and_then(|t| fin(t.relative_change)),
            c.ke.and_then(|t| fin(t.t_statistic)),
            c.mean_vx_m_per_s,
            c.vx.and_then(|t| fin(t.relative_change)),
            c.vx.and_then(|t| fin(t.t_statistic)),
            c.ke.or(c.vx).map(|t| t.t_critical),
            c.stress_ratio.and_then(fin),
            i64::from(c.ratio_ok),
            i64::from(c.flowing),
            i64::from(c.steady),
        ],
    )?;
    Ok(())
}

impl ChuteResults {
    /// Writes every chute table for `job_id`, and `series` into `chute_series`, in one
    /// IMMEDIATE transaction.
    ///
    /// # Errors
    /// Database errors (among them: a transaction already open on `conn`: use `write` inside
    /// it), or a non-finite value bound for a NOT NULL column.
    pub fn commit(
        &self,
        conn: &Connection,
        job_id: i64,
        series: &[FlowSample],
    ) -> anyhow::Result<()> {
        let tx = Transaction::new_unchecked(conn, TransactionBehavior::Immediate)?;
        self.write(&tx, job_id)?;
        write_series(&tx, job_id, series)?;
        tx.commit()?;
        Ok(())
    }

    /// The result tables of `commit` (not the series) without the transaction, for a caller that also marks the job
    /// done in its own transaction (a `Transaction` derefs to `Connection`).
    ///
    /// # Errors
    /// As `commit`.
    pub fn write(&self, conn: &Connection, job_id: i64) -> anyhow::Result<()> {
        // SQLite stores NaN as NULL: a NaN here would fail a NOT NULL constraint with a less
        // helpful message, or land as NULL in a nullable one.
        let finite = |what: &str, v: f64| -> anyhow::Result<f64> {
            anyhow::ensure!(
                v.is_finite(),
                "chute results: {what} is {v}, not a finite number"
            );
            Ok(v)
        };
        let opt = |v: Option<f64>| v.filter(|x| x.is_finite());
        clear(conn, job_id, RESULT_TABLES)?;
        let s = &self.summary;
        conn.execute(
            "INSERT INTO chute_summary (job_id, aspect_ratio, inclination_deg, total_length_m, diameter_m, particles,
                bed_height_m, steady_time_s, steady_stress_ratio, measure_start_s, measure_end_s, samples,
                msd_fit_min_lag_s, msd_fit_max_lag_s, mean_cos_theta, d_perp_m, cg_width_m, steady)
             VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17, ?18)",
            params![
                job_id,
                finite("aspect_ratio", s.aspect_ratio)?,
                finite("inclination_deg", s.inclination_deg)?,
                finite("total_length_m", s.total_length_m)?,
                finite("diameter_m", s.diameter_m)?,
                s.particles as i64,
                finite("bed_height_m", s.bed_height_m)?,
                opt(s.steady_time_s),
                opt(s.steady_stress_ratio),
                finite("measure_start_s", s.measure_start_s)?,
                finite("measure_end_s", s.measure_end_s)?,
                s.samples as i64,
                finite("msd_fit_min_lag_s", s.msd_fit_min_lag_s)?,
                finite("msd_fit_max_lag_s", s.msd_fit_max_lag_s)?,
                finite("mean_cos_theta", s.mean_cos_theta)?,
                finite("d_perp_m", s.d_perp_m)?,
                finite("cg_width_m", s.cg_width_m)?,
                i64::from(s.steady),
            ],
        )?;
        let mut ins = conn.prepare(
            "INSERT INTO chute_blocks (job_id, block, z_m, diffusion_m2_per_s, diffusion_stderr_m2_per_s, msd_fit_r,
                shear_rate_per_s, velocity_x_m_per_s, solid_fraction, mean_particles, vz_std_m_per_s, vz_skewness,
                correlation_length_m, nematic_order_s2, mean_abs_cos_flow, diffusion_y_m2_per_s,
                diffusion_y_stderr_m2_per_s)
             VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17)",
        )?;
        for b in &self.blocks {
            ins.execute(params![
                job_id,
                b.block,
                finite("block z_m", b.z_m)?,
                opt(b.diffusion_m2_per_s),
                opt(b.diffusion_stderr_m2_per_s),
                opt(b.msd_fit_r),
                finite("block shear_rate_per_s", b.shear_rate_per_s)?,
                finite("block velocity_x_m_per_s", b.velocity_x_m_per_s)?,
                finite("block solid_fraction", b.solid_fraction)?,
                finite("block mean_particles", b.mean_particles)?,
                opt(b.vz_std_m_per_s),
                opt(b.vz_skewness),
                opt(b.correlation_length_m),
                opt(b.nematic_order),
                opt(b.mean_abs_cos_flow),
                opt(b.diffusion_y_m2_per_s),
                opt(b.diffusion_y_stderr_m2_per_s),
            ])?;
        }
        let mut ins = conn.prepare(
            "INSERT INTO chute_msd (job_id, block, lag_s, msd_m2, pairs) VALUES (?1, ?2, ?3, ?4, ?5)",
        )?;
        for m in &self.msd {
            ins.execute(params![
                job_id,
                m.block,
                m.lag_s,
                finite("msd_m2", m.msd_m2)?,
                m.pairs as i64
            ])?;
        }
        let mut ins = conn.prepare(
            "INSERT INTO chute_fields (job_id, z_m, density_kg_per_m3, velocity_x_m_per_s, shear_rate_per_s,
                stress_xz_pa, stress_zz_pa) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)",
        )?;
        for f in &self.fields {
            ins.execute(params![
                job_id,
                finite("field z_m", f.z_m)?,
                finite("density_kg_per_m3", f.density_kg_per_m3)?,
                finite("field velocity_x_m_per_s", f.velocity_x_m_per_s)?,
                finite("field shear_rate_per_s", f.shear_rate_per_s)?,
                finite("stress_xz_pa", f.stress_xz_pa)?,
                finite("stress_zz_pa", f.stress_zz_pa)?,
            ])?;
        }
        let mut ins = conn.prepare(
            "INSERT INTO chute_vz_pdf (job_id, block, x, density) VALUES (?1, ?2, ?3, ?4)",
        )?;
        for p in &self.vz_pdf {
            ins.execute(params![
                job_id,
                p.block,
                p.x,
                finite("vz pdf density", p.density)?
            ])?;
        }
        let mut ins = conn.prepare(
            "INSERT INTO chute_correlation (job_id, block, r_m, c_m2_per_s2, pairs) VALUES (?1, ?2, ?3, ?4, ?5)",
        )?;
        for c in &self.correlation {
            ins.execute(params![
                job_id,
                c.block,
                c.r_m,
                finite("c_m2_per_s2", c.c_m2_per_s2)?,
                c.pairs as i64
            ])?;
        }
        Ok(())
    }
}
