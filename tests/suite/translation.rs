//! Translation invariance: a scene moved by `origin_m` (100 m, and 10 km) gives the results it
//! gives at the origin, in f32, on the CPU and the GPU (the GPU's silo in `gpu_translation.rs`). The moved and the unmoved jobs start
//! from the same packing (the seed ignores `origin_m`) and diverge only through the engine's
//! rounding, so each result is compared with its statistical error (for the silo, the 95 % CI
//! of the difference of two flow rates, √(CI₀² + CI₁²)).
//!
//! These small, soft scenes flow fast enough that plain f32 coordinates (before split
//! positions) still pass at 100 m; at 10 km (f32 numbers 10⁻³ m apart) plain f32 failed both:
//! the silo stopped on an overlap of 0.24 d and the chute flowed at 0.74 m/s instead of 0.26.
//! The slow-particle and resting-overlap tests that fail at 100 m are in `precision.rs`.

use std::path::Path;

use crate::common::cli::{launch_on, read_db, tiny_chute, write_campaign};
use serde_json::{json, Value};
use tempfile::TempDir;

/// Where the moved jobs sit.
pub const MOVED: [f64; 2] = [100.0, 1.0e4];

/// The tiny silo (300 particles, 1 s of discharge) at the origin and `moved` metres above it, f32.
fn silo(moved: &[f64]) -> Value {
    let origins: Vec<[f64; 3]> = std::iter::once(0.0)
        .chain(moved.iter().copied())
        .map(|z| [0.0, 0.0, z])
        .collect();
    json!({
        "name": "silo_origin",
        "scene": "silo",
        "base": {
            "cylinder_radius_m": 0.03, "cylinder_height_m": 0.2, "particle_count": 300,
            "youngs_modulus_pa": 3.0e6, "shear_modulus_pa": 1.0e5, "dt_s": null,
            "contact_steps": 20, "discharge_time_s": 1.0, "settle_max_time_s": 0.2,
            "orifice_diameter_m": 0.02, "rotation_frequency_hz": 1.0
        },
        "sweep": { "origin_m": origins },
        "observers": { "discharge": { "skip_initial_s": 0.1, "block_s": 0.05 } },
        "run": { "precision": "f32", "checkpoint_interval_s": 1.0 }
    })
}

/// Where a job's scene sits (its height z), from its stored parameters.
fn origin_z(params_json: &str) -> f64 {
    let v: Value = serde_json::from_str(params_json).unwrap();
    let scene = v.get("silo").or_else(|| v.get("chute")).unwrap();
    scene
        .get("origin_m")
        .map_or(0.0, |o| o[2].as_f64().unwrap())
}

/// (origin z, Q, its 95 % CI) of each silo job, by origin.
fn flow_rates(db: &Path) -> Vec<(f64, f64, f64)> {
    let conn = read_db(db);
    let mut q = conn
        .prepare(
            "SELECT j.params_json, s.q_kg_per_s, s.q_ci95_kg_per_s FROM discharge_summary s
             JOIN jobs j ON j.id = s.job_id",
        )
        .unwrap();
    let mut out: Vec<(f64, f64, f64)> = q
        .query_map([], |r| {
            Ok((origin_z(&r.get::<_, String>(0)?), r.get(1)?, r.get(2)?))
        })
        .unwrap()
        .map(Result::unwrap)
        .collect();
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    out
}

pub fn silo_is_invariant(backend: &str, moved: &[f64]) {
    let dir = TempDir::new().unwrap();
    let file = write_campaign(dir.path(), "silo.json", &silo(moved));
    let db = dir.path().join("sweep.db");
    launch_on(dir.path(), &file, &db, backend, 2);
    let q = flow_rates(&db);
    assert_eq!(q.len(), 1 + moved.len(), "a job per origin: {q:?}");
    let (_, q0, ci0) = q[0];
    assert!(
        q0 > 0.0 && ci0 < 0.5 * q0,
        "the reference run barely flowed"
    );
    for &(z, q1, ci1) in &q[1..] {
        // Two estimates of one rate: their difference's 95 % CI combines both.
        let ci = (ci0 * ci0 + ci1 * ci1).sqrt();
        eprintln!(
            "{backend}: Q = {q0:.4} ± {ci0:.4} kg/s at the origin, {q1:.4} ± {ci1:.4} kg/s {z} m up (difference's CI {ci:.4})"
        );
        assert!(
            (q1 - q0).abs() <= ci,
            "{backend}: Q = {q1} ± {ci1} kg/s {z} m up, {q0} ± {ci0} kg/s at the origin: the difference exceeds its 95 % CI {ci}"
        );
    }
}

#[test]
fn a_silo_moved_100_m_discharges_at_the_same_rate_on_the_cpu() {
    silo_is_invariant("cpu", &MOVED);
}

/// Mean V_x of each chute job (mass-weighted over the coarse-grained profile, after 1 s to the
/// steady-state test and 1 s of measurement), with the height its scene sits at.
fn chute_velocities(db: &Path) -> Vec<(f64, f64)> {
    let conn = read_db(db);
    let mut q = conn
        .prepare(
            "SELECT j.params_json,
                    SUM(f.velocity_x_m_per_s * f.density_kg_per_m3) / SUM(f.density_kg_per_m3)
             FROM chute_fields f JOIN jobs j ON j.id = f.job_id GROUP BY f.job_id",
        )
        .unwrap();
    q.query_map([], |r| Ok((origin_z(&r.get::<_, String>(0)?), r.get(1)?)))
        .unwrap()
        .map(Result::unwrap)
        .collect()
}

fn mean_and_variance(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    (
        m,
        x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0),
    )
}

/// Four replicas of a small chute at the origin and moved 100 m and 10 km along each axis: their
/// mean V_x agree within the replicas' own scatter (Welch: |Δ| ≤ t·SE with t = 2.45, 95 % for 6
/// degrees of freedom).
#[test]
fn a_chute_moved_100_m_flows_at_the_same_speed() {
    let dir = TempDir::new().unwrap();
    let origins = vec![[0.0; 3], [MOVED[0]; 3], [MOVED[1]; 3]];
    let mut c = tiny_chute("chute_origin", "f32", 1.0);
    c["sweep"] = json!({ "origin_m": origins });
    c["replicas"] = json!(4);
    let file = write_campaign(dir.path(), "chute.json", &c);
    let db = dir.path().join("sweep.db");
    launch_on(dir.path(), &file, &db, "cpu", 2);
    let v = chute_velocities(&db);
    let group = |z: f64| -> Vec<f64> { v.iter().filter(|r| r.0 == z).map(|r| r.1).collect() };
    let at0 = group(0.0);
    assert_eq!(at0.len(), 4, "{v:?}");
    let (m0, v0) = mean_and_variance(&at0);
    assert!(m0 > 0.05, "the reference chute does not flow: {m0} m/s");
    for z in MOVED {
        let moved = group(z);
        assert_eq!(moved.len(), 4, "{v:?}");
        let (m1, v1) = mean_and_variance(&moved);
        let se = ((v0 + v1) / 4.0).sqrt();
        eprintln!("mean V_x {m0:.4} m/s at the origin ({at0:.4?}), {m1:.4} m/s moved {z} m ({moved:.4?}), SE {se:.4}");
        assert!(
            (m1 - m0).abs() <= 2.45 * se,
            "mean V_x {m1} m/s moved {z} m, {m0} m/s at the origin (SE of the difference {se})"
        );
    }
}
