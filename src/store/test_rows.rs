//! Rows written straight into a fresh in-memory database, for tests of what reads them (the
//! report's synthetic silo campaign). Test-only; it keeps their SQL behind the store's door.

use rusqlite::{params, Connection};

/// An in-memory database with the current schema.
pub(crate) fn empty_db() -> Connection {
    // The store's own schema, migrations included (columns added since schema.sql), with
    // foreign keys off so rows can be written in any order.
    let conn = super::open::open_in_memory(None).expect("in-memory db");
    conn.pragma_update(None, "foreign_keys", "OFF")
        .expect("foreign keys");
    conn
}

/// A campaign row; its id.
pub(crate) fn campaign(conn: &Connection, name: &str, scene: &str, created_at: &str) -> i64 {
    conn.execute(
        "INSERT INTO campaigns (name, file, scene, spec_json, created_at) VALUES (?1, ?2, ?3, '{}', ?4)",
        params![name, format!("{name}.json"), scene, created_at],
    )
    .expect("insert campaign");
    conn.last_insert_rowid()
}

/// The id of the campaign called `name`.
pub(crate) fn campaign_id(conn: &Connection, name: &str) -> i64 {
    conn.query_row("SELECT id FROM campaigns WHERE name = ?1", [name], |r| {
        r.get(0)
    })
    .expect("campaign")
}

/// A silo job of `campaign` (hash and label `label`, target 3 s); its id.
pub(crate) fn silo_job(
    conn: &Connection,
    campaign: i64,
    label: &str,
    status: &str,
    params_json: &str,
) -> i64 {
    job_of(conn, campaign, "silo", 3.0, label, status, params_json)
}

/// A job of `scene` in `campaign` (hash and label `label`, its end at `target_time_s`); its id.
fn job_of(
    conn: &Connection,
    campaign: i64,
    scene: &str,
    target_time_s: f64,
    label: &str,
    status: &str,
    params_json: &str,
) -> i64 {
    conn.execute(
        "INSERT INTO jobs (hash, scene, params_json, seed, status, target_time_s) \
         VALUES (?1, ?4, ?2, 1, ?3, ?5)",
        params![label, params_json, status, scene, target_time_s],
    )
    .expect("insert job");
    let job = conn.last_insert_rowid();
    conn.execute(
        "INSERT INTO campaign_jobs (campaign_id, job_id, label) VALUES (?1, ?2, ?3)",
        params![campaign, job, label],
    )
    .expect("insert campaign_job");
    job
}

/// A discharge summary of a synthetic job (`q_method` 'synthetic').
pub(crate) struct Summary {
    pub d: f64,
    pub f: f64,
    pub particle_d: f64,
    pub bulk_density: f64,
    /// (Q, its 95 % CI) in kg/s; None for a run that clogged before Q was measured.
    pub q: Option<(f64, f64)>,
    pub flowing_time_s: f64,
    pub discharged_mass_kg: f64,
    pub discharged_count: i64,
    pub clogs: i64,
    pub clogged_time_s: f64,
    pub permanently_clogged: bool,
    /// Blocks Q is the mean of (`discharge_summary.q_blocks`); None as in rows from before
    /// schema 8 (replicas then combine by their spread, not their pooled blocks).
    pub q_blocks: Option<i64>,
}

pub(crate) fn discharge_summary(conn: &Connection, job: i64, s: &Summary) {
    conn.execute(
        "INSERT INTO discharge_summary (job_id, orifice_diameter_m, rotation_frequency_hz, \
         particle_diameter_m, bulk_density_kg_per_m3, q_kg_per_s, q_ci95_kg_per_s, q_method, \
         flowing_time_s, discharged_mass_kg, discharged_count, clogs, clogged_time_s, \
         permanently_clogged, q_blocks) \
         VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, 'synthetic', ?8, ?9, ?10, ?11, ?12, ?13, ?14)",
        params![
            job,
            s.d,
            s.f,
            s.particle_d,
            s.bulk_density,
            s.q.map(|q| q.0),
            s.q.map(|q| q.1),
            s.flowing_time_s,
            s.discharged_mass_kg,
            s.discharged_count,
            s.clogs,
            s.clogged_time_s,
            s.permanently_clogged,
            s.q_blocks,
        ],
    )
    .expect("insert summary");
}

/// One M(t) sample.
pub(crate) fn discharge_sample(conn: &Connection, job: i64, t_s: f64, mass_kg: f64, count: i64) {
    conn.execute(
        "INSERT INTO discharge_series (job_id, t_s, mass_kg, count) VALUES (?1, ?2, ?3, ?4)",
        params![job, t_s, mass_kg, count],
    )
    .expect("insert series");
}

/// A chute job of `campaign` (hash and label `label`, target 400 s); its id.
pub(crate) fn chute_job(
    conn: &Connection,
    campaign: i64,
    label: &str,
    status: &str,
    params_json: &str,
) -> i64 {
    job_of(conn, campaign, "chute", 400.0, label, status, params_json)
}

/// A chute summary of a synthetic job (measured from 160 s for `measure_s`).
pub(crate) struct ChuteSummary {
    pub aspect_ratio: f64,
    pub inclination_deg: f64,
    /// L, m.
    pub total_length_m: f64,
    /// H, m.
    pub bed_height_m: f64,
    pub d_perp_m: f64,
    pub measure_s: f64,
    /// The flow's verdict (`chute_flow_state.state`).
    pub state: &'static str,
}

pub(crate) fn chute_summary(conn: &Connection, job: i64, s: &ChuteSummary) {
    conn.execute(
        "INSERT INTO chute_summary (job_id, aspect_ratio, inclination_deg, total_length_m, \
         diameter_m, particles, bed_height_m, steady_time_s, steady_stress_ratio, \
         measure_start_s, measure_end_s, samples, msd_fit_min_lag_s, msd_fit_max_lag_s, \
         mean_cos_theta, d_perp_m, cg_width_m, steady) \
         VALUES (?1, ?2, ?3, ?4, ?5, 4000, ?6, 150.0, 0.5, 160.0, ?7, 240, 1.0, 20.0, 0.5, ?8, \
         ?9, ?10)",
        params![
            job,
            s.aspect_ratio,
            s.inclination_deg,
            s.total_length_m,
            s.total_length_m / s.aspect_ratio,
            s.bed_height_m,
            160.0 + s.measure_s,
            s.d_perp_m,
            s.total_length_m / 4.0,
            s.state == "steady"
        ],
    )
    .expect("insert chute summary");
    conn.execute(
        "INSERT INTO chute_flow_state (job_id, state, measured, min_flow_velocity_m_per_s) \
         VALUES (?1, ?2, 1, 0.01)",
        params![job, s.state],
    )
    .expect("insert flow state");
}

/// One block of a synthetic chute job (`chute_blocks`), SI units.
pub(crate) struct ChuteBlock {
    pub block: i64,
    pub z_m: f64,
    pub d: Option<f64>,
    /// D's standard error.
    pub d_se: Option<f64>,
    pub shear_rate: f64,
    pub velocity_x: f64,
    pub solid_fraction: f64,
    pub vz_skewness: Option<f64>,
}

pub(crate) fn chute_block(conn: &Connection, job: i64, b: &ChuteBlock) {
    conn.execute(
        "INSERT INTO chute_blocks (job_id, block, z_m, diffusion_m2_per_s, \
         diffusion_stderr_m2_per_s, msd_fit_r, shear_rate_per_s, velocity_x_m_per_s, \
         solid_fraction, mean_particles, vz_std_m_per_s, vz_skewness, correlation_length_m) \
         VALUES (?1, ?2, ?3, ?4, ?5, 0.999, ?6, ?7, ?8, 200.0, 0.01, ?9, 0.1)",
        params![
            job,
            b.block,
            b.z_m,
            b.d,
            b.d_se,
            b.shear_rate,
            b.velocity_x,
            b.solid_fraction,
            b.vz_skewness
        ],
    )
    .expect("insert chute block");
}

/// One height of a synthetic chute job's coarse-grained profile (`chute_fields`).
pub(crate) fn chute_field(conn: &Connection, job: i64, z_m: f64, shear_rate: f64) {
    conn.execute(
        "INSERT INTO chute_fields (job_id, z_m, density_kg_per_m3, velocity_x_m_per_s, \
         shear_rate_per_s, stress_xz_pa, stress_zz_pa) VALUES (?1, ?2, 1430.0, ?3, ?4, 1.0, 2.0)",
        params![job, z_m, shear_rate * z_m, shear_rate],
    )
    .expect("insert chute field");
}
