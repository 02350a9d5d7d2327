//! A warm start for the chute: instead of a loose gas poured from rest, which near the stopping
//! angle takes hundreds of time units to become a steady flow (issue 24), a dense bed already
//! moving with Bagnold's profile
//!
//!   V_x(z) = u_s (1 − (1 − z/h)^{3/2}),  u_s = 2/3 (I/d) √(φ g cos α) h^{3/2},
//!
//! which is what a constant inertial number I = γ̇ d / √(P/ρ_p) gives under the lithostatic
//! pressure P = φ ρ_p g cos α (h − z) (z from the base spheres' centres, h the bed's top).
//! `warm_surface_velocity_m_per_s` sets u_s directly instead.
//!
//! The bed (`dense_bed.rs`) is a random packing at `flowing_solid_fraction` between the base
//! spheres' tops and the height that fraction gives, relaxed until no two particles overlap by
//! more than `WARM_OVERLAP_D` (rods lie along the flow, x); a lattice would start a crystal that
//! slides as a plug. Spin starts at zero.

use super::chute::ChuteParams;
pub use super::chute::InitialState;
use super::chute_scene::ChuteScene;
use super::dense_bed::DenseBed;
use super::silo::FieldError;
use crate::engine::State;

/// Rotation taking the body axis (z) to the flow direction (x): a quarter turn about y.
const ALONG_X: [f64; 4] = [
    0.0,
    std::f64::consts::FRAC_1_SQRT_2,
    0.0,
    std::f64::consts::FRAC_1_SQRT_2,
];

impl ChuteParams {
    /// Problems with the warm-start parameters, each naming its field.
    pub(super) fn warm_start_problems(&self) -> Vec<FieldError> {
        let mut e = Vec::new();
        let i = self.warm_inertial_number;
        if !(i > 0.0 && i <= 1.0) {
            e.push(FieldError {
                field: "warm_inertial_number".into(),
                message: format!(
                    "expected an inertial number 0 < I ≤ 1 (dense flows: 0.01–0.5), got {i}"
                ),
            });
        }
        if let Some(u) = self.warm_surface_velocity_m_per_s {
            if !(u >= 0.0 && u.is_finite()) {
                e.push(FieldError {
                    field: "warm_surface_velocity_m_per_s".into(),
                    message: format!("expected a surface velocity ≥ 0 m/s or null, got {u}"),
                });
            }
        }
        e
    }
}

/// The dense bed of the warm start, before velocities.
#[derive(Clone, Debug)]
pub struct WarmBed {
    /// Particle centres (m).
    pub pos: Vec<[f64; 3]>,
    /// Solid fraction (the target, `flowing_solid_fraction`).
    pub solid_fraction: f64,
    /// The bed's top, h (m, from the base spheres' centres).
    pub top_m: f64,
    /// The largest overlap between two of its particles (m), at most `WARM_OVERLAP_D` d unless
    /// the target solid fraction is beyond what relaxation reaches.
    pub max_overlap_m: f64,
}

/// Largest overlap the warm bed starts with, in particle diameters: below the overlaps of a bed
/// resting under its own weight at k_n = 2·10⁵ m g / d (about 10⁻⁴ d at 20 d depth).
pub const WARM_OVERLAP_D: f64 = 1e-4;

/// The warm start's dense bed for the job's parameters above the base spheres' tops `z_floor`
/// (deterministic for a seed).
pub fn warm_bed(p: &ChuteParams, z_floor: f64, seed: u64) -> WarmBed {
    let shape = p.shape();
    let d = 2.0 * shape.radius;
    let (lx, ly) = p.box_size();
    let n = p.count();
    let height = n as f64 * shape.volume() / (lx * ly * p.flowing_solid_fraction);
    let bed = DenseBed {
        count: n,
        radius: shape.radius,
        half_length: shape.half_length,
        lx,
        ly,
        z_lo: z_floor + shape.radius,
        z_hi: z_floor + height - shape.radius,
    };
    let packed = bed.pack(WARM_OVERLAP_D * d, seed ^ 0x5EED_BA6E_0001);
    WarmBed {
        pos: packed.pos,
        solid_fraction: p.flowing_solid_fraction,
        top_m: z_floor + height,
        max_overlap_m: packed.max_overlap,
    }
}

/// Bagnold's profile with surface velocity `u_s` on a bed of top `h`: u_s (1 − (1 − z/h)^{3/2})
/// for 0 ≤ z ≤ h (0 below, u_s above).
pub fn bagnold_velocity(z: f64, h: f64, u_s: f64) -> f64 {
    let s = (1.0 - z / h).clamp(0.0, 1.0);
    u_s * (1.0 - s * s.sqrt())
}

impl ChuteScene {
    /// The state a job starts from: the poured gas (`initial_state`) or the warm start.
    pub fn start_state(&self, seed: u64) -> State<f64> {
        match self.p.initial_state {
            InitialState::Pour => self.initial_state(seed),
            InitialState::Bagnold => self.bagnold_state(seed),
        }
    }

    /// Surface velocity u_s of the Bagnold guess on a bed of solid fraction `phi` and top `h`.
    pub fn bagnold_surface_velocity(&self, phi: f64, h: f64) -> f64 {
        let p = &self.p;
        p.warm_surface_velocity_m_per_s.unwrap_or_else(|| {
            let d = 2.0 * p.shape().radius;
            let cos_a = p.inclination_deg.to_radians().cos();
            2.0 / 3.0 * p.warm_inertial_number / d
                * (phi * p.gravity_m_per_s2 * cos_a).sqrt()
                * h.powf(1.5)
        })
    }

    /// The base and the warm start's dense bed moving with the Bagnold profile (ids as in
    /// `initial_state`: the base first).
    pub fn bagnold_state(&self, seed: u64) -> State<f64> {
        let p = &self.p;
        let mut s = self.base_state(seed);
        let bed = warm_bed(p, self.base_radius(), seed);
        let u_s = self.bagnold_surface_velocity(bed.solid_fraction, bed.top_m);
        let shape = p.shape();
        let rho = p.particle_density_kg_per_m3;
        let n0 = s.len() as u32;
        for (k, r) in bed.pos.iter().enumerate() {
            let v = [bagnold_velocity(r[2], bed.top_m, u_s), 0.0, 0.0];
            let id = n0 + k as u32;
            if p.spheres() {
                s.push_sphere(id, *r, v, shape.radius, rho, false);
            } else {
                s.push_spherocylinder(id, *r, v, ALONG_X, shape, rho, false);
            }
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sphere chute of issue 24 in d = m = g = 1 units.
    fn spheres() -> ChuteParams {
        ChuteParams {
            aspect_ratio: 1.0,
            particle_length_m: 1.0,
            particle_density_kg_per_m3: 6.0 / std::f64::consts::PI,
            box_x_lengths: 10.0,
            box_y_lengths: 10.0,
            bed_height_lengths: 20.0,
            inclination_deg: 24.0,
            initial_state: InitialState::Bagnold,
            ..ChuteParams::default()
        }
    }

    #[test]
    fn bad_warm_values_are_named() {
        let p = ChuteParams {
            warm_inertial_number: -1.0,
            warm_surface_velocity_m_per_s: Some(f64::NAN),
            ..spheres()
        };
        let e = p.validate();
        assert!(e.iter().any(|e| e.field == "warm_inertial_number"));
        assert!(e.iter().any(|e| e.field == "warm_surface_velocity_m_per_s"));
    }

    /// The defaults stay out of the serialised parameters (older jobs keep their hashes); a
    /// warm start is in them.
    #[test]
    fn defaults_are_left_out_of_the_parameters() {
        let text = serde_json::to_string(&ChuteParams::default()).unwrap();
        assert!(
            !text.contains("initial_state") && !text.contains("warm_"),
            "{text}"
        );
        let text = serde_json::to_string(&spheres()).unwrap();
        assert!(text.contains("\"initial_state\":\"bagnold\""), "{text}");
        let back: ChuteParams = serde_json::from_str(&text).unwrap();
        assert_eq!(back, spheres());
    }

    /// Every flowing particle of the warm bed: no overlap with another (minimum image) or the
    /// base beyond `WARM_OVERLAP_D` d, V_x on Bagnold's curve, the bed's φ the target one and
    /// not layered (no 1 d bin of the bulk denser than 0.7: a lattice's layers would be).
    #[test]
    fn warm_spheres_have_the_profile_and_no_overlap() {
        let sc = ChuteScene::new(spheres()).unwrap();
        let s = sc.start_state(3);
        let p = &sc.p;
        let (lx, ly) = p.box_size();
        let bed = warm_bed(p, sc.base_radius(), 3);
        assert!(
            (bed.solid_fraction - p.flowing_solid_fraction).abs() < 0.01,
            "φ = {}",
            bed.solid_fraction
        );
        let u_s = sc.bagnold_surface_velocity(bed.solid_fraction, bed.top_m);
        let mut worst: f64 = 0.0;
        let mobile: Vec<usize> = (0..s.len()).filter(|&i| s.inv_mass[i] > 0.0).collect();
        assert_eq!(mobile.len(), p.count());
        for i in 0..s.len() {
            for j in (i + 1)..s.len() {
                if s.inv_mass[i] == 0.0 && s.inv_mass[j] == 0.0 {
                    continue;
                }
                let (a, b) = (s.pos[i].to_f64(), s.pos[j].to_f64());
                let mut dx = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
                dx[0] -= lx * (dx[0] / lx).round();
                dx[1] -= ly * (dx[1] / ly).round();
                let dist = (dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2]).sqrt();
                worst = worst.max(s.radius[i] + s.radius[j] - dist);
            }
        }
        assert!(worst <= WARM_OVERLAP_D + 1e-12, "largest overlap {worst} d");
        let mut bins = [0usize; 40];
        for &i in &mobile {
            bins[s.pos[i].to_f64()[2].floor() as usize] += 1;
        }
        let v = std::f64::consts::PI / 6.0;
        let h = bed.top_m;
        let bulk: Vec<f64> = (3..(h as usize - 3))
            .map(|k| bins[k] as f64 * v / (lx * ly))
            .collect();
        let mean = bulk.iter().sum::<f64>() / bulk.len() as f64;
        assert!((mean - 0.55).abs() < 0.03, "bulk φ {mean}");
        assert!(bulk.iter().all(|&f| f < 0.7), "layered: {bulk:?}");
        for &i in &mobile {
            let (r, v) = (s.pos[i].to_f64(), s.vel[i].to_f64());
            let expected = u_s * (1.0 - (1.0 - r[2] / bed.top_m).max(0.0).powf(1.5));
            assert!((v[0] - expected).abs() < 1e-12 && v[1] == 0.0 && v[2] == 0.0);
        }
        // Bagnold's amplitude: 2/3 I √(φ g cos α) h^{3/2} with d = g = 1.
        let cos_a = 24f64.to_radians().cos();
        let want = 2.0 / 3.0 * 0.1 * (bed.solid_fraction * cos_a).sqrt() * bed.top_m.powf(1.5);
        assert!((u_s - want).abs() < 1e-12);
        assert!(bed.top_m > 18.0 && bed.top_m < 24.0, "h = {}", bed.top_m);
    }

    /// Rods lie along the flow, their segments at least (1 − `WARM_OVERLAP_D`) d apart.
    #[test]
    fn warm_rods_lie_along_the_flow_without_overlap() {
        let p = ChuteParams {
            aspect_ratio: 2.0,
            box_x_lengths: 6.0,
            box_y_lengths: 6.0,
            bed_height_lengths: 6.0,
            initial_state: InitialState::Bagnold,
            warm_surface_velocity_m_per_s: Some(0.5),
            ..ChuteParams::default()
        };
        let sc = ChuteScene::new(p).unwrap();
        let s = sc.start_state(1);
        let shape = sc.p.shape();
        let (lx, ly) = sc.p.box_size();
        let mobile: Vec<usize> = (0..s.len()).filter(|&i| s.inv_mass[i] > 0.0).collect();
        for &i in &mobile {
            let a = s.axis(i).to_f64();
            assert!((a[0].abs() - 1.0).abs() < 1e-12, "axis {a:?}");
        }
        let h = shape.half_length;
        for (k, &i) in mobile.iter().enumerate() {
            for &j in &mobile[k + 1..] {
                let (a, b) = (s.pos[i].to_f64(), s.pos[j].to_f64());
                let mut d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
                d[0] -= lx * (d[0] / lx).round();
                d[1] -= ly * (d[1] / ly).round();
                // Parallel segments along x: their distance.
                let along = (d[0].abs() - 2.0 * h).max(0.0);
                let dist = (along * along + d[1] * d[1] + d[2] * d[2]).sqrt();
                let bound = (1.0 - WARM_OVERLAP_D) * 2.0 * shape.radius - 1e-12;
                assert!(dist >= bound, "{i} {j}: {dist}");
            }
        }
        let top = mobile
            .iter()
            .map(|&i| s.vel[i].to_f64()[0])
            .fold(0.0, f64::max);
        assert!(top <= 0.5 + 1e-12 && top > 0.3, "fastest {top}");
    }
}
