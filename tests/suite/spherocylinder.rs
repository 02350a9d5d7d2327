//! Spherocylinder geometry and rigid-body rotation (issue 6), tested as pure functions: no
//! engine run. Each test's `///` header states its law, its tolerance and what a failure means;
//! in short:
//! - segment–segment closest points against brute-force sampling on 10⁵ random pairs (general,
//!   near-parallel with θ < 10⁻⁶ rad, end-to-end, crossed, T; zero and tiny lengths), f64 and f32;
//! - the analytic inertia tensor against a grid integral within 0.5 %, ξ = 1, 1.01, 1.5, 3;
//! - a torque-free asymmetric top over 10⁵ steps: energy and lab angular momentum bounded with
//!   no drift, |q| = 1 within 10⁻¹², the trajectory second-order close to RK4 on Euler's
//!   equations;
//! - a symmetric top's body-frame precession at (I3 − I1)/I1 ω3 within 0.5 %;
//! - work–energy under a torque;
//! - contact normal, overlap and point in the special configurations, and ξ = 1.00 equal bit for
//!   bit to the engine's sphere–sphere and sphere–plane contacts.
//!
//! Units are arbitrary (segments of length O(1)) except where a test says otherwise.

use crate::common::Noise;

use sweep::engine::shape::{
    angular_momentum, angular_velocity, closest_points, contact_plane, contact_sphere,
    contact_spherocylinders, euler_rhs, rotate_free, rotate_free_split, rotate_free_symmetric,
    rotational_energy, PairContact, Quat, Spherocylinder, PARALLEL_SIN,
};
use sweep::engine::walls::{Wall, WallShape};
use sweep::engine::{Real, V3};

type V = V3<f64>;

fn v(x: f64, y: f64, z: f64) -> V {
    V3::new(x, y, z)
}

fn uniform(n: &mut Noise, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * 0.5 * (n.next() + 1.0)
}

fn unit(n: &mut Noise) -> V {
    loop {
        let w = v(n.next(), n.next(), n.next());
        let r2 = w.norm2();
        if r2 > 1e-4 && r2 <= 1.0 {
            return w * (1.0 / r2.sqrt());
        }
    }
}

fn normalized(w: V) -> V {
    w * (1.0 / w.norm())
}

/// A random unit vector perpendicular to the unit vector `u`.
fn perp(n: &mut Noise, u: V) -> V {
    loop {
        let w = u.cross(unit(n));
        if w.norm2() > 1e-4 {
            return normalized(w);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Segment–segment closest points
// ---------------------------------------------------------------------------------------------

#[derive(Clone, Copy, Debug)]
struct Pair {
    p1: V,
    d1: V,
    p2: V,
    d2: V,
}

const KINDS: [&str; 5] = ["general", "near-parallel", "end-to-end", "crossed", "T"];

/// 10 % points (l = 0), 10 % tiny (l = 0.01, ξ = 1.01 at d = 1), else l ∈ [0.05, 2].
fn length(n: &mut Noise) -> f64 {
    let k = uniform(n, 0.0, 1.0);
    if k < 0.1 {
        0.0
    } else if k < 0.2 {
        0.01
    } else {
        uniform(n, 0.05, 2.0)
    }
}

fn random_pair(n: &mut Noise, kind: usize) -> Pair {
    let (l1, l2) = (length(n), length(n));
    let u = unit(n);
    let p1 = v(n.next(), n.next(), n.next());
    let d1 = u * l1;
    let flip = n.next() < 0.0;
    match kind {
        0 => Pair {
            p1,
            d1,
            p2: v(n.next(), n.next(), n.next()),
            d2: unit(n) * l2,
        },
        1 => {
            // θ = 0 (a fifth of them) or 10^U(−9, −6) rad; either direction; any axial shift.
            let theta = if n.next() < -0.6 {
                0.0
            } else {
                10f64.powf(uniform(n, -9.0, -6.0))
            };
            let dir = u * theta.cos() + perp(n, u) * theta.sin();
            let along = uniform(n, -l2 - 0.3, l1 + 0.3);
            let lateral = perp(n, u) * uniform(n, 0.0, 1.2);
            let sign = if flip { -1.0 } else { 1.0 };
            Pair {
                p1,
                d1,
                p2: p1 + u * along + lateral,
                d2: dir * (sign * l2),
            }
        }
        2 => {
            // Segment 2 continues segment 1 beyond its end, nearly collinear, either way round.
            let gap = uniform(n, -0.1, 0.2);
            let dir = normalized(u + unit(n) * uniform(n, 0.0, 1e-3));
            let near = p1 + d1 + u * gap + perp(n, u) * uniform(n, 0.0, 0.05);
            if flip {
                Pair {
                    p1,
                    d1,
                    p2: near + dir * l2,
                    d2: dir * -l2,
                }
            } else {
                Pair {
                    p1,
                    d1,
                    p2: near,
                    d2: dir * l2,
                }
            }
        }
        3 => {
            // Crossing over (or near) segment 1, roughly perpendicular.
            let a = perp(n, u);
            let b = u.cross(a);
            let centre = p1 + d1 * uniform(n, -0.2, 1.2) + b * uniform(n, -1.0, 1.0);
            let dir = normalized(a + u * uniform(n, -0.3, 0.3));
            Pair {
                p1,
                d1,
                p2: centre - dir * (0.5 * l2),
                d2: dir * l2,
            }
        }
        _ => {
            // T: segment 2 stands on segment 1's side, its foot at or near it.
            let a = perp(n, u);
            let foot = p1 + d1 * uniform(n, -0.1, 1.1) + a * uniform(n, 0.0, 0.3);
            if flip {
                Pair {
                    p1,
                    d1,
                    p2: foot + a * l2,
                    d2: a * -l2,
                }
            } else {
                Pair {
                    p1,
                    d1,
                    p2: foot,
                    d2: a * l2,
                }
            }
        }
    }
}

fn round<R: Real>(w: V) -> V3<R> {
    V3::from_f64(w.to_f64())
}

fn widen<R: Real>(w: V3<R>) -> V {
    V3::from_f64(w.to_f64())
}

fn dist2_at(p: &Pair, s: f64, t: f64) -> f64 {
    ((p.p1 + p.d1 * s) - (p.p2 + p.d2 * t)).norm2()
}

/// Parameter of the point of `a + u d` nearest to `x`, clamped to [0, 1].
fn project(a: V, d: V, x: V) -> f64 {
    let dd = d.norm2();
    if dd == 0.0 {
        0.0
    } else {
        ((x - a).dot(d) / dd).clamp(0.0, 1.0)
    }
}

/// Brute-force references in f64: the minimum distance over a 33 × 33 (s, t) grid, and over
/// 1001 values of s (t projected) and of t (s projected); with their resolutions, the most the
/// sampled minimum can exceed the true one (D is |d1|- and |d2|-Lipschitz in s and t).
fn sampled(p: &Pair) -> (f64, f64, f64, f64) {
    const N: usize = 32;
    const M: usize = 1000;
    let mut grid = f64::INFINITY;
    for i in 0..=N {
        for j in 0..=N {
            grid = grid.min(dist2_at(p, i as f64 / N as f64, j as f64 / N as f64));
        }
    }
    let mut line = f64::INFINITY;
    for i in 0..=M {
        let x = i as f64 / M as f64;
        let t = project(p.p2, p.d2, p.p1 + p.d1 * x);
        let s = project(p.p1, p.d1, p.p2 + p.d2 * x);
        line = line.min(dist2_at(p, x, t)).min(dist2_at(p, s, x));
    }
    let (a, b) = (p.d1.norm(), p.d2.norm());
    (
        grid.sqrt(),
        (a + b) / (2 * N) as f64,
        line.sqrt(),
        a.min(b) / (2 * M) as f64,
    )
}

/// Runs the 10⁵ pairs in precision R; returns, per kind, the largest (D − sampled minimum) and
/// the largest |D(returned dist2) − D(returned s, t in f64)|.
fn check_segments<R: Real>(tol_choice: f64, tol_round: f64) -> [(f64, f64); 5] {
    let mut noise = Noise::new(6);
    let mut worst = [(f64::NEG_INFINITY, 0.0f64); 5];
    for k in 0..100_000 {
        let kind = k % 5;
        let exact = random_pair(&mut noise, kind);
        let (p1, d1, p2, d2) = (
            round::<R>(exact.p1),
            round::<R>(exact.d1),
            round::<R>(exact.p2),
            round::<R>(exact.d2),
        );
        // The reference sees the same (rounded) inputs.
        let pair = Pair {
            p1: widen(p1),
            d1: widen(d1),
            p2: widen(p2),
            d2: widen(d2),
        };
        let c = closest_points(p1, d1, p2, d2);
        let (s, t) = (c.s.to_f64(), c.t.to_f64());
        assert!(
            (0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&t),
            "{kind}: {pair:?}"
        );
        assert!(c.p == p1 + d1 * c.s && c.q == p2 + d2 * c.t, "{pair:?}");
        let at = dist2_at(&pair, s, t).sqrt();
        let returned = c.dist2.to_f64().sqrt();
        let (grid, grid_res, line, line_res) = sampled(&pair);
        // Pairs the algorithm treats as parallel may sit ½ l sin θ above the minimum.
        let sin = pair.d1.cross(pair.d2).norm() / (pair.d1.norm() * pair.d2.norm()).max(1e-300);
        let slack = if sin <= 2.0 * PARALLEL_SIN {
            0.5 * pair.d1.norm().max(pair.d2.norm()) * sin
        } else {
            0.0
        };
        let tol = tol_choice + slack;
        let what = format!("{} pair {k} {:?}: {pair:?}", R::NAME, KINDS[kind]);
        assert!(
            at <= grid + tol && at <= line + tol,
            "above a sample: {what}"
        );
        assert!(
            grid - at <= grid_res + tol,
            "below the grid resolution: {what}"
        );
        assert!(
            line - at <= line_res + tol,
            "below the line resolution: {what}"
        );
        assert!((returned - at).abs() <= tol_round, "rounding: {what}");
        let w = &mut worst[kind];
        w.0 = w.0.max(at - line - slack);
        w.1 = w.1.max((returned - at).abs());
    }
    for (kind, w) in worst.iter().enumerate() {
        eprintln!(
            "{} {:>13}: max D − sampled min − slack {:+.2e}, max |D_returned − D(s,t)| {:.2e}",
            R::NAME,
            KINDS[kind],
            w.0,
            w.1
        );
    }
    worst
}

/// Law: for two segments p1 + s d1, p2 + t d2 (s, t ∈ [0, 1]) `closest_points` returns the
/// global minimum of |P(s) − Q(t)|. Reference: brute-force sampling in f64, a 33 × 33 (s, t) grid
/// and 2 × 1001 values of one parameter with the other projected, on 10⁵ random pairs (a fifth
/// each general, near-parallel with θ = 0 or 10⁻⁹…10⁻⁶ rad, end-to-end, crossed, T; 10 % of
/// lengths zero, 10 % 0.01). Every returned pair lies on the segments (checked), so its distance D
/// is ≥ the true minimum; it must be ≤ every sampled distance + 10⁻¹² (+ ½ l sin θ for pairs
/// treated as parallel, sin θ ≤ 10⁻⁶) and within the sampling resolution of the sampled minima
/// ((|d1| + |d2|)/64 for the grid, min(|d1|, |d2|)/2000 for the lines). The returned dist2
/// matches the returned points re-evaluated in f64 within 10⁻¹⁴.
/// A failure means a missed global minimum (wrong clamping order, a parallel or zero-length case
/// falling through to the line–line formula) or points off the segments.
#[test]
fn segment_distance_matches_brute_force_f64() {
    check_segments::<f64>(1e-12, 1e-14);
}

/// As the f64 test, run in f32 (inputs rounded to f32, reference in f64 on those rounded
/// inputs): the returned (s, t), evaluated in f64, must be ≤ every sample + 10⁻⁷ (+ ½ l sin θ
/// when treated as parallel; measured ≤ 5 × 10⁻⁹), and the returned f32 distance must match that
/// f64 evaluation within 10⁻⁶ (f32 rounding of coordinates of size ~3; measured 2.3 × 10⁻⁷). A
/// failure means the algorithm loses accuracy in f32 (e.g. the near-parallel cancellation of
/// a e − b², which the cross-product form avoids).
#[test]
fn segment_distance_matches_brute_force_f32() {
    check_segments::<f32>(1e-7, 1e-6);
}

// ---------------------------------------------------------------------------------------------
// Mass and inertia
// ---------------------------------------------------------------------------------------------

/// Law: the solid spherocylinder's volume and principal moments about its centre,
/// I∥ = m_c r²/2 + 2/5 m_s r², I⊥ = m_c (l²/12 + r²/4) + m_s (2/5 r² + l²/4 + 3/8 l r), equal
/// the grid integrals ∫ dV, ∫ (x² + y²) ρ dV and ∫ (y² + z²) ρ dV over a midpoint grid of 400
/// cells per diameter, within 0.5 %, for ξ = 1, 1.01, 1.5, 3 (d = 1, ρ = 1; measured
/// ≤ 1.7 × 10⁻⁴, the grid's own resolution). A failure means a wrong term in the analytic tensor
/// (the caps' parallel-axis shift is the usual culprit), which would give wrong rotational
/// dynamics and tumbling rates.
#[test]
fn inertia_matches_a_grid_integral() {
    for xi in [1.0, 1.01, 1.5, 3.0] {
        let shape = Spherocylinder::<f64>::from_aspect_ratio(xi, xi).unwrap();
        let (r, hl) = (shape.radius, shape.half_length);
        // One octant by symmetry; cells of side h.
        let h = 1.0 / 400.0;
        let (nr, nz) = ((r / h).round() as usize, ((hl + r) / h).ceil() as usize);
        let (mut vol, mut i_axial, mut i_perp) = (0.0, 0.0, 0.0);
        for k in 0..nz {
            let z = (k as f64 + 0.5) * h;
            let dz = (z - hl).max(0.0);
            let rho2 = r * r - dz * dz;
            if rho2 <= 0.0 {
                continue;
            }
            for i in 0..nr {
                let x = (i as f64 + 0.5) * h;
                for j in 0..nr {
                    let y = (j as f64 + 0.5) * h;
                    if x * x + y * y <= rho2 {
                        vol += 1.0;
                        i_axial += x * x + y * y;
                        i_perp += y * y + z * z;
                    }
                }
            }
        }
        let cell = 8.0 * h * h * h;
        let (vol, i_axial, i_perp) = (vol * cell, i_axial * cell, i_perp * cell);
        let analytic = shape.inertia(1.0);
        let errs = [
            (shape.volume() - vol) / vol,
            (shape.mass(1.0) - vol) / vol,
            (analytic.z - i_axial) / i_axial,
            (analytic.x - i_perp) / i_perp,
            (analytic.y - i_perp) / i_perp,
        ];
        eprintln!(
            "ξ = {xi}: relative errors volume {:+.1e}, I∥ {:+.1e}, I⊥ {:+.1e}",
            errs[0], errs[2], errs[3]
        );
        for e in errs {
            assert!(e.abs() < 5e-3, "ξ = {xi}: {errs:?}");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Rigid-body rotation
// ---------------------------------------------------------------------------------------------

fn diag_inv(i: V) -> V {
    v(1.0 / i.x, 1.0 / i.y, 1.0 / i.z)
}

/// Angle (rad) of the rotation taking q1 to q2.
fn angle_between(q1: Quat<f64>, q2: Quat<f64>) -> f64 {
    let d = q1.conjugate() * q2;
    2.0 * d.vector().norm().min(1.0).asin()
}

/// Reference: RK4 on Euler's equations (body ω) and q̇ = ½ q ⊗ (ω, 0), torque-free.
fn rk4(q: Quat<f64>, w: V, inertia: V, dt: f64, steps: usize) -> (Quat<f64>, V) {
    let f = |q: Quat<f64>, w: V| -> (Quat<f64>, V) {
        let dq = q * Quat::from_parts(w, 0.0);
        (
            Quat::from_parts(dq.vector() * 0.5, dq.w * 0.5),
            euler_rhs(inertia, w, V3::zero()),
        )
    };
    let add = |q: Quat<f64>, dq: Quat<f64>, h: f64| {
        Quat::from_parts(q.vector() + dq.vector() * h, q.w + dq.w * h)
    };
    let (mut q, mut w) = (q, w);
    for _ in 0..steps {
        let (k1q, k1w) = f(q, w);
        let (k2q, k2w) = f(add(q, k1q, dt / 2.0), w + k1w * (dt / 2.0));
        let (k3q, k3w) = f(add(q, k2q, dt / 2.0), w + k2w * (dt / 2.0));
        let (k4q, k4w) = f(add(q, k3q, dt), w + k3w * dt);
        let sum_q = Quat::from_parts(
            k1q.vector() + (k2q.vector() + k3q.vector()) * 2.0 + k4q.vector(),
            k1q.w + 2.0 * (k2q.w + k3q.w) + k4q.w,
        );
        q = add(q, sum_q, dt / 6.0).normalize();
        w += (k1w + (k2w + k3w) * 2.0 + k4w) * (dt / 6.0);
    }
    (q, w)
}

/// Law: torque-free, an asymmetric top (I = 2, 3, 5) conserves its kinetic energy and its
/// lab-frame angular momentum. Started spinning near the unstable intermediate axis (ω = 0.05,
/// 2, 0.05 rad/s in the body, so it flips over and over: the hardest case for a rotation
/// integrator) and run 10⁵ steps of dt = 5 ms (|ω| dt = 0.01):
/// - energy ½ π·I⁻¹π from q and L: max |E − E0|/E0 ≤ 10⁻⁵ (measured 1.1 × 10⁻⁶), and the mean
///   over the last tenth of the run within 10⁻⁸ of that over the first tenth (no drift);
/// - L from the motion itself, R(q) I ω with ω = 2 q* q̇ by central differences of q: max
///   |L − L0|/|L0| ≤ 5 × 10⁻⁵ (the O(dt²) difference error; measured 8.4 × 10⁻⁶),
///   first-to-last-tenth drift ≤ 10⁻⁸;
/// - ||q| − 1| ≤ 10⁻¹² throughout;
/// - over the first 10 s the orientation stays within 10⁻⁵ rad of RK4 (dt/20) on Euler's
///   equations (measured 3 × 10⁻⁶), and halving dt cuts that error 3.5–4.5 fold (second order).
///
/// A failure means the free rotation does not follow Euler's equations (a wrong sign or axis in
/// a sub-rotation), is not symplectic (energy drift), or leaks norm.
#[test]
fn asymmetric_top_conserves_energy_and_angular_momentum() {
    let inertia = v(2.0, 3.0, 5.0);
    let inv = diag_inv(inertia);
    let q0 = Quat::from_axis_angle(normalized(v(0.3, -0.5, 0.8)), 1.1);
    let w0 = v(0.05, 2.0, 0.05);
    let l = q0.rotate(v(w0.x * inertia.x, w0.y * inertia.y, w0.z * inertia.z));
    let dt = 5e-3;
    let steps = 100_000;
    let e0 = rotational_energy(q0, inv, l);
    let mut qs = Vec::with_capacity(steps + 1);
    qs.push(q0);
    let mut q = q0;
    let mut norm_err: f64 = 0.0;
    for _ in 0..steps {
        q = rotate_free(q, l, inv, dt);
        norm_err = norm_err.max((q.norm2().sqrt() - 1.0).abs());
        qs.push(q);
    }
    let tenth = steps / 10;
    let (mut e_max, mut l_max) = (0.0f64, 0.0f64);
    let (mut e_first, mut e_last, mut l_first, mut l_last) = (0.0, 0.0, 0.0, 0.0);
    let mut flips = 0;
    for n in 1..steps {
        let e = (rotational_energy(qs[n], inv, l) - e0) / e0;
        let dq = Quat::from_parts(
            (qs[n + 1].vector() - qs[n - 1].vector()) * (0.5 / dt),
            (qs[n + 1].w - qs[n - 1].w) * (0.5 / dt),
        );
        let w_body = (qs[n].conjugate() * dq).vector() * 2.0;
        let l_fd = angular_momentum(qs[n], inertia, qs[n].rotate(w_body));
        let dl = (l_fd - l).norm() / l.norm();
        e_max = e_max.max(e.abs());
        l_max = l_max.max(dl);
        if n <= tenth {
            e_first += e / tenth as f64;
            l_first += dl / tenth as f64;
        } else if n >= steps - tenth {
            e_last += e / tenth as f64;
            l_last += dl / tenth as f64;
        }
        // Count flips of the body y axis against L.
        let before = qs[n - 1].rotate(v(0.0, 1.0, 0.0)).dot(l);
        let after = qs[n].rotate(v(0.0, 1.0, 0.0)).dot(l);
        if before * after < 0.0 {
            flips += 1;
        }
    }
    eprintln!(
        "asymmetric top: {flips} flips; max |ΔE|/E = {e_max:.2e}, drift {:.2e}; \
         max |ΔL|/L = {l_max:.2e}, drift {:.2e}; max ||q| − 1| = {norm_err:.1e}",
        e_last - e_first,
        l_last - l_first
    );
    assert!(flips >= 4, "the top must tumble: {flips} flips");
    assert!(e_max <= 1e-5 && (e_last - e_first).abs() <= 1e-8);
    assert!(l_max <= 5e-5 && (l_last - l_first).abs() <= 1e-8);
    assert!(norm_err <= 1e-12);

    // Trajectory: against RK4 on Euler's equations over 10 s, at dt and dt/2.
    let t_end = 10.0;
    let (q_ref, _) = rk4(
        q0,
        w0,
        inertia,
        dt / 20.0,
        (t_end / (dt / 20.0)).round() as usize,
    );
    let error = |h: f64| {
        let mut q = q0;
        for _ in 0..(t_end / h).round() as usize {
            q = rotate_free_split(q, l, inv, h);
        }
        angle_between(q, q_ref)
    };
    let (e1, e2) = (error(dt), error(dt / 2.0));
    eprintln!(
        "asymmetric top vs RK4 at 10 s: {e1:.2e} rad (dt), {e2:.2e} rad (dt/2), ratio {:.2}",
        e1 / e2
    );
    assert!(e1 <= 1e-5, "{e1}");
    assert!((3.5..=4.5).contains(&(e1 / e2)), "{e1} {e2}");
}

/// Law: the free rotation of a quaternion in f32 keeps |q| = 1 within 10⁻⁶ (measured 1.2 × 10⁻⁷)
/// and the energy of the tumbling top of the f64 test within 10⁻⁴ (measured 1.1 × 10⁻⁵) over 10⁵
/// steps (rounding only; L is held exactly). A failure means f32 runs would let orientations
/// drift measurably.
#[test]
fn asymmetric_top_in_f32_stays_normalised() {
    let inertia = V3::<f32>::new(2.0, 3.0, 5.0);
    let inv = V3::new(0.5, 1.0 / 3.0, 0.2);
    let axis = V3::<f32>::new(0.3, -0.5, 0.8);
    let q0 = Quat::from_axis_angle(axis * (1.0 / axis.norm()), 1.1);
    let l = q0.rotate(V3::new(0.05 * inertia.x, 2.0 * inertia.y, 0.05 * inertia.z));
    let e0 = rotational_energy(q0, inv, l) as f64;
    let (mut q, mut e_max, mut n_max) = (q0, 0.0f64, 0.0f64);
    for _ in 0..100_000 {
        q = rotate_free(q, l, inv, 5e-3);
        n_max = n_max.max((q.norm2().sqrt() as f64 - 1.0).abs());
        e_max = e_max.max(((rotational_energy(q, inv, l) as f64) - e0).abs() / e0);
    }
    eprintln!("f32 asymmetric top: max |ΔE|/E = {e_max:.2e}, max ||q| − 1| = {n_max:.1e}");
    assert!(n_max <= 1e-6 && e_max <= 1e-4);
}

/// Measured body-frame precession rate of π⊥ = (π1, π2) (rad/s), from the unwrapped angle.
fn precession_rate(step: impl Fn(Quat<f64>) -> Quat<f64>, q0: Quat<f64>, l: V, dt: f64) -> f64 {
    let steps = 20_000;
    let mut q = q0;
    let mut angle = 0.0;
    let mut prev = q.rotate_inv(l);
    for _ in 0..steps {
        q = step(q);
        let pi = q.rotate_inv(l);
        angle += (prev.x * pi.y - prev.y * pi.x).atan2(prev.x * pi.x + prev.y * pi.y);
        prev = pi;
    }
    angle / (steps as f64 * dt)
}

/// Law: a torque-free symmetric top (the ξ = 3 spherocylinder, d = 1, ρ = 1: I1 = I2 = I⊥,
/// I3 = I∥) keeps ω3 and its perpendicular body-frame ω turns about the symmetry axis at
/// Ω_p = (I3 − I1)/I1 · ω3. Started at ω = (0.3, 0, 2) rad/s, run 2 × 10⁴ steps of dt = 2 ms:
/// the measured rate matches Ω_p within 0.5 % both with the exact symmetric-top rotation
/// (`rotate_free`; also within 10⁻⁹, it is exact up to rounding, measured 8 × 10⁻¹⁴) and with the
/// principal-axis splitting (`rotate_free_split`, O(dt²), measured 5 × 10⁻⁸). ω3 stays constant
/// within 10⁻¹². A failure means the inertia is applied about the wrong axes or the free rotation
/// turns the wrong way.
#[test]
fn symmetric_top_precesses_at_the_analytic_rate() {
    let shape = Spherocylinder::<f64>::from_aspect_ratio(3.0, 3.0).unwrap();
    let inertia = shape.inertia(1.0);
    let inv = diag_inv(inertia);
    let w = v(0.3, 0.0, 2.0);
    let q0 = Quat::from_axis_angle(normalized(v(1.0, 2.0, 0.5)), 0.4);
    let l = q0.rotate(v(w.x * inertia.x, w.y * inertia.y, w.z * inertia.z));
    let expect = (inertia.z - inertia.x) / inertia.x * w.z;
    let dt = 2e-3;
    let exact = precession_rate(|q| rotate_free(q, l, inv, dt), q0, l, dt);
    let split = precession_rate(|q| rotate_free_split(q, l, inv, dt), q0, l, dt);
    let rel = |x: f64| (x - expect) / expect;
    eprintln!(
        "precession: Ω_p = {expect:.6} rad/s; exact rotation {:+.1e}, split {:+.1e} relative",
        rel(exact),
        rel(split)
    );
    assert!(rel(exact).abs() < 5e-3 && rel(split).abs() < 5e-3);
    assert!(rel(exact).abs() < 1e-9);
    // ω3 is conserved.
    let mut q = q0;
    for _ in 0..1000 {
        q = rotate_free_symmetric(q, l, inv, dt);
    }
    let w3 = q.rotate_inv(angular_velocity(q, inv, l)).z;
    assert!((w3 - w.z).abs() < 1e-12, "{w3}");
}

/// Law: under a torque τ the kick–rotate–kick scheme (L += τ dt/2; free rotation; L += τ dt/2)
/// obeys the work–energy theorem, E(T) − E(0) = ∫ τ·ω dt. A constant lab torque (0.3, −0.2, 0.5)
/// on the asymmetric top (I = 2, 3, 5), 10⁴ steps of 1 ms; the work by the trapezoid rule on ω
/// at full steps: the two agree within 10⁻⁶ of the energy change (measured 2.6 × 10⁻⁸). A failure
/// means the torque enters in the wrong frame or at the wrong point of the step.
#[test]
fn work_of_a_torque_becomes_rotational_energy() {
    let inertia = v(2.0, 3.0, 5.0);
    let inv = diag_inv(inertia);
    let tau = v(0.3, -0.2, 0.5);
    let dt = 1e-3;
    let mut q = Quat::from_axis_angle(normalized(v(-0.2, 0.7, 0.4)), 2.0);
    let mut l = angular_momentum(q, inertia, v(0.4, 1.0, -0.7));
    let e0 = rotational_energy(q, inv, l);
    let mut work = 0.0;
    let mut w_prev = angular_velocity(q, inv, l);
    for _ in 0..10_000 {
        l += tau * (0.5 * dt);
        q = rotate_free(q, l, inv, dt);
        l += tau * (0.5 * dt);
        let w = angular_velocity(q, inv, l);
        work += 0.5 * dt * (tau.dot(w_prev) + tau.dot(w));
        w_prev = w;
    }
    let de = rotational_energy(q, inv, l) - e0;
    eprintln!(
        "torque: ΔE = {de:.6}, work = {work:.6}, relative gap {:.1e}",
        (de - work) / de
    );
    assert!(((de - work) / de).abs() < 1e-6);
}

// ---------------------------------------------------------------------------------------------
// Contacts
// ---------------------------------------------------------------------------------------------

const X: V = V3 {
    x: 1.0,
    y: 0.0,
    z: 0.0,
};
const Y: V = V3 {
    x: 0.0,
    y: 1.0,
    z: 0.0,
};
const Z: V = V3 {
    x: 0.0,
    y: 0.0,
    z: 1.0,
};

fn close(a: V, b: V, tol: f64) -> bool {
    (a - b).norm() <= tol
}

fn assert_contact(c: Option<PairContact<f64>>, normal: V, overlap: f64, arm_i: V, arm_j: V) {
    let c = c.expect("contact expected");
    let ok = close(c.normal, normal, 1e-12)
        && (c.overlap - overlap).abs() <= 1e-12
        && close(c.arm_i, arm_i, 1e-12)
        && close(c.arm_j, arm_j, 1e-12);
    assert!(
        ok,
        "got {c:?}, expected normal {normal:?} overlap {overlap} arms {arm_i:?} {arm_j:?}"
    );
}

/// Law: in the special configurations of two ξ = 3 rods (d = 1, l = 2, overlap δ = 10⁻³) the
/// normal, overlap and contact point are the geometric ones within 10⁻¹²:
/// - parallel side by side, shifted 0.3 along the axis: normal across, contact point in the
///   middle of the axial overlap (x = 0.15), for parallel and antiparallel axes; tilting by
///   ±5 × 10⁻⁷ rad (inside the parallel tolerance) moves it by < 10⁻⁶ (no jump);
/// - crossed at right angles: normal along the common perpendicular, point between the axes;
/// - end to end (caps touching, axes collinear, either way round): normal along the axis;
/// - T (one rod's cap on the other's side): normal along the stem;
/// - a ξ = 1.01 rod crossing a ξ = 3 one, and a rod on a base sphere (`contact_sphere`).
///
/// Tilting one of two parallel rods through the parallel tolerance moves the contact point
/// continuously. Swapping i and j negates the normal and swaps the arms within 10⁻¹² (10⁴ random
/// overlapping pairs); for near-parallel pairs (θ ~ 10⁻⁷) within 10⁻⁶, since the overlap's
/// middle is then taken on the other axis (it differs by ~θ l). A failure means a wrong sign
/// convention or a contact point that does not follow the closest points or jumps.
#[test]
fn contact_in_special_configurations() {
    let rod = Spherocylinder::<f64>::from_aspect_ratio(3.0, 3.0).unwrap();
    let (r, hl) = (rod.radius, rod.half_length);
    let dl = 1e-3;
    let gap = 2.0 * r - dl;
    let mid = r - dl / 2.0;

    // Parallel side by side: i spans x ∈ [−0.7, 1.3], j [−1, 1]: overlap [−0.7, 1], middle 0.15.
    let d = v(0.3, gap, 0.0);
    for uj in [X, -X] {
        let c = contact_spherocylinders(d, X, &rod, uj, &rod);
        assert_contact(c, Y, dl, v(-0.15, -mid, 0.0), v(0.15, mid, 0.0));
    }
    for tilt in [5e-7, -5e-7] {
        let ui = normalized(X + Z * tilt);
        let c = contact_spherocylinders(d, ui, &rod, X, &rod).unwrap();
        let point = d + c.arm_i;
        assert!(close(point, v(0.15, gap / 2.0, 0.0), 1e-6), "{c:?}");
    }
    // Crossed.
    let c = contact_spherocylinders(v(0.0, 0.0, gap), X, &rod, Y, &rod);
    assert_contact(c, Z, dl, -Z * mid, Z * mid);
    // End to end, caps touching.
    let d = v(2.0 * hl + gap, 0.0, 0.0);
    for (ui, uj) in [(X, X), (-X, X), (X, -X)] {
        let c = contact_spherocylinders(d, ui, &rod, uj, &rod);
        assert_contact(c, X, dl, -X * (hl + mid), X * (hl + mid));
    }
    // T: i stands on j's side at x = 0.4.
    let c = contact_spherocylinders(v(0.4, 0.0, hl + gap), Z, &rod, X, &rod);
    assert_contact(c, Z, dl, -Z * (hl + mid), v(0.4, 0.0, mid));
    // A nearly spherical rod (ξ = 1.01) crossing a long one.
    let short = Spherocylinder::<f64>::from_aspect_ratio(1.01, 1.01).unwrap();
    let c = contact_spherocylinders(v(0.5, 0.0, gap), Y, &short, X, &rod);
    assert_contact(c, Z, dl, -Z * mid, v(0.5, 0.0, mid));
    // On a base sphere of radius 1 under the rod's end.
    let base = 1.0;
    let d = v(hl, 0.0, base + r - dl);
    let c = contact_sphere(d, X, &rod, base);
    assert_contact(c, Z, dl, v(-hl, 0.0, -mid), Z * (base - dl / 2.0));
    // Tilting one of two parallel rods through the parallel tolerance moves the contact point
    // continuously: steps of 10⁻⁸ rad from −4θc to 4θc move it by < 2 % of l.
    let d = v(0.3, gap, 0.0);
    let mut prev: Option<V> = None;
    for k in -400..=400 {
        let theta = k as f64 * 1e-8;
        let ui = v(theta.cos(), theta.sin(), 0.0);
        let c = contact_spherocylinders(d, ui, &rod, X, &rod).unwrap();
        let point = d + c.arm_i;
        if let Some(p) = prev {
            assert!(
                (point - p).norm() < 0.02 * 2.0 * hl,
                "jump at θ = {theta}: {p:?} → {point:?}"
            );
        }
        prev = Some(point);
    }

    // Swap symmetry on random overlapping pairs.
    let mut n = Noise::new(66);
    let mut checked = 0usize;
    let mut worst = (0.0f64, 0.0f64);
    while checked < 10_000 {
        let ui = unit(&mut n);
        let near = checked.is_multiple_of(2);
        let uj = if near {
            normalized(ui + unit(&mut n) * 1e-7)
        } else {
            unit(&mut n)
        };
        let d = v(n.next(), n.next(), n.next()) * 1.5;
        let (Some(a), Some(b)) = (
            contact_spherocylinders(d, ui, &rod, uj, &short),
            contact_spherocylinders(-d, uj, &short, ui, &rod),
        ) else {
            continue;
        };
        checked += 1;
        let err = (a.normal + b.normal).norm()
            + (a.overlap - b.overlap).abs()
            + (a.arm_i - b.arm_j).norm()
            + (a.arm_j - b.arm_i).norm();
        let tol = if near { 1e-6 } else { 1e-12 };
        let w = if near { &mut worst.1 } else { &mut worst.0 };
        *w = w.max(err);
        assert!(err <= tol, "{d:?} {ui:?} {uj:?}: {a:?} vs {b:?}");
    }
    eprintln!(
        "swap symmetry: worst deviation {:.1e} (general), {:.1e} (near-parallel)",
        worst.0, worst.1
    );
}

/// Law: a rod on a plane (z = 0, normal +z): lying flat the overlap is r − h and the contact
/// point is under the centre (the middle of the touching part); tilted by 10⁻³ rad it is under
/// the lower end; standing on its end the overlap counts from the lower cap; at sin θ = 1.5 θc
/// (θc = 10⁻⁶) it is halfway along the ramp; and as the tilt crosses the tolerance the point
/// moves continuously (steps of 10⁻⁸ rad move it by < 2 % of l). Tolerance 10⁻¹² (10⁻⁹ on the
/// ramp, where θ is set through asin). A failure means a resting rod gets a spurious torque, a
/// tilted one the wrong lever arm, or the contact point jumps.
#[test]
fn contact_with_a_plane() {
    let rod = Spherocylinder::<f64>::from_aspect_ratio(3.0, 3.0).unwrap();
    let (r, hl) = (rod.radius, rod.half_length);
    let dl = 1e-3;
    let origin = V3::zero();
    let flat = contact_plane(v(0.2, 0.1, r - dl), X, &rod, origin, Z).unwrap();
    assert!((flat.overlap - dl).abs() < 1e-12 && flat.normal == Z);
    assert!(close(flat.arm, -Z * (r - dl / 2.0), 1e-12), "{flat:?}");
    // Tilted: the end at −x is lower.
    let theta: f64 = 1e-3;
    let axis = v(theta.cos(), 0.0, theta.sin());
    let centre = v(0.0, 0.0, r - dl + hl * theta.sin());
    let c = contact_plane(centre, axis, &rod, origin, Z).unwrap();
    assert!((c.overlap - dl).abs() < 1e-12);
    assert!(
        close(c.arm, -axis * hl - Z * (r - dl / 2.0), 1e-12),
        "{c:?}"
    );
    // Halfway through the ramp (sin θ = 1.5 θc) it is halfway to the end.
    let theta = (1.5 * PARALLEL_SIN).asin();
    let axis = v(theta.cos(), 0.0, theta.sin());
    let centre = v(0.0, 0.0, r - dl + hl * theta.sin());
    let c = contact_plane(centre, axis, &rod, origin, Z).unwrap();
    assert!(
        close(c.arm, -axis * (0.5 * hl) - Z * (r - dl / 2.0), 1e-9),
        "{c:?}"
    );
    // Standing on its end.
    let c = contact_plane(v(0.0, 0.0, hl + r - dl), Z, &rod, origin, Z).unwrap();
    assert!((c.overlap - dl).abs() < 1e-12);
    assert!(close(c.arm, -Z * (hl + r - dl / 2.0), 1e-12), "{c:?}");
    // Continuity through the tolerance.
    let mut prev: Option<V> = None;
    for k in -300..=300 {
        let theta = k as f64 * 1e-8;
        let axis = v(theta.cos(), 0.0, theta.sin());
        let c = contact_plane(
            v(0.0, 0.0, r - dl + hl * theta.abs()),
            axis,
            &rod,
            origin,
            Z,
        );
        let arm = c.unwrap().arm;
        if let Some(p) = prev {
            assert!(
                (arm - p).norm() < 0.02 * 2.0 * hl,
                "jump at θ = {theta}: {p:?} → {arm:?}"
            );
        }
        prev = Some(arm);
    }
}

/// Replica of the CPU engine's sphere–sphere contact (`engine/cpu/`, `ForceContext::particle`).
/// Normal, overlap and the two lever arms of a contact.
type SphereContact<R> = (V3<R>, R, V3<R>, V3<R>);

fn engine_sphere<R: Real>(d: V3<R>, ri: R, rj: R) -> Option<SphereContact<R>> {
    let dist2 = d.norm2();
    let sum = ri + rj;
    if dist2 >= sum * sum {
        return None;
    }
    let dist = dist2.sqrt();
    let n = d * (R::one() / dist);
    let overlap = sum - dist;
    let half_ov = overlap * R::from_f64(0.5);
    Some((n, overlap, -(n * (ri - half_ov)), n * (rj - half_ov)))
}

fn sphere_limit_is_exact<R: Real>() {
    let mut noise = Noise::new(7);
    let mut touching = 0;
    for _ in 0..20_000 {
        let ri = R::from_f64(uniform(&mut noise, 0.2, 0.6));
        let rj = R::from_f64(uniform(&mut noise, 0.2, 0.6));
        let d: V3<R> = round(v(noise.next(), noise.next(), noise.next()) * 1.2);
        let (ui, uj): (V3<R>, V3<R>) = (round(unit(&mut noise)), round(unit(&mut noise)));
        let (si, sj) = (Spherocylinder::sphere(ri), Spherocylinder::sphere(rj));
        let got = contact_spherocylinders(d, ui, &si, uj, &sj)
            .map(|c| (c.normal, c.overlap, c.arm_i, c.arm_j));
        assert_eq!(got, engine_sphere(d, ri, rj), "{} {d:?}", R::NAME);
        let base = contact_sphere(d, ui, &si, rj).map(|c| (c.normal, c.overlap, c.arm_i, c.arm_j));
        assert_eq!(base, got);
        touching += usize::from(got.is_some());
        // Plane through a random point with a random normal, against the engine's plane wall.
        let point = [noise.next(), noise.next(), noise.next()];
        let nv = unit(&mut noise).to_f64();
        let wall = Wall {
            shape: WallShape::Plane { point, normal: nv },
            rotation: None,
        }
        .kernel::<R>();
        let len = (nv[0].powi(2) + nv[1].powi(2) + nv[2].powi(2)).sqrt();
        let normal = V3::from_f64([nv[0] / len, nv[1] / len, nv[2] / len]);
        let mine = contact_plane(d, ui, &si, V3::from_f64(point), normal);
        let theirs = wall.touch(d, ri);
        assert_eq!(mine.is_some(), theirs.is_some());
        if let (Some(m), Some(t)) = (mine, theirs) {
            assert!(m.normal == t.normal && m.overlap == t.overlap);
            assert!(m.arm == -(t.normal * (ri - t.overlap * R::from_f64(0.5))));
        }
    }
    assert!(touching > 1000, "{touching}");
}

/// Law: with l = 0 (ξ = 1.00) the spherocylinder contacts are the engine's sphere contacts
/// exactly (`==`, every field, f64 and f32): sphere–sphere (normal, overlap, both lever arms, as
/// in `CpuEngine`), rod–base-sphere, and sphere–plane against `WallKernel::touch` (normal,
/// overlap, and the engine's lever arm −n (r − δ/2)), on 2 × 10⁴ random configurations with random
/// (irrelevant) axes. A failure means ξ = 1.00 runs would not reproduce sphere runs, i.e. the
/// segment code adds rounding even when the segment is a point.
#[test]
fn aspect_ratio_one_is_the_sphere_contact_exactly() {
    sphere_limit_is_exact::<f64>();
    sphere_limit_is_exact::<f32>();
}
