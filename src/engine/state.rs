//! Particle state as structure of arrays, in the run's precision. Holds what a checkpoint must
//! keep to continue a run exactly: kinematics, per-particle constants, forces of the last step
//! (velocity Verlet's first half-kick needs them) and the contact-history table. Scratch buffers
//! (neighbour lists, cell grid) live in the backend, not here.

use super::history::History;
use super::periodic::Periodic;
use super::position::{separation, split_v3, to_f64_v3};
use super::real::{Real, V3};
use super::shape::{angular_momentum, angular_velocity, Quat, Spherocylinder};

/// Particles of one run. Arrays that an effect does not need are empty (a sphere run without
/// rotation has empty `omega` and `torque`).
#[derive(Clone, Debug, PartialEq)]
pub struct State<R: Real> {
    /// Stable particle identity (survives sorting and removal); contact history is keyed by it.
    pub id: Vec<u32>,
    /// Positions, or with `Real::SPLIT_POSITIONS` their nearest `R` (`position.rs`).
    pub pos: Vec<V3<R>>,
    /// With `Real::SPLIT_POSITIONS`, the rest of each position (|lo| ≤ half the spacing of `R`
    /// at `pos`); otherwise empty. A state without it (from the GPU) has zero rests.
    pub pos_lo: Vec<V3<R>>,
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
    /// Whether particles have orientations (spherocylinders). Then `omega` is the lab angular
    /// velocity derived from `ang_mom`, and the four arrays below exist; otherwise they are empty
    /// and no orientation code runs.
    pub oriented: bool,
    /// Orientation, body → lab; the body z axis is the particle's axis.
    pub orientation: Vec<Quat<R>>,
    /// Angular momentum in the lab frame (kg m²/s): the integrated rotational variable.
    pub ang_mom: Vec<V3<R>>,
    /// Inverse principal moments (body frame, 1/(kg m²)); zero for fixed particles.
    pub inv_inertia_body: Vec<V3<R>>,
    /// Half the axis segment l/2 (m); 0 for spheres (the rough base).
    pub half_length: Vec<R>,
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
            oriented: false,
            orientation: Vec::new(),
            ang_mom: Vec::new(),
            inv_inertia_body: Vec::new(),
            half_length: Vec::new(),
            id: Vec::new(),
            pos: Vec::new(),
            pos_lo: Vec::new(),
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

    /// An empty state of oriented particles (spherocylinders; spheres among them have l = 0).
    /// Rotation is always on.
    pub fn new_oriented(history_slots: usize) -> Self {
        let mut s = Self::new(true, history_slots);
        s.oriented = true;
        s
    }

    pub fn len(&self) -> usize {
        self.pos.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }

    /// Appends a position, split where `R` splits positions.
    fn push_position(&mut self, x: [f64; 3]) {
        let (hi, lo) = split_v3(x);
        self.pos.push(hi);
        if R::SPLIT_POSITIONS {
            self.pos_lo.resize(self.pos.len() - 1, V3::zero());
            self.pos_lo.push(lo);
        }
    }

    /// Position i in f64 (hi + lo for a split position).
    pub fn position_f64(&self, i: usize) -> [f64; 3] {
        match self.pos_lo.get(i) {
            Some(&lo) if R::SPLIT_POSITIONS => to_f64_v3(self.pos[i], lo),
            _ => self.pos[i].to_f64(),
        }
    }

    /// The rest of particle i's split position (zero where positions are not split).
    #[inline(always)]
    pub fn lo(&self, i: usize) -> V3<R> {
        self.pos_lo.get(i).copied().unwrap_or_default()
    }

    /// The separation from particle a to particle b, c_b − c_a (minimum image), as precise as
    /// its own size allows where positions are split.
    #[inline(always)]
    pub fn separation(&self, periodic: &Periodic<R>, a: usize, b: usize) -> V3<R> {
        periodic
            .image()
            .fold(separation(self.pos[a], self.lo(a), self.pos[b], self.lo(b)))
    }

    /// Each split position as `split` gives it back from f64 (what a download and an upload
    /// make of it); nothing where positions are not split.
    pub fn canonical_positions(&mut self) {
        if !R::SPLIT_POSITIONS {
            return;
        }
        self.pos_lo.resize(self.pos.len(), V3::zero());
        for (hi, lo) in self.pos.iter_mut().zip(self.pos_lo.iter_mut()) {
            (*hi, *lo) = split_v3(to_f64_v3(*hi, *lo));
        }
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
        if self.oriented {
            let shape = Spherocylinder::sphere(radius);
            return self.push_spherocylinder(id, pos, vel, [0.0, 0.0, 0.0, 1.0], shape, rho, fixed);
        }
        let m = rho * 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3);
        self.id.push(id);
        self.push_position(pos);
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

    /// Adds a spherocylinder of density `rho` with orientation `q` ([x, y, z, w], body → lab) to
    /// an oriented state, at rest in rotation. A `fixed` particle never moves or turns.
    #[allow(clippy::too_many_arguments)]
    pub fn push_spherocylinder(
        &mut self,
        id: u32,
        pos: [f64; 3],
        vel: [f64; 3],
        q: [f64; 4],
        shape: Spherocylinder<f64>,
        rho: f64,
        fixed: bool,
    ) {
        assert!(self.oriented, "push_spherocylinder needs an oriented state");
        let m = shape.mass(rho);
        let inertia = shape.inertia(rho);
        self.id.push(id);
        self.push_position(pos);
        self.vel.push(V3::from_f64(vel));
        self.force.push(V3::zero());
        self.radius.push(R::from_f64(shape.radius));
        self.mass.push(R::from_f64(m));
        self.inv_mass
            .push(R::from_f64(if fixed { 0.0 } else { 1.0 / m }));
        self.omega.push(V3::zero());
        self.torque.push(V3::zero());
        let inv = if fixed {
            [0.0; 3]
        } else {
            [1.0 / inertia.x, 1.0 / inertia.y, 1.0 / inertia.z]
        };
        self.inv_inertia_body.push(V3::from_f64(inv));
        self.orientation.push(Quat::from_f64(q).normalize());
        self.ang_mom.push(V3::zero());
        self.half_length.push(R::from_f64(shape.half_length));
        self.history.push_particle();
    }

    /// Sets particle k's lab angular velocity (oriented states: through L = R I Rᵀ ω).
    pub fn set_angular_velocity(&mut self, k: usize, omega: [f64; 3]) {
        let w = V3::from_f64(omega);
        if self.oriented {
            let inv = self.inv_inertia_body[k];
            let recip = |x: R| {
                if x > R::zero() {
                    R::one() / x
                } else {
                    R::zero()
                }
            };
            let inertia = V3::new(recip(inv.x), recip(inv.y), recip(inv.z));
            self.ang_mom[k] = angular_momentum(self.orientation[k], inertia, w);
            self.omega[k] = angular_velocity(self.orientation[k], inv, self.ang_mom[k]);
        } else {
            self.omega[k] = w;
        }
    }

    /// The unit axis (body z in the lab frame) of particle k; +z for unoriented states.
    pub fn axis(&self, k: usize) -> V3<R> {
        if self.oriented {
            self.orientation[k].axis_z()
        } else {
            V3::new(R::zero(), R::zero(), R::one())
        }
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
        take(&mut self.pos_lo, order);
        take(&mut self.vel, order);
        take(&mut self.force, order);
        take(&mut self.radius, order);
        take(&mut self.mass, order);
        take(&mut self.inv_mass, order);
        take(&mut self.omega, order);
        take(&mut self.torque, order);
        take(&mut self.inv_inertia, order);
        take(&mut self.orientation, order);
        take(&mut self.ang_mom, order);
        take(&mut self.inv_inertia_body, order);
        take(&mut self.half_length, order);
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
            if self.oriented {
                // ½ ω·L with ω = R I⁻¹ Rᵀ L.
                e += 0.5 * self.omega[i].dot(self.ang_mom[i]).to_f64();
            } else if self.rotation {
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
        let (pos, pos_lo): (Vec<V3<S>>, Vec<V3<S>>) = (0..self.len())
            .map(|i| split_v3(self.position_f64(i)))
            .unzip();
        State {
            id: self.id.clone(),
            pos,
            pos_lo: if S::SPLIT_POSITIONS {
                pos_lo
            } else {
                Vec::new()
            },
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
            oriented: self.oriented,
            orientation: self
                .orientation
                .iter()
                .map(|q| Quat::from_f64(q.to_f64()))
                .collect(),
            ang_mom: cv(&self.ang_mom),
            inv_inertia_body: cv(&self.inv_inertia_body),
            half_length: c(&self.half_length),
            time: self.time,
            step: self.step,
        }
    }
}
