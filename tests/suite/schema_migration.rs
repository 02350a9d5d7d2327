//! A store of the previous schema (12) opened by this sweep: migrated in place to the current
//! version, its rows kept, the columns added since NULL in them, and readable by the figures'
//! queries.

use rusqlite::Connection;

/// `chute_blocks` as schema 12 created it (schema.sql at commit 464e26b).
const CHUTE_BLOCKS_V12: &str = "CREATE TABLE chute_blocks (
    job_id                  INTEGER NOT NULL REFERENCES jobs(id),
    block                   INTEGER NOT NULL,
    z_m                     REAL NOT NULL,
    diffusion_m2_per_s      REAL,
    diffusion_stderr_m2_per_s REAL,
    msd_fit_r               REAL,
    shear_rate_per_s        REAL NOT NULL,
    velocity_x_m_per_s      REAL NOT NULL,
    solid_fraction          REAL NOT NULL,
    mean_particles          REAL NOT NULL,
    vz_std_m_per_s          REAL,
    vz_skewness             REAL,
    correlation_length_m    REAL,
    PRIMARY KEY (job_id, block)
)";

fn columns(conn: &Connection, table: &str) -> Vec<String> {
    let mut q = conn
        .prepare(&format!("PRAGMA table_info({table})"))
        .unwrap();
    q.query_map([], |r| r.get::<_, String>(1))
        .unwrap()
        .map(Result::unwrap)
        .collect()
}

/// Law: migration adds columns and changes nothing else. A schema-12 store with one chute
/// block row, opened twice, is at the current version with the four schema-13 columns and
/// schema 14's `claim_looks` and schema 15's `jobs.cpu_time_s` (NULL for its job); the row's
/// values read back unchanged and its new columns are NULL (`blocks` gives None). A failure means old stores are refused, rewritten, or misread.
#[test]
fn a_schema_12_store_migrates_in_place() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("old.db");
    {
        let conn = sweep::store::open(&path).unwrap();
        conn.execute_batch(&format!(
            "DROP TABLE chute_blocks; {CHUTE_BLOCKS_V12}; DROP TABLE claim_looks;
             ALTER TABLE jobs DROP COLUMN cpu_time_s;
             INSERT INTO jobs (id, hash, scene, params_json, seed, target_time_s)
                 VALUES (1, 'h', 'chute', '{{}}', 0, 1.0);
             INSERT INTO chute_blocks (job_id, block, z_m, diffusion_m2_per_s, shear_rate_per_s,
                 velocity_x_m_per_s, solid_fraction, mean_particles)
                 VALUES (1, 3, 0.4375, 2.5e-4, 0.75, 1.5, 0.55, 120.0);
             PRAGMA user_version = 12;"
        ))
        .unwrap();
        assert!(!columns(&conn, "chute_blocks").contains(&"diffusion_y_m2_per_s".to_string()));
    }
    for _ in 0..2 {
        let conn = sweep::store::open(&path).unwrap();
        let v: i64 = conn
            .query_row("PRAGMA user_version", [], |r| r.get(0))
            .unwrap();
        assert_eq!(v, sweep::store::SCHEMA_VERSION);
        assert_eq!(v, 15);
        // Schema 14's table of what each look had spent.
        assert!(columns(&conn, "claim_looks").contains(&"core_hours".to_string()));
        // Schema 15's CPU time of each job: unknown for the jobs that ran before.
        let cpu: Option<f64> = conn
            .query_row("SELECT cpu_time_s FROM jobs WHERE id = 1", [], |r| r.get(0))
            .unwrap();
        assert_eq!(cpu, None);
        let cols = columns(&conn, "chute_blocks");
        for c in [
            "nematic_order_s2",
            "mean_abs_cos_flow",
            "diffusion_y_m2_per_s",
            "diffusion_y_stderr_m2_per_s",
        ] {
            assert!(cols.iter().any(|x| x == c), "{c} missing: {cols:?}");
        }
        let rows = sweep::store::chute_reads::blocks(&conn, 1).unwrap();
        assert_eq!(rows.len(), 1);
        let b = &rows[0];
        assert_eq!(
            (b.block, b.z_m, b.diffusion_m2_per_s, b.shear_rate_per_s),
            (3, 0.4375, Some(2.5e-4), 0.75)
        );
        assert_eq!((b.velocity_x_m_per_s, b.solid_fraction), (1.5, 0.55));
        assert_eq!(
            (
                b.nematic_order,
                b.mean_abs_cos_flow,
                b.diffusion_y_m2_per_s,
                b.diffusion_y_stderr_m2_per_s
            ),
            (None, None, None, None)
        );
    }
}
