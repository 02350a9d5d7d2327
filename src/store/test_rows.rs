//! Rows written straight into a fresh in-memory database, for tests of what reads them (the
//! report's synthetic silo campaign). Test-only; it keeps their SQL behind the store's door.

use rusqlite::{params, Connection};

/// An in-memory database with the current schema.
pub(crate) fn empty_db() -> Connection {
    let conn = Connection::open_in_memory().expect("in-memory db");
    conn.execute_batch(include_str!("../../schema.sql"))
        .expect("schema");
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
    conn.execute(
        "INSERT INTO jobs (hash, scene, params_json, seed, status, target_time_s) \
         VALUES (?1, 'silo', ?2, 1, ?3, 3.0)",
        params![label, params_json, status],
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
