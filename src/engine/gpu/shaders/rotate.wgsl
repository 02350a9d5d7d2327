// Rotation of oriented particles (spherocylinders): the rotational half of cpu/rods.rs's fused-kick
// velocity Verlet, as oriented::kick_rotate. L (lab frame) is kicked by the torque, the
// orientation turns by the exact free rotor of a symmetric top with L held (shape/rigid.rs
// rotate_free_symmetric), is renormalised, ω = R I⁻¹ Rᵀ L is refreshed, and the unit axis the
// contacts read is re-derived. Quaternions are vec4 (x, y, z, w), the layout of shape::Quat;
// every formula is written in the CPU's operation order.

// |q|² = x² + y² + z² + w², summed left to right.
fn quat_norm2(q: vec4<f32>) -> f32 {
    return q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w;
}

// The Hamilton product a b (rotate by b, then by a).
fn quat_mul(a: vec4<f32>, b: vec4<f32>) -> vec4<f32> {
    let u = a.xyz;
    let v = b.xyz;
    return vec4<f32>(v * a.w + u * b.w + cross3(u, v), a.w * b.w - dot3(u, v));
}

// q scaled to unit norm (after every rotation: rounding would otherwise let |q| random-walk).
fn quat_normalize(q: vec4<f32>) -> vec4<f32> {
    let k = 1.0 / sqrt(quat_norm2(q));
    return vec4<f32>(q.xyz * k, q.w * k);
}

// Body → lab, q v q* for unit q (v + w t + u × t with t = 2 u × v).
fn quat_rotate(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    let u = q.xyz;
    let t = cross3(u, v) * 2.0;
    return v + t * q.w + cross3(u, t);
}

// Lab → body, q* v q.
fn quat_rotate_inv(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    return quat_rotate(vec4<f32>(-q.xyz, q.w), v);
}

// The body z axis in the lab frame: a spherocylinder's unit axis (Quat::axis_z).
fn axis_z(q: vec4<f32>) -> vec3<f32> {
    return vec3<f32>(
        2.0 * (q.x * q.z + q.w * q.y),
        2.0 * (q.y * q.z - q.w * q.x),
        1.0 - 2.0 * (q.x * q.x + q.y * q.y),
    );
}

// ω = R I⁻¹ Rᵀ L for body-frame inverse principal moments `inv` (rigid.rs angular_velocity).
fn angular_velocity(q: vec4<f32>, inv: vec3<f32>, l: vec3<f32>) -> vec3<f32> {
    let p = quat_rotate_inv(q, l);
    return quat_rotate(q, vec3<f32>(p.x * inv.x, p.y * inv.y, p.z * inv.z));
}

// (sin x, cos x), accurate to about an ulp of f32 for |x| up to ~10⁴. WGSL's sin and cos only
// promise an absolute error of 2⁻¹¹ on [−π, π] (GPUs implement them with short tables), which
// for the small turns of one step (ω dt ~ 10⁻³) would be a relative error of 50 %; the CPU
// engine takes them from f64. So: Cody–Waite reduction by π/2 (the three parts of π/2 have
// short mantissas, so k × part is exact for |k| < 2¹⁵ without fused multiply–add), then the
// minimax polynomials of Cephes' sinf and cosf on [−π/4, π/4], and the quadrant.
fn sin_cos(x: f32) -> vec2<f32> {
    let k = round(x * 0.63661977236758134);
    let r = ((x - k * 1.5703125) - k * 4.837512969970703125e-4) - k * 7.54978995489188216e-8;
    let z = r * r;
    let s = ((-1.9515295891e-4 * z + 8.3321608736e-3) * z - 1.6666654611e-1) * z * r + r;
    let c = ((2.443315711809948e-5 * z - 1.388731625493765e-3) * z + 4.166664568298827e-2) * z * z
        - 0.5 * z + 1.0;
    let quadrant = i32(k) & 3;
    if (quadrant == 0) {
        return vec2<f32>(s, c);
    } else if (quadrant == 1) {
        return vec2<f32>(c, -s);
    } else if (quadrant == 2) {
        return vec2<f32>(-s, -c);
    }
    return vec2<f32>(-c, s);
}

// The exact free rotation of a symmetric top (I1 = I2, axis body z) over dt with L held:
// q ← exp(½ α L̂) q exp(½ β e3), α = |L| dt/I1, β = (1/I3 − 1/I1) π3 dt, π3 = L·axis.
fn rotate_free_symmetric(q: vec4<f32>, l: vec3<f32>, inv: vec3<f32>, dt: f32) -> vec4<f32> {
    // π3 is conserved by both factors, so it may be read before either.
    let pi3 = dot3(l, axis_z(q));
    let b = sin_cos((inv.z - inv.x) * pi3 * dt * 0.5);
    let spin = vec4<f32>(0.0, 0.0, b.x, b.y);
    let l_norm = sqrt(dot3(l, l));
    var turned = q;
    if (l_norm > 0.0) {
        let a = sin_cos(l_norm * inv.x * dt * 0.5);
        turned = quat_mul(vec4<f32>(l * (a.x / l_norm), a.y), q);
    }
    return quat_normalize(quat_mul(turned, spin));
}

// After the translation of oriented particle i at step k: kick L by the torque (dt/2 at a
// chunk's first step, two dt/2 after), turn freely for dt, refresh ω and the axis; then flag the lists
// stale when the ends may have moved more than skin/2 since the last build, |Δc| + (l/2)|Δu|
// (as cpu/rods.rs).
fn kick_rotate(i: u32, k: u32) {
    if (vel_im[i].w == 0.0 || !live(info[i].alive)) { return; }
    let r = rod[i];
    let inv = r.inv_inertia_h.xyz;
    let h = r.inv_inertia_h.w;
    var turned = 0.0;
    if (inv.x != 0.0) {
        // Two half kicks after a chunk's first step, as translate.
        let dl = load[i].torque.xyz * params.half_dt;
        var ls = kick_split(r.ang_mom.xyz, omega[rest_at(i)].xyz, dl);
        if (k > 0u) {
            ls = kick_split(ls.s, ls.e, dl);
        }
        let l = ls.s;
        let q = rotate_free_symmetric(r.q, l, inv, params.dt);
        rod[i].q = q;
        rod[i].ang_mom = vec4<f32>(l, 0.0);
        put_omega(rest_at(i), vec4<f32>(ls.e, 0.0));
        put_omega(i, vec4<f32>(angular_velocity(q, inv, l), 0.0));
        let u = axis_z(q);
        put_pos(shape_at(i), vec4<f32>(u, h));
        if (h > 0.0) {
            let du = u - ref_pos[shape_at(i)].xyz;
            turned = sqrt(dot3(du, du)) * h;
        }
    }
    let d = min_image(ref_pos[i].xyz, moved_pos(i).xyz);
    if (sqrt(dot3(d, d)) + turned > params.half_skin) {
        flag_stale(k);
    }
}
