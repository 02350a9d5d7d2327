//! Re-insertion (`reinsert: true`): the particles the sink removed are put back above the bed,
//! so a small silo discharges at a steady rate for longer than its packing would allow.
//!
//! The floor they are dropped from is fixed when the orifice opens (the settled bed's top plus
//! a diameter). Measured on the bed at every chunk, the top of the highest particles counts the
//! re-inserted ones still falling: at a large orifice enough of them are in the air to lift the
//! floor chunk by chunk up to the lid, and particles that found no place under it were lost.
//! Each chunk's particles are spread over levels of many particles each, and a particle that
//! finds no free place is an error, never a silent loss.

use rand::{Rng, SeedableRng};

use crate::engine::{SinkEvent, State};
use crate::scene::SiloScene;

/// Random places tried on one level before the next level up.
const TRIES_PER_LEVEL: usize = 50;
/// Levels tried (from a particle's own, upwards and round) before giving up.
const LEVELS_TRIED: usize = 20;
/// Vertical spacing of the levels and the margin of a place, in radii.
const LEVEL_SPACING_RADII: f64 = 2.2;
/// The share of a level's area its particles are planned to cover: random places find free
/// spots quickly well below random sequential addition's jamming coverage (0.547).
const LEVEL_COVERAGE: f64 = 0.2;

/// Some removed particles found no free place under the lid.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error(
    "re-insertion found no free place for {lost} of {removed} removed particle(s) between the \
     floor z = {floor_m:.4} m and the lid z = {lid_m:.4} m: raise cylinder_height_m, or shorten \
     observers.discharge.sample_interval_s (fewer particles per chunk)"
)]
pub struct RefillError {
    pub lost: usize,
    pub removed: usize,
    pub floor_m: f64,
    pub lid_m: f64,
}

impl SiloScene {
    /// The floor re-inserted particles are dropped from: the settled bed's top when the
    /// orifice opens, plus a diameter. Kept for the whole discharge (module comment).
    pub fn refill_floor(&self, opened: &State<f64>) -> f64 {
        self.bed_height(opened) + self.p.particle_diameter_m
    }

    /// Puts the removed particles back at random free places above `floor_m`, each with its own
    /// id and mass, at rest. Deterministic for a seed. The k-th particle of the chunk starts on
    /// level k / (particles per level) and climbs a level every `TRIES_PER_LEVEL` tries, back to
    /// the lowest past the highest level under the lid.
    ///
    /// # Errors
    /// A particle that found no free place under the lid: the others are placed.
    pub fn reinsert(
        &self,
        s: &mut State<f64>,
        removed: &[SinkEvent],
        floor_m: f64,
        seed: u64,
    ) -> Result<(), RefillError> {
        let p = &self.p;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        // The largest radius spaces the places; each particle keeps its own mass below.
        let r = p.particle_diameter_m * 0.5 * (1.0 + p.diameter_polydispersity);
        let r_place = p.cylinder_radius_m - r * 1.05;
        let per_level = ((LEVEL_COVERAGE * (r_place / r).powi(2)).floor() as usize).max(1);
        let lid = p.cylinder_height_m;
        // Levels whose places lie wholly under the lid (z + r < lid); a particle's tries cycle
        // through them.
        let spacing = LEVEL_SPACING_RADII * r;
        let room = lid - floor_m - 2.0 * r;
        let levels = if room <= 0.0 {
            0
        } else {
            (room / spacing).ceil() as usize
        };
        let mut lost = 0;
        for (k, ev) in removed.iter().enumerate() {
            let radius = (ev.mass_kg
                / (p.particle_density_kg_per_m3 * 4.0 / 3.0 * std::f64::consts::PI))
                .cbrt();
            let mut placed = false;
            let attempts = if levels == 0 {
                0
            } else {
                TRIES_PER_LEVEL * LEVELS_TRIED
            };
            for attempt in 0..attempts {
                let level = (k / per_level + attempt / TRIES_PER_LEVEL) % levels;
                let z = floor_m + r + level as f64 * spacing;
                let rr = r_place * rng.random::<f64>().sqrt();
                let th = rng.random::<f64>() * std::f64::consts::TAU;
                let x = [rr * th.cos(), rr * th.sin(), z];
                let free = s.pos.iter().zip(&s.radius).all(|(q, &rq)| {
                    let d2 = (q.x - x[0]).powi(2) + (q.y - x[1]).powi(2) + (q.z - x[2]).powi(2);
                    d2 > (rq + radius) * (rq + radius) * 1.0001
                });
                if free {
                    s.push_sphere(
                        ev.id,
                        x,
                        [0.0, 0.0, 0.0],
                        radius,
                        p.particle_density_kg_per_m3,
                        false,
                    );
                    placed = true;
                    break;
                }
            }
            lost += usize::from(!placed);
        }
        if lost > 0 {
            return Err(RefillError {
                lost,
                removed: removed.len(),
                floor_m,
                lid_m: lid,
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::SinkEvent;
    use crate::scene::SiloParams;

    fn scene() -> SiloScene {
        SiloScene::new(SiloParams {
            cylinder_radius_m: 0.075,
            cylinder_height_m: 0.25,
            particle_count: 4700,
            orifice_diameter_m: 0.032,
            reinsert: true,
            ..SiloParams::default()
        })
        .unwrap()
    }

    fn removed(n: usize, mass: f64) -> Vec<SinkEvent> {
        (0..n)
            .map(|k| SinkEvent {
                id: 100_000 + k as u32,
                time_s: 0.0,
                mass_kg: mass,
            })
            .collect()
    }

    /// A chunk of a large orifice removes tens of particles: every one goes back, none overlaps
    /// another, all above the floor and under the lid. (The old rule put the k-th on the k-th
    /// level: past about 30 levels under this lid the rest were dropped without a word.)
    #[test]
    fn a_chunk_s_particles_all_go_back_without_overlaps() {
        let sc = scene();
        let mass = sc.p.particle_mass();
        let mut s = State::<f64>::new(true, 0);
        let floor = 0.05;
        sc.reinsert(&mut s, &removed(120, mass), floor, 7).unwrap();
        assert_eq!(s.len(), 120);
        let r = sc.p.particle_diameter_m / 2.0;
        for i in 0..s.len() {
            assert!(s.pos[i].z > floor && s.pos[i].z + r < sc.p.cylinder_height_m);
            for j in 0..i {
                let d = (s.pos[i] - s.pos[j]).norm();
                assert!(d > s.radius[i] + s.radius[j], "{i} and {j} overlap: {d}");
            }
        }
        // The same seed places them the same way.
        let mut again = State::<f64>::new(true, 0);
        sc.reinsert(&mut again, &removed(120, mass), floor, 7)
            .unwrap();
        assert!(s.pos.iter().zip(&again.pos).all(|(a, b)| a == b));
    }

    /// Near the lid a chunk's later particles start over at the lowest level instead of being
    /// lost above the lid: two levels take more than two levels' worth of starts.
    #[test]
    fn near_the_lid_the_levels_are_reused() {
        let sc = scene();
        let r = sc.p.particle_diameter_m / 2.0;
        let floor = sc.p.cylinder_height_m - 2.0 * r - 1.5 * LEVEL_SPACING_RADII * r;
        let mut s = State::<f64>::new(true, 0);
        sc.reinsert(&mut s, &removed(300, sc.p.particle_mass()), floor, 3)
            .unwrap();
        assert_eq!(s.len(), 300);
        assert!(s.pos.iter().all(|q| q.z + r < sc.p.cylinder_height_m));
    }

    /// With no room left under the lid the particles are an error naming how many, not lost.
    #[test]
    fn no_room_under_the_lid_is_an_error() {
        let sc = scene();
        let mut s = State::<f64>::new(true, 0);
        let floor = sc.p.cylinder_height_m - sc.p.particle_diameter_m;
        let err = sc
            .reinsert(&mut s, &removed(3, sc.p.particle_mass()), floor, 1)
            .unwrap_err();
        assert_eq!((err.lost, err.removed), (3, 3));
        assert!(err.to_string().contains("cylinder_height_m"), "{err}");
    }
}
