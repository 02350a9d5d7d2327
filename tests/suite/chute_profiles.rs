//! The chute observer's per-block orientation (S2, ⟨|cos θ|⟩) and D_y against analytic values,
//! and its checkpoints across the change that added them. Each test's `///` header states its
//! law, its tolerance and what a failure means; in short:
//! - S2 = 1 for parallel axes, 1/4 for axes isotropic in a plane, ≈ 0 for isotropic ones
//!   (within 5/√N, N the rod samples); ⟨|cos θ|⟩ = 1, 0, 2/π, 1/2 for axes along the flow,
//!   across it, isotropic in the x–y plane and isotropic (within 4 standard errors);
//! - D_y of random walks in y, wrapped into the periodic box, given back per block within
//!   3 of its window errors (and 6 %), in both `msd_blocks` assignments; spheres store no
//!   orientation but their D_y;
//! - an observer checkpointed before these accumulators existed resumes with them missing (their
//!   values None) and every other result bit for bit; one checkpointed with them resumes bit for
//!   bit; a damaged record is refused.

use crate::common::Noise;

use sweep::engine::contact::ContactRecord;
use sweep::observe::chute::{
    ChuteGeometry, ChuteObserver, ChuteObserverSettings, ChuteResults, ChuteSnapshot,
};
use sweep::observe::chute_stats::{abs_cos_to, nematic_order};
use sweep::observe::msd::MsdBlocks;

use std::f64::consts::PI;

const L: f64 = 0.125;
const Z_BASE: f64 = 0.1;
const BLOCKS: usize = 4;

fn uniform01(n: &mut Noise) -> f64 {
    0.5 * (n.next() + 1.0)
}

fn gauss(n: &mut Noise) -> f64 {
    let u1 = 1.0 - uniform01(n);
    let u2 = uniform01(n);
    (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
}

fn isotropic(n: &mut Noise) -> [f64; 3] {
    let u = [gauss(n), gauss(n), gauss(n)];
    let r = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
    u.map(|c| c / r)
}

fn planar(n: &mut Noise) -> [f64; 3] {
    let phi = 2.0 * PI * uniform01(n);
    [phi.cos(), phi.sin(), 0.0]
}

/// The four orientation laws of blocks 0–3: along x (flipped at random: a rod has no head),
/// isotropic, isotropic in the x–y plane, along z.
fn axis_of_block(k: usize, n: &mut Noise) -> [f64; 3] {
    let sign = if n.next() < 0.0 { -1.0 } else { 1.0 };
    match k {
        0 => [sign, 0.0, 0.0],
        1 => isotropic(n),
        2 => planar(n),
        _ => [0.0, 0.0, sign],
    }
}

fn geometry(rods: bool) -> ChuteGeometry {
    let d = if rods { L / 2.5 } else { L };
    ChuteGeometry {
        total_length_m: L,
        diameter_m: d,
        cylinder_length_m: L - d,
        box_x_m: 1.0,
        box_y_m: 1.0,
        z_base_m: Z_BASE,
        z_top_m: Z_BASE + BLOCKS as f64 * L,
        inclination_deg: 28.0,
    }
}

struct Frame {
    t: f64,
    id: Vec<u32>,
    pos: Vec<[f64; 3]>,
    vel: Vec<[f64; 3]>,
    axis: Vec<[f64; 3]>,
    mass: Vec<f64>,
}

impl Frame {
    fn snapshot(&self) -> ChuteSnapshot<'_> {
        ChuteSnapshot {
            time_s: self.t,
            id: &self.id,
            pos: &self.pos,
            vel: &self.vel,
            axis: &self.axis,
            mass: &self.mass,
            contacts: &[] as &[ContactRecord],
        }
    }
}

/// D_y of block k (m²/s): block 3 diffuses 4 times faster than block 0.
fn d_y(k: usize) -> f64 {
    1e-3 * (k + 1) as f64
}

/// `per_block` particles in each block at a fixed height (its centre ± L/4), y a Gaussian walk
/// of diffusivity `d_y(k)` wrapped into [0, 1) (over 20 s a particle moves ~0.2–0.4 m, so many
/// cross the boundary), x a shear drift, axes by `axis_of_block`, listed in a different order
/// every frame.
fn frames(per_block: usize, count: usize, dt: f64, seed: u64) -> Vec<Frame> {
    let n = per_block * BLOCKS;
    let mut noise = Noise::new(seed);
    let block = |i: usize| i / per_block;
    let mut pos: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let z = Z_BASE + (block(i) as f64 + 0.25 + 0.5 * uniform01(&mut noise)) * L;
            [uniform01(&mut noise), uniform01(&mut noise), z]
        })
        .collect();
    let mut out = Vec::new();
    for f in 0..count {
        let vel: Vec<[f64; 3]> = pos
            .iter()
            .map(|p| {
                [
                    p[2] + 0.01 * gauss(&mut noise),
                    0.0,
                    0.01 * gauss(&mut noise),
                ]
            })
            .collect();
        let axis: Vec<[f64; 3]> = (0..n)
            .map(|i| axis_of_block(block(i), &mut noise))
            .collect();
        let order: Vec<usize> = (0..n).map(|i| (i * 7 + f * 13) % n).collect();
        out.push(Frame {
            t: 3.0 + f as f64 * dt,
            id: order.iter().map(|&i| i as u32).collect(),
            pos: order.iter().map(|&i| pos[i]).collect(),
            vel: order.iter().map(|&i| vel[i]).collect(),
            axis: order.iter().map(|&i| axis[i]).collect(),
            mass: vec![1e-3; n],
        });
        for (i, p) in pos.iter_mut().enumerate() {
            p[0] = (p[0] + vel[i][0] * dt).rem_euclid(1.0);
            p[1] = (p[1] + (2.0 * d_y(block(i)) * dt).sqrt() * gauss(&mut noise)).rem_euclid(1.0);
        }
    }
    out
}

fn settings(assignment: MsdBlocks) -> ChuteObserverSettings {
    ChuteObserverSettings {
        max_lag_s: 1.0,
        fit_min_lag_s: 0.3,
        msd_blocks: assignment,
        ..Default::default()
    }
}

fn run(st: &ChuteObserverSettings, rods: bool, frames: &[Frame]) -> ChuteResults {
    let mut obs = ChuteObserver::new(st.clone(), geometry(rods)).expect("valid");
    for f in frames {
        obs.sample(&f.snapshot());
    }
    obs.finish()
}

/// Law: S2 is the largest eigenvalue of Q = ⟨(3 u⊗u − I)/2⟩: 1 for parallel axes (to rounding,
/// 10⁻¹²), 1/4 for axes isotropic in a plane, 0 for isotropic ones as N → ∞. For N isotropic
/// unit vectors E‖Q‖²_F = (3 · 1/5 + 6 · 3/20)/N = 1.5/N and, Q being traceless,
/// λ_max² ≤ (2/3)‖Q‖²_F, so E S2² ≤ 1/N: the tolerance 5/√N is 25 times that mean square
/// (Markov: a seed fails with probability < 4 %; N‖Q‖² is nearly χ² with 5 degrees of freedom,
/// which puts it below 10⁻⁶); the planar case has the same order of spread. ⟨|cos θ|⟩ to x:
/// |u_x| is uniform on [0, 1] for isotropic axes (mean 1/2, std 1/√12), and |cos φ| has mean
/// 2/π and std √(1/2 − 4/π²) for planar ones; tolerance 4 standard errors. A failure means the
/// tensor, its eigenvalue or the angle is wrong.
#[test]
fn nematic_order_and_abs_cos_of_known_distributions() {
    let n = 20_000;
    let mut noise = Noise::new(7);
    let tol = 5.0 / (n as f64).sqrt();
    let axes = |f: &mut dyn FnMut() -> [f64; 3]| (0..n).map(|_| f()).collect::<Vec<_>>();
    let dir = isotropic(&mut noise);
    let parallel = axes(&mut || {
        let s = if noise.next() < 0.0 { -1.0 } else { 1.0 };
        dir.map(|c| s * c)
    });
    let s2 = nematic_order(&parallel).unwrap();
    assert!((s2 - 1.0).abs() < 1e-12, "parallel: S2 = {s2}");
    let iso = axes(&mut || isotropic(&mut noise));
    let s2 = nematic_order(&iso).unwrap();
    assert!(
        s2 > 0.0 && s2 < tol,
        "isotropic: S2 = {s2}, tolerance {tol}"
    );
    let flat = axes(&mut || planar(&mut noise));
    let s2 = nematic_order(&flat).unwrap();
    assert!((s2 - 0.25).abs() < tol, "planar: S2 = {s2}");
    assert!(nematic_order(&[]).is_none());

    let mean_abs_cos = |v: &[[f64; 3]]| {
        v.iter()
            .map(|&u| abs_cos_to(u, [1.0, 0.0, 0.0]))
            .sum::<f64>()
            / v.len() as f64
    };
    let se_iso = (1.0f64 / 12.0).sqrt() / (n as f64).sqrt();
    let c = mean_abs_cos(&iso);
    assert!((c - 0.5).abs() < 4.0 * se_iso, "isotropic ⟨|cos θ|⟩ = {c}");
    let se_flat = (0.5 - 4.0 / (PI * PI)).sqrt() / (n as f64).sqrt();
    let c = mean_abs_cos(&flat);
    assert!(
        (c - 2.0 / PI).abs() < 4.0 * se_flat,
        "planar ⟨|cos θ|⟩ = {c}"
    );
    assert!((mean_abs_cos(&parallel) - dir[0].abs()).abs() < 1e-12);
}

/// Law: the observer's per-block S2 and ⟨|cos θ|⟩ are those of the rods centred in each block:
/// block 0 along x (1, 1), block 1 isotropic (0, 1/2), block 2 isotropic in x–y (1/4, 2/π),
/// block 3 along z (1, 0). 250 rods per block and 100 snapshots, fresh axes every snapshot:
/// N = 25 000 rod samples per block, tolerances as in the test above (5/√N for S2, 4 standard
/// errors for ⟨|cos θ|⟩). Spheres (ξ = 1) have no axis: None everywhere. A failure means rods
/// land in the wrong block or the averages are formed wrongly.
#[test]
fn observer_orientation_per_block() {
    let st = settings(MsdBlocks::Trajectory);
    let fr = frames(250, 100, st.sample_interval_s, 11);
    let r = run(&st, true, &fr);
    assert_eq!(r.blocks.len(), BLOCKS);
    let n = 25_000f64;
    let tol = 5.0 / n.sqrt();
    let want = [
        (1.0, 1.0, 0.0),
        (0.0, 0.5, (1.0f64 / 12.0).sqrt()),
        (0.25, 2.0 / PI, (0.5 - 4.0 / (PI * PI)).sqrt()),
        (1.0, 0.0, 0.0),
    ];
    for (b, (s2, c, std)) in r.blocks.iter().zip(want) {
        let got_s2 = b.nematic_order.expect("rods have S2");
        let got_c = b.mean_abs_cos_flow.expect("rods have |cos θ|");
        assert!(
            (got_s2 - s2).abs() <= tol.max(1e-12),
            "block {}: S2 = {got_s2}, expected {s2} ± {tol}",
            b.block
        );
        let se = (4.0 * std / n.sqrt()).max(1e-12);
        assert!(
            (got_c - c).abs() <= se,
            "block {}: ⟨|cos θ|⟩ = {got_c}, expected {c} ± {se}",
            b.block
        );
    }
    let spheres = run(&st, false, &fr);
    assert!(spheres
        .blocks
        .iter()
        .all(|b| b.nematic_order.is_none() && b.mean_abs_cos_flow.is_none()));
    assert!(spheres
        .blocks
        .iter()
        .all(|b| b.diffusion_y_m2_per_s.is_some()));
}

/// Law: MSD_y(τ) = 2 D_y τ for Gaussian steps of variance 2 D_y Δ. 200 particles per block,
/// 800 samples at Δ = 0.05 s, y wrapped into the 1 m box (most particles cross it), fitted on
/// τ ∈ [0.3, 1] s as D_z is: each block's D_y = 10⁻³ (k + 1) m²/s is recovered within 3 of its
/// own window standard errors (4 windows) and within 6 %, in both block assignments. D_y's
/// scatter is ~1 % here (√(2 τ_max / T) / √N); its 4-window estimate (3 degrees of freedom)
/// stays below 5 % unless it overshoots 4.5-fold (probability < 0.5 %). Without the unwrapping a crossing adds ~(1 m)² to a displacement and D_y
/// comes out many times too large; a failure also means the blocks are not D_z's.
#[test]
fn d_y_of_wrapped_random_walks_per_block() {
    for mode in [MsdBlocks::Trajectory, MsdBlocks::Window] {
        let st = settings(mode);
        let fr = frames(200, 800, st.sample_interval_s, 5);
        let r = run(&st, true, &fr);
        assert_eq!(r.blocks.len(), BLOCKS, "{mode:?}");
        for b in &r.blocks {
            let want = d_y(b.block as usize);
            let got = b.diffusion_y_m2_per_s.expect("D_y");
            let se = b.diffusion_y_stderr_m2_per_s.expect("D_y's error");
            assert!(
                (got - want).abs() <= 3.0 * se && (got - want).abs() <= 0.06 * want,
                "{mode:?} block {}: D_y = {got} ± {se}, expected {want}",
                b.block
            );
            assert!(
                se > 0.0 && se < 0.05 * want,
                "{mode:?}: error {se} of {want}"
            );
        }
    }
}

/// The keys of a chute observer's JSON as the build before the per-block orientation and D_y
/// wrote it (commit 464e26b): a checkpoint of that build holds exactly these.
const KEYS_BEFORE: [&str; 18] = [
    "settings",
    "geometry",
    "kernel",
    "blocks",
    "profiles",
    "msd",
    "vz_moments",
    "vz_pdf",
    "correlation",
    "block_particle_samples",
    "cos_theta_sum",
    "cos_theta_count",
    "mass_sum",
    "mass_count",
    "samples",
    "first_time_s",
    "last_time_s",
    "particles",
];

/// The results with the new per-block values blanked, as JSON text.
fn without_new_values(r: &ChuteResults) -> String {
    let mut r = r.clone();
    for b in &mut r.blocks {
        b.nematic_order = None;
        b.mean_abs_cos_flow = None;
        b.diffusion_y_m2_per_s = None;
        b.diffusion_y_stderr_m2_per_s = None;
    }
    serde_json::to_string(&r).unwrap()
}

/// Law: resume gives the same bytes as an uninterrupted run, and a checkpoint older than the
/// new accumulators still resumes. After 150 of 300 frames the observer is serialised; (a) read
/// back whole and fed the rest, state and results equal the uninterrupted run's bit for bit
/// (compared as JSON text) and the new values are there; (b) stripped to the keys the previous
/// build wrote (`KEYS_BEFORE`, and the z MSD's own keys unchanged), it reads back, goes on, and
/// gives every result bit for bit with the four new values None (they would cover only part
/// of the window); (c) a record whose new part is damaged, or cut short, is refused. A failure
/// in (b) means the new state leaks into the old results or the old layout no longer reads.
#[test]
fn checkpoints_before_and_after_the_new_accumulators_resume() {
    let st = settings(MsdBlocks::Trajectory);
    let fr = frames(60, 300, st.sample_interval_s, 3);
    let mut whole = ChuteObserver::new(st.clone(), geometry(true)).expect("valid");
    let mut half = whole.clone();
    for f in &fr {
        whole.sample(&f.snapshot());
    }
    for f in &fr[..150] {
        half.sample(&f.snapshot());
    }
    let json = serde_json::to_value(&half).unwrap();
    let reference = whole.finish();
    assert!(reference.blocks.iter().all(|b| b.nematic_order.is_some()
        && b.mean_abs_cos_flow.is_some()
        && b.diffusion_y_m2_per_s.is_some()
        && b.diffusion_y_stderr_m2_per_s.is_some()));

    // (a) this build's checkpoint.
    let mut resumed: ChuteObserver = serde_json::from_value(json.clone()).unwrap();
    for f in &fr[150..] {
        resumed.sample(&f.snapshot());
    }
    assert_eq!(
        serde_json::to_string(&whole).unwrap(),
        serde_json::to_string(&resumed).unwrap()
    );
    assert_eq!(
        serde_json::to_string(&reference).unwrap(),
        serde_json::to_string(&resumed.finish()).unwrap()
    );

    // (b) the previous build's checkpoint.
    let mut old = json.clone();
    let map = old.as_object_mut().unwrap();
    assert!(map.remove("orientation").is_some() && map.remove("lateral").is_some());
    let mut keys: Vec<&str> = map.keys().map(String::as_str).collect();
    let mut want = KEYS_BEFORE.to_vec();
    keys.sort_unstable();
    want.sort_unstable();
    assert_eq!(keys, want, "the previous build's layout");
    let mut msd_keys: Vec<&str> = map["msd"]
        .as_object()
        .unwrap()
        .keys()
        .map(String::as_str)
        .collect();
    msd_keys.sort_unstable();
    assert_eq!(
        msd_keys,
        [
            "cells",
            "filled",
            "fit",
            "last_seen",
            "layout",
            "ring",
            "samples",
            "slots",
            "sums",
            "window"
        ]
    );
    let mut from_old: ChuteObserver = serde_json::from_value(old).expect("an old checkpoint reads");
    for f in &fr[150..] {
        from_old.sample(&f.snapshot());
    }
    let got = from_old.finish();
    assert!(got.blocks.iter().all(|b| b.nematic_order.is_none()
        && b.mean_abs_cos_flow.is_none()
        && b.diffusion_y_m2_per_s.is_none()
        && b.diffusion_y_stderr_m2_per_s.is_none()));
    assert_eq!(without_new_values(&reference), without_new_values(&got));
    let mut whole_old = serde_json::to_value(&whole).unwrap();
    let m = whole_old.as_object_mut().unwrap();
    m.remove("orientation");
    m.remove("lateral");
    assert_eq!(whole_old, serde_json::to_value(&from_old).unwrap());

    // (c) damaged records are refused, not read as missing.
    let mut bad = json.clone();
    bad["lateral"] = serde_json::json!(5);
    assert!(serde_json::from_value::<ChuteObserver>(bad).is_err());
    let mut bad = json.clone();
    bad["orientation"]["q_sum"] = serde_json::json!("x");
    assert!(serde_json::from_value::<ChuteObserver>(bad).is_err());
    let text = serde_json::to_string(&json).unwrap();
    assert!(serde_json::from_str::<ChuteObserver>(&text[..text.len() / 2]).is_err());
}
