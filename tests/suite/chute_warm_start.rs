//! The chute's warm start (`initial_state: "bagnold"`) on the engine: a dense sphere bed started
//! with Bagnold's profile keeps flowing (it neither stops nor blows up) and its particles do not
//! sink into one another or the base; a rod bed lying along the flow runs too.

use sweep::campaign::Precision;
use sweep::engine::State;
use sweep::runner::backend::{self, BackendChoice};
use sweep::scene::chute_warm_start::{InitialState, WARM_OVERLAP_D};
use sweep::scene::{ChuteParams, ChuteScene};

/// Mean v_x of the flowing particles and their largest overlap with any particle (d units:
/// particle–particle and particle–base, brute force over the minimum image).
fn flow_and_overlap(s: &State<f64>, lx: f64, ly: f64) -> (f64, f64) {
    let mobile: Vec<usize> = (0..s.len()).filter(|&i| s.inv_mass[i] > 0.0).collect();
    let vx = mobile.iter().map(|&i| s.vel[i].to_f64()[0]).sum::<f64>() / mobile.len() as f64;
    let mut worst: f64 = 0.0;
    for &i in &mobile {
        for j in 0..s.len() {
            if j == i {
                continue;
            }
            let (a, b) = (s.position_f64(i), s.position_f64(j));
            let mut d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
            d[0] -= lx * (d[0] / lx).round();
            d[1] -= ly * (d[1] / ly).round();
            let dist = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            worst = worst.max(s.radius[i] + s.radius[j] - dist);
        }
    }
    (vx, worst / (2.0 * s.radius[mobile[0]]))
}

/// Spheres (d = m = g = 1, k_n = 2·10⁵, e_n = 0.88, μ = 0.5) on a 5 d × 5 d chute at 26°: the
/// warm bed starts with overlaps below `WARM_OVERLAP_D` (10⁻⁴ d), and after 5 time units it still flows downhill at a
/// velocity of the order of its start (a bed that stopped or ran away would not), with overlaps
/// those of a k_n = 2·10⁵ m g / d bed (a few 10⁻⁴ d under its own weight; 1 % bounds them).
#[test]
fn a_warm_sphere_bed_keeps_flowing() {
    let scene = ChuteScene::new(ChuteParams {
        aspect_ratio: 1.0,
        particle_length_m: 1.0,
        particle_density_kg_per_m3: 6.0 / std::f64::consts::PI,
        box_x_lengths: 5.0,
        box_y_lengths: 5.0,
        bed_height_lengths: 10.0,
        inclination_deg: 26.0,
        initial_state: InitialState::Bagnold,
        ..ChuteParams::default()
    })
    .unwrap();
    let (lx, ly) = scene.p.box_size();
    let s0 = scene.start_state(11);
    let (v0, o0) = flow_and_overlap(&s0, lx, ly);
    assert!(
        o0 <= WARM_OVERLAP_D + 1e-12,
        "the warm bed starts with an overlap of {o0} d"
    );
    assert!(v0 > 0.5, "the warm bed starts at rest: {v0}");
    let mut engine = backend::build(
        BackendChoice::Cpu,
        Precision::F64,
        scene.engine_config(),
        &s0,
        2,
    )
    .unwrap();
    engine.advance((5.0 / scene.dt).round() as u64).unwrap();
    let s = engine.download();
    let (v, o) = flow_and_overlap(&s, lx, ly);
    eprintln!("mean v_x {v0:.3} -> {v:.3} in 5 time units; largest overlap {o:.2e} d");
    assert!(
        v > 0.3 * v0 && v < 3.0 * v0,
        "v_x {v0} -> {v}: not a flowing state"
    );
    assert!(o < 0.01, "largest overlap {o} d");
}

/// Rods (ξ = 1.5, the paper's units) start along the flow and run on the rod engine.
#[test]
fn a_warm_rod_bed_runs() {
    let scene = ChuteScene::new(ChuteParams {
        aspect_ratio: 1.5,
        box_x_lengths: 4.0,
        box_y_lengths: 4.0,
        bed_height_lengths: 4.0,
        contact_steps: 20.0,
        inclination_deg: 30.0,
        initial_state: InitialState::Bagnold,
        ..ChuteParams::default()
    })
    .unwrap();
    let s0 = scene.start_state(5);
    let mut engine = backend::build(
        BackendChoice::Cpu,
        Precision::F64,
        scene.engine_config(),
        &s0,
        2,
    )
    .unwrap();
    engine.advance((0.5 / scene.dt).round() as u64).unwrap();
    let s = engine.download();
    let mobile: Vec<usize> = (0..s.len()).filter(|&i| s.inv_mass[i] > 0.0).collect();
    let vx = mobile.iter().map(|&i| s.vel[i].to_f64()[0]).sum::<f64>() / mobile.len() as f64;
    assert!(vx.is_finite() && vx > 0.0, "mean v_x {vx}");
    assert!(s.kinetic_energy().is_finite());
}

/// A campaign may name the warm start's parameters (and `tangential_restitution` and
/// `catch_plane_height_lengths`, also left out at their defaults); at their defaults the job is the one without them (same hash), a
/// bad value is refused naming its JSON path.
#[test]
fn campaign_defaults_keep_job_hashes() {
    use sweep::campaign::{expand, CampaignFile};
    let hash = |base: &str| {
        let text = format!(r#"{{"name": "t", "scene": "chute", "base": {{{base}}}}}"#);
        let c = CampaignFile::parse_str(&text, "t.json").unwrap();
        expand(&c, "t.json").map(|j| j.get(0).hash())
    };
    let plain = hash(r#""inclination_deg": 27.0"#).unwrap();
    let defaults = hash(
        r#""inclination_deg": 27.0, "initial_state": "pour", "warm_inertial_number": 0.1,
        "warm_surface_velocity_m_per_s": null, "tangential_restitution": null,
        "catch_plane_height_lengths": null"#,
    )
    .unwrap();
    assert_eq!(plain, defaults);
    let raised = hash(r#""inclination_deg": 27.0, "catch_plane_height_lengths": 0.0"#).unwrap();
    assert_ne!(plain, raised);
    let e = hash(r#""catch_plane_height_lengths": 0.2"#).unwrap_err();
    assert!(e.to_string().contains("catch_plane_height_lengths"), "{e}");
    let warm = hash(r#""inclination_deg": 27.0, "initial_state": "bagnold""#).unwrap();
    assert_ne!(plain, warm);
    let e = hash(r#""initial_state": "bagnold", "warm_inertial_number": 0.0"#).unwrap_err();
    assert!(e.to_string().contains("warm_inertial_number"), "{e}");
    assert!(hash(r#""initial_state": "lattice""#).is_err());
}
