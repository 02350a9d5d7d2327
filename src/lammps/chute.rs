//! A sphere chute job written out for LAMMPS (`sweep plan FILE --lammps DIR`): the exact state
//! the job starts from (the fixed rough base and the flowing spheres with their velocities, pour
//! or warm start), gravity at the inclination, the contact law's constants (γ_t included), dt,
//! the periodic box and the catch plane, so that both codes run the same scene from the same
//! state (issue 24). LAMMPS writes what `scripts/compare-lammps-chute.sh` compares with sweep:
//! the kinetic energy (`ke.txt`), the profiles V_x(z), ρ(z) in bins of `dz` from the base
//! spheres' centres (`profile.txt`, `compute chunk/atom bin/1d` + `fix ave/chunk`).
//!
//! How the law is made identical (`gran/hooke/history`, F = k δ + m* γ v in LAMMPS, sweep's
//! γ m* = 2|β|√(k m*)):
//! - Between flowing spheres (m* = m/2): γ = 2|β|√(2k/m), as for the bench beds.
//! - Against the base: sweep treats a fixed sphere as infinitely heavy (m* = m); LAMMPS would do
//!   so too under `fix freeze`, and damp √2 times harder with the pairs' γ. So the base is not
//!   frozen but left out of the integration (it never moves) and given the mass m/(√2 − 1),
//!   which makes LAMMPS's m* = m/√2 and its damping γ m/√2 = 2|β|√(k m), sweep's.
//! - The catch plane (`fix wall/gran`, m* = m) gets its own γ = 2|β|√(k/m).
//! - e_t = 1 (γ_t = 0) is written as `dampflag 0`.
//!
//! Not the same, said in the input's header: LAMMPS's tangential spring is projected onto the
//! tangent plane without sweep's length rescaling, and its contact point velocity uses the
//! radii rather than r − δ/2 (both O(δ/d) ≈ 10⁻³ here).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Context as _;

use crate::campaign::JobSpec;
use crate::engine::contact::{beta, NormalModel};
use crate::engine::State;
use crate::scene::ChuteScene;

/// Bin width of the profiles, in particle diameters.
pub const PROFILE_BIN_D: f64 = 1.0;

/// What LAMMPS is asked to run and record.
#[derive(Clone, Copy, Debug)]
pub struct ChuteRun {
    /// Simulated time (s).
    pub time_s: f64,
    /// Interval between recorded kinetic energies (s).
    pub energy_every_s: f64,
    /// Interval between profile snapshots (s).
    pub profile_every_s: f64,
}

impl ChuteRun {
    /// The job's own schedule: its longest run (`steady_max_time_s + measure_time_s`), energies
    /// every 0.05 s (sweep's chunk), profiles at the snapshot interval (else the chute
    /// observer's sampling interval).
    pub fn of(spec: &JobSpec) -> Self {
        let profile_every_s = spec.observers.snapshots.as_ref().map_or_else(
            || {
                spec.observers
                    .chute
                    .clone()
                    .unwrap_or_default()
                    .sample_interval_s
            },
            |s| s.interval_s,
        );
        ChuteRun {
            time_s: spec.chute().max_time_s(),
            energy_every_s: crate::observe::chute::CHUNK_S,
            profile_every_s,
        }
    }
}

/// The LAMMPS constants of the scene: (pair, wall) `Kn Kt γn γt μ dampflag`, the flowing mass,
/// the base's mass.
struct Constants {
    pair: String,
    wall: String,
    base_mass: f64,
}

fn constants(scene: &ChuteScene) -> anyhow::Result<Constants> {
    let p = &scene.p;
    let law = p.law();
    let NormalModel::Linear {
        kn_n_per_m: kn,
        kt_n_per_m: kt,
    } = law.normal
    else {
        anyhow::bail!("--lammps: the chute's law is linear");
    };
    let m = p.particle_mass();
    let (bn, bt) = (
        beta(law.restitution).abs(),
        beta(law.tangential_restitution).abs(),
    );
    let dampflag = i32::from(bt != 0.0);
    // γ for a contact of reduced mass m*: 2|β|√(k/m*).
    let gamma = |b: f64, k: f64, ms: f64| 2.0 * b * (k / ms).sqrt();
    let line = |ms: f64| {
        format!(
            "{kn:e} {kt:e} {:e} {:e} {} {dampflag}",
            gamma(bn, kn, ms),
            gamma(bt, kt, ms),
            law.friction
        )
    };
    Ok(Constants {
        pair: line(0.5 * m),
        wall: line(m),
        base_mass: m / (std::f64::consts::SQRT_2 - 1.0),
    })
}

/// Writes `data.chute` and `in.chute` for chute job `spec` into `dir` (created); returns the
/// input's path.
///
/// # Errors
/// Rods (LAMMPS's granular styles take spheres), or a file that cannot be written.
pub fn export(spec: &JobSpec, run: ChuteRun, dir: &Path) -> anyhow::Result<PathBuf> {
    let scene = ChuteScene::new(spec.chute().clone()).map_err(|e| anyhow::anyhow!(e))?;
    anyhow::ensure!(
        scene.p.spheres(),
        "--lammps: a chute of spherocylinders (ξ = {}); LAMMPS's granular styles take spheres",
        scene.p.aspect_ratio
    );
    let state = scene.start_state(spec.seed());
    let k = constants(&scene)?;
    let data = data_file(&scene, &state, k.base_mass);
    let input = input_file(&scene, &k, run);
    std::fs::create_dir_all(dir)
        .with_context(|| format!("--lammps: creating {}", dir.display()))?;
    for (name, text) in [("data.chute", &data), ("in.chute", &input)] {
        let path = dir.join(name);
        std::fs::write(&path, text)
            .with_context(|| format!("--lammps: writing {}", path.display()))?;
    }
    Ok(dir.join("in.chute"))
}

/// The data file: type 1 the flowing spheres, type 2 the base; `atom_style sphere` (id type
/// diameter density x y z), then every velocity and spin. Values in full precision (`{:e}` is
/// the shortest text that reads back to the same f64).
fn data_file(scene: &ChuteScene, s: &State<f64>, base_mass: f64) -> String {
    let p = &scene.p;
    let (lx, ly) = p.box_size();
    let mut zhi = f64::NEG_INFINITY;
    for i in 0..s.len() {
        zhi = zhi.max(s.position_f64(i)[2] + s.radius[i]);
    }
    // The box starts at the catch plane; its top shrink-wraps (`boundary p p fm`).
    let zlo = scene.catch_plane_z();
    let mut out = String::new();
    let _ = writeln!(
        out,
        "sweep chute job: {} spheres ({} fixed), alpha = {} deg\n",
        s.len(),
        s.inv_mass.iter().filter(|&&x| x == 0.0).count(),
        p.inclination_deg
    );
    let _ = writeln!(out, "{} atoms\n2 atom types\n", s.len());
    let _ = writeln!(
        out,
        "0e0 {lx:e} xlo xhi\n0e0 {ly:e} ylo yhi\n{zlo:e} {zhi:e} zlo zhi"
    );
    let _ = writeln!(out, "\nAtoms # sphere\n");
    for i in 0..s.len() {
        let r = s.radius[i];
        let vol = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
        let (ty, mass) = if s.inv_mass[i] > 0.0 {
            (1, s.mass[i])
        } else {
            (2, base_mass)
        };
        let x = s.position_f64(i);
        let _ = writeln!(
            out,
            "{} {ty} {:e} {:e} {:e} {:e} {:e}",
            i + 1,
            2.0 * r,
            mass / vol,
            x[0],
            x[1],
            x[2]
        );
    }
    super::write_velocities(&mut out, s);
    out
}

fn input_file(scene: &ChuteScene, k: &Constants, run: ChuteRun) -> String {
    let p = &scene.p;
    let c = scene.engine_config();
    let g = p.gravity_m_per_s2;
    let steps = |t: f64| ((t / scene.dt).round() as u64).max(1);
    let d = 2.0 * p.shape().radius;
    let dz = PROFILE_BIN_D * d;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# sweep chute job (alpha = {} deg), written by `sweep plan --lammps`: the state sweep\n\
         # starts from, its law (gran/hooke/history; base mass and wall damping chosen so that\n\
         # every contact's damping is sweep's, see src/lammps/chute.rs), gravity, dt, box.\n\
         # Not the same: LAMMPS projects the tangential spring without rescaling its length and\n\
         # takes the contact point at the radii (O(overlap/d) differences).\n\
         # Run: mpirun -np 2 lmp -in in.chute  (writes ke.txt and profile.txt)",
        p.inclination_deg
    );
    let _ = writeln!(out, "units si\natom_style sphere\natom_modify map array");
    let _ = writeln!(out, "boundary p p fm\nnewton off\ncomm_modify vel yes");
    let _ = writeln!(out, "read_data data.chute");
    let _ = writeln!(out, "group mobile type 1\ngroup base type 2");
    let _ = writeln!(
        out,
        "# Pairs of flowing spheres (m* = m/2); the base's mass makes m* = m/sqrt(2) against it.\n\
         pair_style gran/hooke/history {}\npair_coeff * *",
        k.pair
    );
    let _ = writeln!(
        out,
        "neighbor {:e} bin\nneigh_modify delay 0 every 1 check yes exclude type 2 2",
        c.skin_m
    );
    let _ = writeln!(out, "timestep {:e}", scene.dt);
    let gv = c.gravity;
    let _ = writeln!(
        out,
        "fix gravity mobile gravity {g:e} vector {:e} {:e} {:e}",
        gv[0] / g,
        gv[1] / g,
        gv[2] / g
    );
    let _ = writeln!(out, "fix move mobile nve/sphere");
    let _ = writeln!(
        out,
        "fix catch mobile wall/gran hooke/history {} zplane {:e} NULL",
        k.wall,
        scene.catch_plane_z()
    );
    // Translational and rotational kinetic energy of the flowing spheres (sweep's series).
    let ne = steps(run.energy_every_s);
    let _ = writeln!(
        out,
        "compute ket mobile ke\ncompute ker mobile erotate/sphere\n\
         variable vcmx equal vcm(mobile,x)\n\
         fix energy mobile ave/time {ne} 1 {ne} c_ket c_ker v_vcmx file ke.txt"
    );
    // One snapshot of the profiles every profile interval, in bins of dz from z = 0, on the
    // steps where sweep samples: a whole number of its chunks.
    let np = ne * ((run.profile_every_s / (ne as f64 * scene.dt)).round() as u64).max(1);
    let _ = writeln!(
        out,
        "compute layers mobile chunk/atom bin/1d z 0.0 {dz:e} units box\n\
         fix profile mobile ave/chunk {np} 1 {np} layers vx density/mass density/number \
         file profile.txt"
    );
    let _ = writeln!(
        out,
        "thermo_style custom step time atoms c_ket c_ker v_vcmx\nthermo_modify format float %.6e\n\
         thermo {}\nrun {}",
        steps(1.0),
        steps(run.time_s)
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::campaign::{expand, CampaignFile};
    use crate::engine::contact::{contact_time, ContactPair};

    fn job(extra: &str) -> JobSpec {
        let text = format!(
            r#"{{"name": "t", "scene": "chute", "base": {{"aspect_ratio": 1.0,
            "particle_length_m": 1.0, "particle_density_kg_per_m3": 1.909859317102744,
            "box_x_lengths": 5.0, "box_y_lengths": 5.0, "bed_height_lengths": 6.0,
            "inclination_deg": 24.0, "initial_state": "bagnold"{extra}}},
            "run": {{"precision": "f64"}}}}"#
        );
        let c = CampaignFile::parse_str(&text, "t.json").unwrap();
        expand(&c, "t.json").unwrap().get(0)
    }

    fn section(text: &str, head: &str, next: Option<&str>) -> Vec<Vec<f64>> {
        let rest = text.split(head).nth(1).unwrap();
        let body = next.map_or(rest, |n| rest.split(n).next().unwrap());
        body.lines()
            .filter(|l| !l.trim().is_empty())
            .map(|l| l.split_whitespace().map(|x| x.parse().unwrap()).collect())
            .collect()
    }

    /// The data file reads back to the state the job starts from (count, types, positions,
    /// velocities, masses), and the input's constants to the job's law, dt and gravity.
    #[test]
    fn chute_scene_round_trips() {
        let spec = job(r#", "tangential_restitution": 1.0"#);
        let scene = ChuteScene::new(spec.chute().clone()).unwrap();
        let state = scene.start_state(spec.seed());
        let run = ChuteRun::of(&spec);
        let dir = std::env::temp_dir().join(format!("sweep-lammps-chute-{}", std::process::id()));
        let input = export(&spec, run, &dir).unwrap();
        let data = std::fs::read_to_string(dir.join("data.chute")).unwrap();
        let text = std::fs::read_to_string(&input).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        assert!(data.contains(&format!("{} atoms", state.len())));
        let atoms = section(&data, "Atoms # sphere", Some("Velocities"));
        let vels = section(&data, "Velocities", None);
        assert_eq!((atoms.len(), vels.len()), (state.len(), state.len()));
        let m = scene.p.particle_mass();
        for (i, (a, v)) in atoms.iter().zip(&vels).enumerate() {
            assert_eq!((a[0], v[0]), ((i + 1) as f64, (i + 1) as f64));
            let fixed = state.inv_mass[i] == 0.0;
            assert_eq!(a[1], if fixed { 2.0 } else { 1.0 });
            assert_eq!(a[2], 2.0 * state.radius[i]);
            assert_eq!(&a[4..7], &state.position_f64(i)[..]);
            assert_eq!(&v[1..4], &state.vel[i].to_f64()[..]);
            let mass = a[3] * std::f64::consts::PI / 6.0 * a[2].powi(3);
            let want = if fixed {
                m / (std::f64::consts::SQRT_2 - 1.0)
            } else {
                m
            };
            assert!((mass / want - 1.0).abs() < 1e-12, "{i}: {mass} vs {want}");
        }
        assert!(vels.iter().any(|v| v[1] > 0.1), "the warm start moves");
        // Constants: Kn Kt γn γt μ dampflag of the pairs give sweep's contact time (same e_n).
        let pair: Vec<f64> = text
            .lines()
            .find_map(|l| l.strip_prefix("pair_style gran/hooke/history "))
            .unwrap()
            .split_whitespace()
            .map(|x| x.parse().unwrap())
            .collect();
        let law = scene.p.law();
        let tc = contact_time(
            &law,
            ContactPair {
                r_eff: 0.25,
                m_eff: 0.5 * m,
            },
            1.0,
        );
        let lammps_tc = std::f64::consts::PI / (pair[0] / (0.5 * m) - pair[2].powi(2) / 4.0).sqrt();
        assert!((lammps_tc / tc - 1.0).abs() < 1e-12);
        assert_eq!(pair[1], 2.0 / 7.0 * pair[0]);
        assert_eq!((pair[3], pair[4], pair[5]), (0.0, 0.5, 0.0));
        // Against the base: LAMMPS's γ m/√2 is sweep's 2|β|√(k m).
        let sweep_base = 2.0 * beta(0.88).abs() * (pair[0] * m).sqrt();
        assert!((pair[2] * m / std::f64::consts::SQRT_2 / sweep_base - 1.0).abs() < 1e-12);
        let a = 24f64.to_radians();
        for line in [
            format!("timestep {:e}", scene.dt),
            format!(
                "fix gravity mobile gravity 1e0 vector {:e} 0e0 {:e}",
                a.sin(),
                -a.cos()
            ),
            "boundary p p fm".into(),
            "zplane -5e-1 NULL".into(),
            format!("run {}", (run.time_s / scene.dt).round()),
        ] {
            assert!(text.contains(&line), "{line:?} missing from\n{text}");
        }
    }

    #[test]
    fn rods_are_refused() {
        let spec = {
            let mut s = job("");
            s.chute.as_mut().unwrap().aspect_ratio = 2.0;
            s
        };
        let dir = std::env::temp_dir().join("sweep-lammps-rods-never-written");
        assert!(export(&spec, ChuteRun::of(&spec), &dir).is_err());
        assert!(!dir.exists());
    }
}
