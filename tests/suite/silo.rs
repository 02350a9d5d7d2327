//! Silo physics, end to end through the `sweep` binary and the database.
//! - Beverloo: at f = 0, Q(D) over four orifices (5–7.25 d, container diameter ≥ 3 D) follows Q = C ρ_b √g (D − k d)^{5/2} with the
//!   fitted k in [1.0, 2.0] and C in [0.45, 0.75] (the accepted ranges for spheres).
//! - Clogging: at f = 0 and D ≈ 3 d most seeds clog permanently within a few seconds (recorded,
//!   job done, not failed); the same D at f = 1 Hz keeps discharging.
//! - Rotating bottom without an orifice: the bottom layer follows the drag profile
//!   v_θ = κ 2π f r with a slip factor κ in [0.5, 1.02] in an inner and an outer ring (f taken
//!   as rad/s would give κ ≈ 0.1).
//!
//! A failure means the silo scene, the rotating wall or the discharge observer is wrong.

use std::path::Path;
use std::process::Command;

use sweep::engine::walls::WallShape;
use sweep::engine::{Backend, CpuEngine};
use sweep::observe::fits::{beverloo_c_at_k, beverloo_fit};
use sweep::scene::silo::{SiloParams, SiloPhase, SiloScene};

fn launch(dir: &Path, campaign: &serde_json::Value) {
    let file = dir.join("c.json");
    std::fs::write(&file, serde_json::to_string_pretty(campaign).unwrap()).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_sweep"))
        .args([
            "launch",
            file.to_str().unwrap(),
            "--db",
            dir.join("t.db").to_str().unwrap(),
            "--parallel",
            "2",
            "--threads",
            "1",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "launch failed: {}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A small, soft silo (Y = 3 MPa, G = Y/30), d = 5.8 mm, n_c = 20, re-inserting particles.
fn base(n: usize, rc: f64, t: f64) -> serde_json::Value {
    serde_json::json!({
        "cylinder_radius_m": rc, "cylinder_height_m": 0.3, "particle_count": n,
        "youngs_modulus_pa": 3.0e6, "shear_modulus_pa": 1.0e5, "dt_s": null, "contact_steps": 20,
        "discharge_time_s": t, "settle_max_time_s": 0.8, "reinsert": true
    })
}

#[test]
#[ignore = "long tier (minutes on 2 cores): bash scripts/test-long.sh"]
fn beverloo_at_f0_over_four_orifices() {
    let dir = tempfile::tempdir().unwrap();
    let d = 0.0058;
    let ds: Vec<f64> = [5.0, 5.75, 6.5, 7.25].iter().map(|k| k * d).collect();
    let c = serde_json::json!({
        "name": "beverloo", "scene": "silo", "base": base(4500, 0.065, 1.5),
        "sweep": { "orifice_diameter_m": ds, "rotation_frequency_hz": [0.0] },
        "observers": { "discharge": { "skip_initial_s": 0.3, "block_s": 0.2 } },
        "run": { "precision": "f32" }
    });
    launch(dir.path(), &c);
    let conn = rusqlite::Connection::open(dir.path().join("t.db")).unwrap();
    let mut q = conn.prepare("SELECT orifice_diameter_m, q_kg_per_s, bulk_density_kg_per_m3 FROM discharge_summary ORDER BY orifice_diameter_m").unwrap();
    let rows: Vec<(f64, Option<f64>, f64)> = q
        .query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))
        .unwrap()
        .collect::<Result<_, _>>()
        .unwrap();
    assert_eq!(rows.len(), 4);
    let x: Vec<f64> = rows.iter().map(|r| r.0).collect();
    let y: Vec<f64> = rows
        .iter()
        .map(|r| r.1.expect("every orifice ≥ 5 d flows"))
        .collect();
    let rho_b = rows[0].2;
    assert!(
        rho_b > 1300.0 && rho_b < 1750.0,
        "bulk density {rho_b} kg/m³ (φ = {})",
        rho_b / 2655.0
    );
    for w in y.windows(2) {
        assert!(w[1] > w[0], "Q must rise with D: {y:?}");
    }
    let fit = beverloo_fit(&x, &y, d, rho_b, 9.81).expect("fit");
    let c15 = beverloo_c_at_k(&x, &y, d, rho_b, 9.81, 1.5).expect("C at k = 1.5");
    eprintln!(
        "Beverloo: C = {:.3}, k = {:.3}; at k = 1.5: C = {c15:.3}; ρ_b = {rho_b:.0} kg/m³, Q = {y:?}",
        fit.c, fit.k
    );
    assert!((1.0..=2.0).contains(&fit.k), "k = {}", fit.k);
    // The jointly fitted C and k trade off against each other (changes of the trajectories
    // alone have moved them between (0.425, 1.16) and (0.46, 1.28)), so the joint C only gets a
    // sanity band; the physics check is C at the usual k = 1.5, which moves only with the flow
    // rates themselves. Published values for spheres are 0.55–0.65 (Beverloo: 0.58); this silo
    // is soft (Y = 3 MPa, n_c = 20) and narrow (22 d), which the accuracy map shows moves Q by
    // up to ~15 %, hence 0.45–0.65. Measured: 0.513.
    assert!((0.4..=0.8).contains(&fit.c), "C = {}", fit.c);
    assert!((0.45..=0.65).contains(&c15), "C at k = 1.5: {c15}");
}

#[test]
#[ignore = "long tier (minutes on 2 cores): bash scripts/test-long.sh"]
fn small_orifice_clogs_at_rest_and_flows_when_rotating() {
    let dir = tempfile::tempdir().unwrap();
    let c = serde_json::json!({
        "name": "clog", "scene": "silo", "base": base(1500, 0.04, 4.0),
        "sweep": { "orifice_diameter_m": [0.0174], "rotation_frequency_hz": [0.0, 1.0] },
        "replicas": 3,
        "observers": { "discharge": { "permanent_clog_after_s": 1.5, "clog_after_s": 0.3, "skip_initial_s": 0.2, "block_s": 0.2 } },
        "run": { "precision": "f32" }
    });
    launch(dir.path(), &c);
    let conn = rusqlite::Connection::open(dir.path().join("t.db")).unwrap();
    let statuses: Vec<String> = conn
        .prepare("SELECT status FROM jobs")
        .unwrap()
        .query_map([], |r| r.get(0))
        .unwrap()
        .collect::<Result<_, _>>()
        .unwrap();
    assert!(
        statuses.iter().all(|s| s == "done"),
        "clogging must end jobs as done: {statuses:?}"
    );
    let rows: Vec<(f64, i64, i64)> = conn
        .prepare("SELECT rotation_frequency_hz, permanently_clogged, discharged_count FROM discharge_summary")
        .unwrap()
        .query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))
        .unwrap()
        .collect::<Result<_, _>>()
        .unwrap();
    let still: Vec<_> = rows.iter().filter(|r| r.0 == 0.0).collect();
    let turning: Vec<_> = rows.iter().filter(|r| r.0 == 1.0).collect();
    eprintln!("f = 0: {still:?}\nf = 1: {turning:?}");
    assert!(
        still.iter().filter(|r| r.1 == 1).count() >= 2,
        "most f = 0 seeds clog permanently: {still:?}"
    );
    assert!(
        turning.iter().all(|r| r.1 == 0),
        "f = 1 Hz keeps flowing: {turning:?}"
    );
    let out_still: i64 = still.iter().map(|r| r.2).sum();
    let out_turning: i64 = turning.iter().map(|r| r.2).sum();
    assert!(
        out_turning > 3 * out_still,
        "rotation discharges far more: {out_turning} vs {out_still}"
    );
}

#[test]
fn rotating_bottom_drags_the_bottom_layer() {
    let p = SiloParams {
        cylinder_radius_m: 0.04,
        particle_count: 800,
        youngs_modulus_pa: 3.0e6,
        shear_modulus_pa: Some(1.0e5),
        dt_s: None,
        contact_steps: Some(20.0),
        rotation_frequency_hz: 1.0,
        ..SiloParams::default()
    };
    let scene = SiloScene::new(p.clone()).unwrap();
    let mut e = CpuEngine::<f64>::new(
        scene.engine_config(SiloPhase::Fill),
        scene.initial_state(7),
        2,
    );
    let chunk = (0.01 / scene.dt) as u64;
    for _ in 0..50 {
        e.advance(chunk).unwrap();
    }
    let settled = e.download();
    let mut cfg = scene.engine_config(SiloPhase::Discharge);
    for w in &mut cfg.walls {
        if let WallShape::OrificePlate { orifice_radius, .. } = &mut w.shape {
            *orifice_radius = 0.0;
        }
    }
    let mut e = CpuEngine::<f64>::new(cfg, settled.convert(), 2);
    for _ in 0..50 {
        e.advance(chunk).unwrap();
    }
    let s = e.download();
    // The drag profile of a bottom layer carried by the disk: v_θ(r) = κ Ω r with Ω = 2π f
    // (f in Hz) and a slip factor κ ≤ 1 (full co-rotation is κ = 1). Measured per particle as
    // v_θ / (Ω r), in an inner and an outer ring of the bottom layer.
    let omega = std::f64::consts::TAU * p.rotation_frequency_hz;
    let rc = p.cylinder_radius_m;
    let mut rings = [(0.0, 0usize), (0.0, 0usize)];
    for i in 0..s.len() {
        let q = s.pos[i];
        let r = (q.x * q.x + q.y * q.y).sqrt();
        if q.z < 0.75 * p.particle_diameter_m && r > 2.0 * p.particle_diameter_m {
            let v_theta = (q.x * s.vel[i].y - q.y * s.vel[i].x) / r;
            let ring = usize::from(r > 0.5 * rc);
            rings[ring].0 += v_theta / (omega * r);
            rings[ring].1 += 1;
        }
    }
    for (name, (sum, n)) in ["inner (r < R_c/2)", "outer"].iter().zip(rings) {
        assert!(n > 10, "{name} ring of the bottom layer has {n} particles");
        let kappa = sum / n as f64;
        eprintln!("bottom layer, {name}: <v_θ / (2π f r)> = {kappa:.3} over {n} particles");
        // Carried by friction: well above the 1/(2π) = 0.16 that f read as rad/s would give,
        // and no faster than the disk. The static side wall slows the outer ring.
        assert!(
            (0.5..=1.02).contains(&kappa),
            "{name}: v_θ = {kappa:.3} × 2π f r, outside the drag band [0.5, 1.02]"
        );
    }
}

/// Re-insertion keeps the bed whole: a refilled silo whose orifice is about as wide as its bed
/// is deep (campaigns/accuracy_cost.json's scene: N = 500, R_c = 3 cm, D = 24 mm = 4.1 d, soft
/// spheres, f32) ends 1.5 s of discharge with every particle, each id once, after hundreds of
/// exits. (When the floor was measured on the particles still falling it climbed to the lid,
/// and the runner's job of this scene ended with 229 of 500.)
#[test]
fn a_refilled_silo_keeps_every_particle() {
    use crate::common;
    use sweep::observe::discharge::DischargeSettings;
    let n = 500;
    let scene = SiloScene::new(SiloParams {
        cylinder_radius_m: 0.03,
        cylinder_height_m: 0.25,
        particle_count: n,
        youngs_modulus_pa: 3.0e6,
        shear_modulus_pa: Some(1.0e5),
        dt_s: None,
        contact_steps: Some(20.0),
        orifice_diameter_m: 0.024,
        discharge_time_s: 1.5,
        settle_max_time_s: 0.4,
        reinsert: true,
        ..SiloParams::default()
    })
    .expect("valid silo");
    let fill = scene.engine_config(SiloPhase::Fill);
    let start = common::silo::fill(
        &mut CpuEngine::<f32>::new(fill, scene.initial_state(1).convert(), 2),
        &scene,
    );
    let settings = DischargeSettings {
        sample_interval_s: 0.01,
        clog_after_s: 0.5,
        permanent_clog_after_s: 2.0,
        skip_initial_s: 0.2,
        block_s: 0.1,
    };
    let config = scene.engine_config(SiloPhase::Discharge);
    let mut b = CpuEngine::<f32>::new(config, start.convert(), 2);
    let (_, out) = common::silo::discharge(&mut b, &scene, &settings, start.time, 1);
    let end = b.download();
    assert!(
        out > 200,
        "only {out} exits: the scene no longer tests re-insertion"
    );
    assert_eq!(
        end.len(),
        n,
        "{out} exits re-inserted into {} particles",
        end.len()
    );
    let ids: std::collections::BTreeSet<u32> = end.id.iter().copied().collect();
    assert_eq!(ids.len(), n, "an id appears twice");
}
