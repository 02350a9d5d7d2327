//! A bench scene written out for LAMMPS (`sweep bench --lammps DIR`), so that LAMMPS's
//! throughput can be measured on the same bed on the same machine: a data file with every
//! sphere (fixed ones as type 2, frozen) and its velocity, and an input that runs LAMMPS's
//! fastest granular path (`gran/hooke/history`, `gran/hertz/history`) with the scene's
//! constants, walls, gravity, periodic axes, skin and time step.
//!
//! What cannot be the same, and is said in the input's header:
//! - LAMMPS's Hertz damping is m* γ_n √(Rδ) v_n; sweep's (the silo paper's) is
//!   2 √(5/6) |β| √(2 Y* √(Rδ) m*) v_n. γ_n is matched at the overlap where the Hertz force of two
//!   spheres equals one sphere's weight (the scale of a settled bed's overlaps).
//! - The tangential springs of a settled bed are not carried over: LAMMPS starts them at zero.
//! - LAMMPS computes in f64.

pub mod chute;

use std::fmt::Write as _;

use anyhow::Context as _;
use std::path::{Path, PathBuf};

use crate::bench::BenchScene;
use crate::engine::contact::{beta, ContactLaw, NormalModel};
use crate::engine::walls::WallShape;

/// Writes `data.NAME` and `in.NAME` into `dir` for the scene `name` (its state as it stands,
/// settled or not); returns the input's path. `steps` timed steps follow 100 untimed ones, as in
/// `sweep bench`.
///
/// # Errors
/// A scene LAMMPS's granular styles cannot express (oriented particles, rotating walls, an
/// orifice, a tilted plane, unequal particle and wall laws), or a file that cannot be written.
pub fn export(name: &str, sc: &BenchScene, steps: u64, dir: &Path) -> anyhow::Result<PathBuf> {
    let s = &sc.state;
    let c = &sc.config;
    anyhow::ensure!(
        !s.oriented,
        "--lammps: scene {name} has oriented particles; LAMMPS's granular styles take spheres"
    );
    anyhow::ensure!(
        c.particle_law == c.wall_law,
        "--lammps: scene {name} has a wall law unlike its particle law"
    );
    anyhow::ensure!(c.sink_z.is_none(), "--lammps: scene {name} has a sink");
    let file = name.replace('/', "-");
    // Both texts first: a scene that cannot be written leaves no half of it behind.
    let (data_text, input_text) = (data_file(name, sc), input_file(name, &file, sc, steps)?);
    let write = |path: &Path, text: &str| {
        std::fs::write(path, text).with_context(|| format!("--lammps: writing {}", path.display()))
    };
    std::fs::create_dir_all(dir)
        .with_context(|| format!("--lammps: creating {}", dir.display()))?;
    write(&dir.join(format!("data.{file}")), &data_text)?;
    let input = dir.join(format!("in.{file}"));
    write(&input, &input_text)?;
    Ok(input)
}

/// The mass of the heaviest mobile sphere and its radius: the pair the damping is matched for.
fn typical(sc: &BenchScene) -> (f64, f64) {
    let s = &sc.state;
    (0..s.len())
        .filter(|&i| s.inv_mass[i] > 0.0)
        .map(|i| (s.mass[i], s.radius[i]))
        .fold((0.0, 0.0), |a, b| if b.0 > a.0 { b } else { a })
}

/// LAMMPS's `gran/*/history` coefficients (Kn Kt γ_n γ_t μ dampflag) for the law.
fn coefficients(law: &ContactLaw, m: f64, r: f64, g: f64) -> String {
    let (bn, bt) = (
        beta(law.restitution).abs(),
        beta(law.tangential_restitution).abs(),
    );
    // Two equal mobile spheres: m* = m/2, R* = r/2.
    let (ms, rs) = (0.5 * m, 0.5 * r);
    let (kn, kt, gn, gt) = match law.normal {
        // F = k δ + m* γ v with sweep's γ m* = 2|β|√(k m*).
        NormalModel::Linear {
            kn_n_per_m,
            kt_n_per_m,
        } => (
            kn_n_per_m,
            kt_n_per_m,
            2.0 * bn * (kn_n_per_m / ms).sqrt(),
            2.0 * bt * (kt_n_per_m / ms).sqrt(),
        ),
        // LAMMPS: √(R*δ) (K_n δ − m* γ_n v_n); sweep: 4/3 Y* √(R*δ) δ and
        // 2√(5/6)|β| √(S m*) with S = 2 Y* √(R*δ) (S_t = 8 G* √(R*δ)). Equal at δ₀, where
        // 4/3 Y* √(R* δ₀) δ₀ = m g.
        NormalModel::Hertz(el) => {
            let (y, gs) = el.effective();
            let d0 = (m * g / (4.0 / 3.0 * y * rs.sqrt())).powf(2.0 / 3.0);
            let a = (rs * d0).sqrt();
            let c = 2.0 * (5.0f64 / 6.0).sqrt();
            (
                4.0 / 3.0 * y,
                8.0 * gs,
                c * bn * (2.0 * y * a * ms).sqrt() / (ms * a),
                c * bt * (8.0 * gs * a * ms).sqrt() / (ms * a),
            )
        }
    };
    format!("{kn:e} {kt:e} {gn:e} {gt:e} {} 1", law.friction)
}

fn data_file(name: &str, sc: &BenchScene) -> String {
    let s = &sc.state;
    let c = &sc.config;
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for i in 0..s.len() {
        let p = s.pos[i];
        for (a, x) in [p.x, p.y, p.z].into_iter().enumerate() {
            lo[a] = lo[a].min(x - s.radius[i]);
            hi[a] = hi[a].max(x + s.radius[i]);
        }
    }
    for (a, p) in [c.periodic_x, c.periodic_y].into_iter().enumerate() {
        if let Some([l, h]) = p {
            (lo[a], hi[a]) = (l, h);
        }
    }
    let mut out = String::new();
    let _ = writeln!(out, "sweep bench scene {name}, {} spheres\n", s.len());
    let _ = writeln!(out, "{} atoms\n2 atom types\n", s.len());
    for (a, x) in ["x", "y", "z"].iter().enumerate() {
        let _ = writeln!(out, "{:e} {:e} {x}lo {x}hi", lo[a], hi[a]);
    }
    // atom-ID atom-type diameter density x y z
    let _ = writeln!(out, "\nAtoms # sphere\n");
    for i in 0..s.len() {
        let r = s.radius[i];
        let rho = s.mass[i] / (4.0 / 3.0 * std::f64::consts::PI * r * r * r);
        let ty = if s.inv_mass[i] > 0.0 { 1 } else { 2 };
        let p = s.pos[i];
        let _ = writeln!(
            out,
            "{} {ty} {:e} {:e} {:e} {:e} {:e}",
            i + 1,
            2.0 * r,
            rho,
            p.x,
            p.y,
            p.z
        );
    }
    write_velocities(&mut out, s);
    out
}

/// The data file's `Velocities` section (atom-ID vx vy vz wx wy wz), atoms numbered from 1 in
/// state order.
fn write_velocities(out: &mut String, s: &crate::engine::State<f64>) {
    let _ = writeln!(out, "\nVelocities\n");
    for i in 0..s.len() {
        let (v, w) = (s.vel[i], s.omega.get(i).copied().unwrap_or_default());
        let _ = writeln!(
            out,
            "{} {:e} {:e} {:e} {:e} {:e} {:e}",
            i + 1,
            v.x,
            v.y,
            v.z,
            w.x,
            w.y,
            w.z
        );
    }
}

fn input_file(name: &str, file: &str, sc: &BenchScene, steps: u64) -> anyhow::Result<String> {
    let c = &sc.config;
    let (m, r) = typical(sc);
    let g = crate::engine::real::V3::<f64>::from_f64(c.gravity).norm();
    let style = match c.particle_law.normal {
        NormalModel::Linear { .. } => "hooke/history",
        NormalModel::Hertz(_) => "hertz/history",
    };
    let coef = coefficients(&c.particle_law, m, r, g);
    let mut walls = Vec::new();
    for (k, w) in c.walls.iter().enumerate() {
        anyhow::ensure!(
            w.rotation.is_none(),
            "--lammps: scene {name}, wall {k} rotates; not exported"
        );
        let spec = match w.shape {
            WallShape::Plane { point, normal } if normal[0] == 0.0 && normal[1] == 0.0 => {
                if normal[2] > 0.0 {
                    format!("zplane {:e} NULL", point[2])
                } else {
                    format!("zplane NULL {:e}", point[2])
                }
            }
            WallShape::OrificePlate {
                z,
                orifice_radius: 0.0,
                ..
            } => format!("zplane {z:e} NULL"),
            WallShape::Cylinder {
                axis_xy: [0.0, 0.0],
                radius,
                ..
            } => format!("zcylinder {radius:e}"),
            other => anyhow::bail!("--lammps: scene {name}, wall {k} ({other:?}) not exported"),
        };
        walls.push(format!(
            "fix wall{k} mobile wall/gran {style} {coef} {spec}"
        ));
    }
    let bound = |p: Option<[f64; 2]>| if p.is_some() { "p" } else { "f" };
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# sweep bench scene {name}, written by `sweep bench --lammps`.\n\
         # Run: mpirun -np 2 lmp -in in.{file}  (the second run is the timed one: particle-steps/s =\n\
         # mobile spheres x {steps} / its loop time). Its last thermo line (ke, vcm x of the\n\
         # mobile spheres) is comparable with `sweep bench`'s end state.\n\
         # Same spheres, velocities, law constants, walls, gravity, periodic axes, skin and dt.\n\
         # Not the same: Hertz damping matched at one overlap (see sweep's src/lammps.rs), no\n\
         # tangential springs carried over, f64 throughout.\n"
    );
    let _ = writeln!(out, "units si\natom_style sphere\natom_modify map array");
    let _ = writeln!(
        out,
        "boundary {} {} fm",
        bound(c.periodic_x),
        bound(c.periodic_y)
    );
    let _ = writeln!(
        out,
        "newton off\ncomm_modify vel yes\nread_data data.{file}"
    );
    let _ = writeln!(out, "group mobile type 1\ngroup base type 2");
    let _ = writeln!(out, "pair_style gran/{style} {coef}\npair_coeff * *");
    let _ = writeln!(
        out,
        "neighbor {:e} bin\nneigh_modify delay 0 every 1 check yes exclude type 2 2",
        c.skin_m
    );
    let _ = writeln!(out, "timestep {:e}", c.dt_s);
    let gv = c.gravity;
    if g > 0.0 {
        let _ = writeln!(
            out,
            "fix gravity mobile gravity {g:e} vector {:e} {:e} {:e}",
            gv[0] / g,
            gv[1] / g,
            gv[2] / g
        );
    }
    let _ = writeln!(out, "fix move mobile nve/sphere");
    if sc.state.inv_mass.contains(&0.0) {
        let _ = writeln!(out, "fix freeze base freeze");
    }
    for w in walls {
        let _ = writeln!(out, "{w}");
    }
    let _ = writeln!(
        out,
        "variable vcmx equal vcm(mobile,x)\nthermo_style custom step atoms ke v_vcmx\n\
         thermo_modify format float %.6e\nthermo 1000\nrun 100\nrun {steps}"
    );
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::contact::{contact_time, ContactPair, Elasticity};

    fn numbers(coef: &str) -> Vec<f64> {
        coef.split_whitespace()
            .map(|x| x.parse().unwrap())
            .collect()
    }

    /// LAMMPS's Hooke contact with m* γ_n damping lasts π / √(k_n/m* − γ_n²/4): it must be
    /// sweep's contact time (so the same e_n) to 1e-9.
    #[test]
    fn linear_coefficients_give_sweeps_contact_time() {
        let (m, r) = (0.5, 0.05);
        let law = ContactLaw {
            normal: NormalModel::Linear {
                kn_n_per_m: 4.0e6,
                kt_n_per_m: 4.0e6 * 2.0 / 7.0,
            },
            restitution: 0.88,
            tangential_restitution: 0.88,
            friction: 0.5,
        };
        let c = numbers(&coefficients(&law, m, r, 9.81));
        let ms = 0.5 * m;
        let lammps = std::f64::consts::PI / (c[0] / ms - c[2] * c[2] / 4.0).sqrt();
        let sweep = contact_time(
            &law,
            ContactPair {
                r_eff: r / 2.0,
                m_eff: ms,
            },
            1.0,
        );
        assert!((lammps / sweep - 1.0).abs() < 1e-9, "{lammps} vs {sweep}");
        assert_eq!((c[1], c[4], c[5]), (4.0e6 * 2.0 / 7.0, 0.5, 1.0));
    }

    /// Hertz: LAMMPS's normal elastic and damping forces, √(R*δ)(K_n δ, m* γ_n v), equal sweep's
    /// at the matching overlap δ₀ (where the elastic force is one weight) to 1e-9.
    #[test]
    fn hertz_damping_matches_at_the_weight_overlap() {
        let (m, r, g) = (2.7e-4, 0.0029, 9.81);
        let (y, gs) = (3.0e7, 1.0e6);
        let law = ContactLaw {
            normal: NormalModel::Hertz(Elasticity::YoungShear {
                youngs_modulus_pa: y,
                shear_modulus_pa: gs,
            }),
            restitution: 0.9,
            tangential_restitution: 0.9,
            friction: 0.5,
        };
        let c = numbers(&coefficients(&law, m, r, g));
        let (ms, rs) = (0.5 * m, 0.5 * r);
        let d0 = (m * g / (4.0 / 3.0 * y * rs.sqrt())).powf(2.0 / 3.0);
        let a = (rs * d0).sqrt();
        assert!((a * c[0] * d0 / (m * g) - 1.0).abs() < 1e-9);
        let sweep_gamma = 2.0 * (5.0f64 / 6.0).sqrt() * beta(0.9).abs() * (2.0 * y * a * ms).sqrt();
        assert!((a * ms * c[2] / sweep_gamma - 1.0).abs() < 1e-9);
        assert_eq!((c[0], c[1]), (4.0 / 3.0 * y, 8.0 * gs));
    }

    /// Every sphere is written once, with its type (fixed ones 2) and velocity; the input names
    /// the data file, the law, the skin, the step and the walls.
    #[test]
    fn chute_bed_is_written_whole() {
        let sc = crate::bench::scene("chute-bed", 500, 1).unwrap();
        let dir = std::env::temp_dir().join(format!("sweep-lammps-{}", std::process::id()));
        let input = export("chute-bed", &sc, 300, &dir).unwrap();
        let data = std::fs::read_to_string(dir.join("data.chute-bed")).unwrap();
        let text = std::fs::read_to_string(&input).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        let n = sc.state.len();
        assert!(data.contains(&format!("{n} atoms")));
        let atoms: Vec<&str> = data
            .split("Atoms # sphere")
            .nth(1)
            .unwrap()
            .split("Velocities")
            .next()
            .unwrap()
            .lines()
            .filter(|l| !l.trim().is_empty())
            .collect();
        assert_eq!(atoms.len(), n);
        let fixed = atoms
            .iter()
            .filter(|l| l.split(' ').nth(1) == Some("2"))
            .count();
        let expected = sc.state.inv_mass.iter().filter(|&&x| x == 0.0).count();
        assert_eq!(fixed, expected);
        for line in [
            "read_data data.chute-bed",
            "pair_style gran/hooke/history",
            "fix freeze base freeze",
            "boundary p p fm",
            "run 300",
        ] {
            assert!(text.contains(line), "{line:?} missing from\n{text}");
        }
        assert!(text.contains(&format!("timestep {:e}", sc.config.dt_s)));
        assert!(text.contains("zplane -6.25e-2 NULL"));
    }
}
