// Contacts of oriented particles (spherocylinders; spheres among them have l = 0): the segment
// geometry of shape/segment.rs, the pair and plane contacts of shape/spherocylinder.rs, the wall
// contacts of walls/mod.rs `touch_oriented` and the gather of oriented.rs, in the CPU's operation
// order. No recursion and no unbounded loop: every branch of the closest-point search is a
// straight formula.
//
// Each pair is evaluated in one canonical order, the lower id as "a", by both of its particles
// from identical inputs, so both compute the same force bit for bit and apply ±F, and both store
// the same (a's view) tangential spring, keyed by the partner's id.

// Closest points of segment 1 (p1 + s d1) and segment 2 (p2 + t d2), s, t ∈ [0, 1].
struct Closest {
    s: f32,
    t: f32,
    p: vec3<f32>,
    q: vec3<f32>,
    dist2: f32,
}

// Clamps to [0, 1]; NaN becomes 0 (segment.rs clamp01).
fn clamp01(x: f32) -> f32 {
    return rmin(rmax(x, 0.0), 1.0);
}

// Non-parallel segments from the line–line minimiser s_line: s clamped, t optimal for it; if t
// leaves [0, 1] it is clamped and s re-solved. a = |d1|², b = d1·d2, c = d1·r, e = |d2|², f = d2·r.
fn seg_general(s_line: f32, a: f32, b: f32, c: f32, e: f32, f: f32) -> vec2<f32> {
    let s = clamp01(s_line);
    let t = (b * s + f) / e;
    if (t < 0.0) {
        return vec2<f32>(clamp01(-c / a), 0.0);
    } else if (t > 1.0) {
        return vec2<f32>(clamp01((b - c) / a), 1.0);
    }
    return vec2<f32>(s, t);
}

// Parallel segments: the middle of the overlap of segment 2 projected on segment 1, or, when the
// projections are disjoint (end to end), the nearest ends.
fn seg_parallel(a: f32, b: f32, c: f32, e: f32, f: f32) -> vec2<f32> {
    // Where the two ends of segment 2 project on segment 1's line, in units of s.
    let s0 = -c / a;
    let s1 = (b - c) / a;
    var lo = s1;
    var hi = s0;
    if (s0 <= s1) {
        lo = s0;
        hi = s1;
    }
    let lo_in = rmax(lo, 0.0);
    let hi_in = rmin(hi, 1.0);
    if (lo_in <= hi_in) {
        let s = (lo_in + hi_in) * 0.5;
        return vec2<f32>(s, clamp01((b * s + f) / e));
    }
    let s = select(1.0, 0.0, hi < 0.0);
    let t = clamp01((b * s + f) / e);
    return vec2<f32>(clamp01((b * t - c) / a), t);
}

// segment.rs closest_points: robust for crossed, T, end-to-end, parallel and nearly parallel
// segments and zero-length ones (points). The line–line minimiser is written with cross products
// (error ~ε/sin θ, not ε/sin²θ); below sin θ = θc the pair is the overlap's middle, above 2θc the
// exact pair, linear in between, so the contact point never jumps.
fn closest_points(p1: vec3<f32>, d1: vec3<f32>, p2: vec3<f32>, d2: vec3<f32>) -> Closest {
    let r = p1 - p2;
    let a = dot3(d1, d1);
    let e = dot3(d2, d2);
    let c = dot3(d1, r);
    let f = dot3(d2, r);
    var st = vec2<f32>(0.0, 0.0);
    if (a <= POINT_LEN2 && e <= POINT_LEN2) {
        st = vec2<f32>(0.0, 0.0);
    } else if (a <= POINT_LEN2) {
        st = vec2<f32>(0.0, clamp01(f / e));
    } else if (e <= POINT_LEN2) {
        st = vec2<f32>(clamp01(-c / a), 0.0);
    } else {
        let b = dot3(d1, d2);
        let n = cross3(d1, d2);
        let n2 = dot3(n, n);
        let ae = a * e;
        if (n2 > 4.0 * PARALLEL_SIN2 * ae) {
            st = seg_general(dot3(n, cross3(d2, r)) / n2, a, b, c, e, f);
        } else if (n2 <= PARALLEL_SIN2 * ae) {
            st = seg_parallel(a, b, c, e, f);
        } else {
            // θc < sin θ ≤ 2θc: from the overlap's middle (w = 0) to the exact pair (w = 1).
            let s_mid = seg_parallel(a, b, c, e, f).x;
            let s_exact = seg_general(dot3(n, cross3(d2, r)) / n2, a, b, c, e, f).x;
            let w = sqrt(n2 / ae) / PARALLEL_SIN - 1.0;
            let s = s_mid + (s_exact - s_mid) * rmin(rmax(w, 0.0), 1.0);
            st = vec2<f32>(s, clamp01((b * s + f) / e));
        }
    }
    var out: Closest;
    out.s = st.x;
    out.t = st.y;
    out.p = p1 + d1 * st.x;
    out.q = p2 + d2 * st.y;
    let pq = out.p - out.q;
    out.dist2 = dot3(pq, pq);
    return out;
}

// A unit vector perpendicular to the unit vector u: u crossed with the coordinate axis it is
// least aligned with.
fn perpendicular(u: vec3<f32>) -> vec3<f32> {
    let ax = abs(u.x);
    let ay = abs(u.y);
    let az = abs(u.z);
    var e = vec3<f32>(0.0, 0.0, 1.0);
    if (ax <= ay && ax <= az) {
        e = vec3<f32>(1.0, 0.0, 0.0);
    } else if (ay <= az) {
        e = vec3<f32>(0.0, 1.0, 0.0);
    }
    let p = cross3(u, e);
    return p * (1.0 / sqrt(dot3(p, p)));
}

// The normal for axes that touch (|p − q| = 0): along ui × uj if the axes cross, else the part
// of the centre vector d across ui, else any perpendicular of ui.
fn touching_normal(d: vec3<f32>, ui: vec3<f32>, uj: vec3<f32>) -> vec3<f32> {
    let c = cross3(ui, uj);
    let c2 = dot3(c, c);
    if (c2 > TOUCH_TINY) {
        return c * (1.0 / sqrt(c2));
    }
    let across = d - ui * dot3(d, ui);
    let a2 = dot3(across, across);
    if (a2 > TOUCH_TINY * dot3(d, d) && a2 > 0.0) {
        return across * (1.0 / sqrt(a2));
    }
    return perpendicular(ui);
}

// A contact seen from particle a: normal from b to a, overlap, lever arms from each centre.
struct PairContact {
    hit: bool,
    normal: vec3<f32>,
    overlap: f32,
    arm_a: vec3<f32>,
    arm_b: vec3<f32>,
}

// contact_spherocylinders: d = c_a − c_b (minimum image), u unit axes, h = l/2, r radii.
fn contact_pair(d: vec3<f32>, ua: vec3<f32>, ha: f32, ra: f32, ub: vec3<f32>, hb: f32,
                rb: f32) -> PairContact {
    var out: PairContact;
    out.hit = false;
    let hva = ua * ha;
    let hvb = ub * hb;
    // In the frame of c_b: axis a runs from d − ha to d + ha, axis b from −hb to hb.
    let cp = closest_points(d - hva, hva + hva, -hvb, hvb + hvb);
    let sum = ra + rb;
    if (cp.dist2 >= sum * sum) { return out; }
    let dist = sqrt(cp.dist2);
    var normal: vec3<f32>;
    if (dist > 0.0) {
        normal = (cp.p - cp.q) * (1.0 / dist);
    } else {
        normal = touching_normal(d, ua, ub);
    }
    let overlap = sum - dist;
    let half_ov = overlap * 0.5;
    // Axis points relative to their own centres: h (2s − 1) is exactly 0 for a sphere.
    let on_a = hva * (cp.s * 2.0 - 1.0);
    let on_b = hvb * (cp.t * 2.0 - 1.0);
    out.hit = true;
    out.normal = normal;
    out.overlap = overlap;
    out.arm_a = on_a - normal * (ra - half_ov);
    out.arm_b = on_b + normal * (rb - half_ov);
    return out;
}

// A contact of a rod with a wall: normal (from the wall), overlap, arm from the centre, and the
// wall's surface velocity there.
struct RodWallContact {
    hit: bool,
    normal: vec3<f32>,
    overlap: f32,
    arm: vec3<f32>,
    wall_velocity: vec3<f32>,
}

// Velocity of wall w's surface at `point` (zero unless it rotates).
fn surface_velocity(w: Wall, point: vec3<f32>) -> vec3<f32> {
    let om = w.rot.w;
    if (om != 0.0) {
        let rel = point - w.rot.xyz;
        return vec3<f32>(-om * rel.y, om * rel.x, 0.0);
    }
    return vec3<f32>(0.0);
}

// spherocylinder.rs contact_plane: overlap r − (height of the lower axis end); the contact point
// below the lower end once the axis tilts by sin θ ≥ 2θc, below the centre for sin θ ≤ θc (a rod
// lying flat gets no spurious torque), linear in between.
fn contact_plane(c: vec3<f32>, u: vec3<f32>, hl: f32, r: f32, point: vec3<f32>,
                 n: vec3<f32>) -> RodWallContact {
    var out: RodWallContact;
    out.hit = false;
    let h = u * hl;
    let above = dot3(c - point, n);
    let lowest = above - abs(dot3(h, n));
    if (lowest >= r) { return out; }
    let overlap = r - lowest;
    let tilt = dot3(u, n);
    let ramp = rmin(rmax(abs(tilt) / PARALLEL_SIN - 1.0, 0.0), 1.0);
    let sigma = select(ramp, -ramp, tilt > 0.0);
    out.hit = true;
    out.normal = n;
    out.overlap = overlap;
    out.arm = h * sigma - n * (r - overlap * 0.5);
    return out;
}

// walls/mod.rs touch_oriented: planes exact; other walls take the deepest of the axis' two end
// spheres and its centre sphere (the first of equals).
// lo: the rest of the split centre (position.rs).
fn touch_oriented(w: Wall, c: vec3<f32>, lo: vec3<f32>, u: vec3<f32>, hl: f32, r: f32) -> RodWallContact {
    if (w.kind == 0u) {
        var pc = contact_plane((c - w.a.xyz) + lo, u, hl, r, vec3<f32>(0.0), w.b.xyz);
        if (pc.hit) {
            pc.wall_velocity = surface_velocity(w, c + pc.arm);
        }
        return pc;
    }
    var best: RodWallContact;
    best.hit = false;
    if (hl == 0.0) {
        let wc = wall_touch_split(w, c, lo, r);
        if (wc.hit) {
            best.hit = true;
            best.normal = wc.normal;
            best.overlap = wc.overlap;
            best.arm = -(wc.normal * (r - wc.overlap * 0.5));
            best.wall_velocity = wc.wall_velocity;
        }
        return best;
    }
    let h = u * hl;
    for (var k = 0u; k < 3u; k++) {
        var offset = vec3<f32>(0.0);
        if (k == 0u) {
            offset = h;
        } else if (k == 1u) {
            offset = -h;
        }
        let wc = wall_touch_split(w, c + offset, lo, r);
        if (wc.hit && (!best.hit || wc.overlap > best.overlap)) {
            best.hit = true;
            best.normal = wc.normal;
            best.overlap = wc.overlap;
            best.arm = offset - wc.normal * (r - wc.overlap * 0.5);
            best.wall_velocity = wc.wall_velocity;
        }
    }
    return best;
}

// |arm × n|²/I⊥ of a rod (h > 0; `inv_i` its 1/I⊥, in Info.inv_inertia for oriented runs), zero
// for a sphere: contact/effective_mass.rs.
fn turn_term(h: f32, inv_i: f32, arm: vec3<f32>, n: vec3<f32>) -> f32 {
    let c = cross3(arm, n);
    return select(0.0, dot3(c, c) * inv_i, h > 0.0);
}

// The oriented gather (oriented.rs `particle`): force, torque, largest overlap ratio and contact
// count of particle i, its history rows rewritten.
fn gather_oriented(i: u32, me: Info) -> Gathered {
    var f = vec3<f32>(0.0);
    var t = vec3<f32>(0.0);
    var max_ov = 0.0;
    var nc = 0u;
    let use_rows = HISTORY;
    let v4 = vel_im[i];
    let fixed_i = v4.w == 0.0;
    let cnt = nbr_get(nbr_at(i, 0u));
    for (var q = 0u; q < cnt; q++) {
        let j = nbr_get(nbr_at(i, 1u + q));
        let other = info[j];
        if (!live_at_forces(other.alive)) { continue; }
        let fixed_j = vel_im[j].w == 0.0;
        if (fixed_i && fixed_j) { continue; }
        // Canonical order: a has the lower id.
        let i_is_a = me.id < other.id;
        let a = select(i, j, !i_is_a);
        let b = select(j, i, !i_is_a);
        let pa = pos_r[a];
        let pb = pos_r[b];
        let sa = pos_r[shape_at(a)];
        let sb = pos_r[shape_at(b)];
        let d = separation(pb.xyz, pos_r[lo_at(b)].xyz, pa.xyz, pos_r[lo_at(a)].xyz); // c_a − c_b
        let pc = contact_pair(d, sa.xyz, sa.w, pa.w, sb.xyz, sb.w, pb.w);
        if (!pc.hit) { continue; }
        let va = vel_im[a];
        let vb = vel_im[b];
        let v_rel = (va.xyz + cross3(omega[a].xyz, pc.arm_a))
            - (vb.xyz + cross3(omega[b].xyz, pc.arm_b));
        let ma = info[a].mass;
        let mb = info[b].mass;
        // A fixed partner acts as infinitely heavy.
        var m_eff = ma * mb / (ma + mb);
        if (vb.w == 0.0) {
            m_eff = ma;
        } else if (va.w == 0.0) {
            m_eff = mb;
        }
        // contact/effective_mass.rs: a rod's turning lightens the contact.
        if (sa.w > 0.0 || sb.w > 0.0) {
            let turns = turn_term(sa.w, info[a].inv_inertia, pc.arm_a, pc.normal)
                + turn_term(sb.w, info[b].inv_inertia, pc.arm_b, pc.normal);
            m_eff = 1.0 / ((va.w + vb.w) + turns);
        }
        let ra = pa.w;
        let rb = pb.w;
        var spring = vec3<f32>(0.0);
        if (use_rows) {
            spring = rows_get(other.id);
        }
        let stored = spring;
        let fc = contact_force(params.law_pp, pc.overlap, pc.normal, v_rel, ra * rb / (ra + rb),
                               m_eff, spring_dt(), &spring);
        if (use_rows) {
            rows_put(i, other.id, spring);
        }
        var force_i = -fc;
        var arm_i = pc.arm_b;
        if (i_is_a) {
            force_i = fc;
            arm_i = pc.arm_a;
        }
        f = f + force_i;
        t = t + cross3(arm_i, force_i);
        max_ov = rmax(max_ov, pc.overlap / (rmin(ra, rb) * 2.0));
        nc++;
        if (RECORD && !fixed_i && (fixed_j || i_is_a)) {
            emit(i, me, j, other.id, select(0u, 2u, fixed_j), pos_r[i].xyz, select(-d, d, i_is_a), force_i,
                 elastic_energy(params.law_pp, pc.overlap, ra * rb / (ra + rb), stored));
        }
    }
    if (WALLS && !fixed_i) {
        let p4 = pos_r[i];
        let sh = pos_r[shape_at(i)];
        let ri = p4.w;
        let wi = omega[i].xyz;
        for (var w = 0u; w < params.n_walls; w++) {
            let wc = touch_oriented(walls.w[params.job * MAX_WALLS + w], p4.xyz, pos_r[lo_at(i)].xyz, sh.xyz, sh.w, ri);
            if (!wc.hit) { continue; }
            let v_rel = v4.xyz + cross3(wi, wc.arm) - wc.wall_velocity;
            let key = WALL_KEY | w;
            var spring = vec3<f32>(0.0);
            if (use_rows) {
                spring = rows_get(key);
            }
            let stored = spring;
            var m_w = me.mass;
            if (sh.w > 0.0) {
                m_w = 1.0 / (v4.w + turn_term(sh.w, me.inv_inertia, wc.arm, wc.normal));
            }
            let fc = contact_force(params.law_pw, wc.overlap, wc.normal, v_rel, ri, m_w, spring_dt(),
                                   &spring);
            if (use_rows) {
                rows_put(i, key, spring);
            }
            f = f + fc;
            t = t + cross3(wc.arm, fc);
            max_ov = rmax(max_ov, wc.overlap / (ri * 2.0));
            nc++;
            if (RECORD) {
                emit(i, me, w, 0u, 3u, p4.xyz, -wc.arm, fc,
                     elastic_energy(params.law_pw, wc.overlap, ri, stored));
            }
        }
    }
    return Gathered(f, t, max_ov, nc);
}
