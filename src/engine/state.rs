//! Particle state as structure of arrays, in the run's precision. Holds what a checkpoint must
//! keep to continue a run exactly: kinematics, per-particle constants, forces of the last step
//! (velocity Verlet's first half-kick needs them) and the contact-history table. Scratch buffers
//! (neighbour lists, cell grid) live in the backend, not here.

use super::history::History;
use super::real::{Real, V3};

/// Particles of one run. Arrays that an effect does not need are empty (a sphere run without
/// rotation has empty `omega` and `torque`).
#[derive(Clone, Debug, PartialEq)]
pub struct State<R: Real> {
    /// Stable particle identity (survives sorting and removal); contact history is keyed by it.
    pub id: Vec<u32>,
    pub pos: Vec<V3<R>>,
    pub vel: Vec<V3<R>>,
    /// Force of the last evaluation (N), used by the first half-kick of velocity Verlet.
    pub force: Vec<V3<R>>,
    pub radius: Vec<R>,
    pub mass: Vec<R>,
    /// 0 for fixed particles (rough base), 1/m otherwise.
    pub inv_mass: Vec<R>,
    /// Angular velocity (rad/s); empty when rotation is off.
    pub omega: Vec<V3<R>>,
    /// Torque of the last evaluation (N m); empty when rotation is off.
    pub torque: Vec<V3<R>>,
    /// 1/I for spheres (I = 2/5 m r²), 0 for fixed particles; empty when rotation is off.
    pub inv_inertia: Vec<R>,
    /// Tangential springs, per particle, keyed by partner id; empty when friction is off.
    pub history: History<R>,
    /// Whether angular velocities exist and are integrated.
    pub rotation: bool,
    /// Simulated time (s) and step count.
    pub time: f64,
    pub step: u64,
}

impl<R: Real> State<R> {
    /// An empty state; `rotation` and `history_slots` (0 = no tangential history) set which
    /// optional arrays exist.
    pub fn new(rotation: bool, history_slots: usize) -> Self {
        Self {
            rotation,
            id: Vec::new(),
            pos: Vec::new(),
            vel: Vec::new(),
            force: Vec::new(),
            radius: Vec::new(),
            mass: Vec::new(),
            inv_mass: Vec::new(),
            omega: Vec::new(),
            torque: Vec::new(),
            inv_inertia: Vec::new(),
            history: History::new(history_slots),
            time: 0.0,
            step: 0,
        }
    }

    pub fn len(&self) -> usize {
        self.pos.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }

    /// Adds a sphere of density `rho`. A `fixed` particle never moves (rough base).
    #[allow(clippy::too_many_arguments)]
    pub fn push_sphere(
        &mut self,
        id: u32,
        pos: [f64; 3],
        vel: [f64; 3],
        radius: f64,
        rho: f64,
        fixed: bool,
    ) {
        let m = rho * 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3);
        self.id.push(id);
        self.pos.push(V3::from_f64(pos));
        self.vel.push(V3::from_f64(vel));
        self.force.push(V3::zero());
        self.radius.push(R::from_f64(radius));
        self.mass.push(R::from_f64(m));
        self.inv_mass
            .push(R::from_f64(if fixed { 0.0 } else { 1.0 / m }));
        if self.rotation {
            self.omega.push(V3::zero());
            self.torque.push(V3::zero());
            let inertia = 0.4 * m * radius * radius;
            self.inv_inertia
                .push(R::from_f64(if fixed { 0.0 } else { 1.0 / inertia }));
        }
        self.history.push_particle();
    }

    /// Reorders every array by `order` (new index k takes old index `order[k]`).
    pub fn permute(&mut self, order: &[u32]) {
        fn take<T: Copy>(v: &mut Vec<T>, order: &[u32]) {
            if v.is_empty() {
                return;
            }
            let out: Vec<T> = order.iter().map(|&o| v[o as usize]).collect();
            *v = out;
        }
        take(&mut self.id, order);
        take(&mut self.pos, order);
        take(&mut self.vel, order);
        take(&mut self.force, order);
        take(&mut self.radius, order);
        take(&mut self.mass, order);
        take(&mut self.inv_mass, order);
        take(&mut self.omega, order);
        take(&mut self.torque, order);
        take(&mut self.inv_inertia, order);
        self.history.permute(order);
    }

    /// Keeps only particles whose `keep` flag is set, preserving order (deterministic).
    pub fn retain(&mut self, keep: &[bool]) {
        let order: Vec<u32> = (0..self.len() as u32)
            .filter(|&i| keep[i as usize])
            .collect();
        self.permute(&order);
    }

    /// Total kinetic energy, translational plus rotational (J), in f64.
    pub fn kinetic_energy(&self) -> f64 {
        let mut e = 0.0;
        for i in 0..self.len() {
            if self.inv_mass[i].to_f64() == 0.0 {
                continue;
            }
            e += 0.5 * self.mass[i].to_f64() * self.vel[i].norm2().to_f64();
            if self.rotation {
                let inv_i = self.inv_inertia[i].to_f64();
                if inv_i > 0.0 {
                    e += 0.5 / inv_i * self.omega[i].norm2().to_f64();
                }
            }
        }
        e
    }

    /// Total linear momentum of the mobile particles (kg m/s), in f64.
    pub fn momentum(&self) -> [f64; 3] {
        let mut p = [0.0; 3];
        for i in 0..self.len() {
            if self.inv_mass[i].to_f64() == 0.0 {
                continue;
            }
            let v = self.vel[i].to_f64();
            let m = self.mass[i].to_f64();
            for k in 0..3 {
                p[k] += m * v[k];
            }
        }
        p
    }

    /// Converts to another precision (checkpoints move between f64, f32 and the GPU).
    pub fn convert<S: Real>(&self) -> State<S> {
        fn c<A: Real, B: Real>(v: &[A]) -> Vec<B> {
            v.iter().map(|x| B::from_f64(x.to_f64())).collect()
        }
        fn cv<A: Real, B: Real>(v: &[V3<A>]) -> Vec<V3<B>> {
            v.iter().map(|x| V3::from_f64(x.to_f64())).collect()
        }
        State {
            id: self.id.clone(),
            pos: cv(&self.pos),
            vel: cv(&self.vel),
            force: cv(&self.force),
            radius: c(&self.radius),
            mass: c(&self.mass),
            inv_mass: c(&self.inv_mass),
            omega: cv(&self.omega),
            torque: cv(&self.torque),
            inv_inertia: c(&self.inv_inertia),
            history: self.history.convert(),
            rotation: self.rotation,
            time: self.time,
            step: self.step,
        }
    }
}
