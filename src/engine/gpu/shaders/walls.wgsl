// Walls (walls/): infinite plane, inside of a vertical finite cylinder, horizontal plate with a
// circular orifice whose rim is a real edge; a rotating wall contributes its surface velocity.

@group(0) @binding(1) var<uniform> walls: Walls;

struct WallContact {
    hit: bool,
    // Unit normal from the wall to the particle centre.
    normal: vec3<f32>,
    overlap: f32,
    wall_velocity: vec3<f32>,
}

// The contact of a sphere (centre p, radius rad) with wall w, as WallKernel::touch.
fn wall_touch(w: Wall, p: vec3<f32>, rad: f32) -> WallContact {
    var out: WallContact;
    out.hit = false;
    var normal: vec3<f32>;
    var dist: f32;
    var point: vec3<f32>;
    if (w.kind == 0u) {
        let d = dot3(p - w.a.xyz, w.b.xyz);
        if (d >= rad) { return out; }
        normal = w.b.xyz;
        dist = d;
        point = p - w.b.xyz * d;
    } else if (w.kind == 1u) {
        if (p.z < w.z0 || p.z > w.z1) { return out; }
        let dx = p.x - w.a.x;
        let dy = p.y - w.a.y;
        let rr = sqrt(dx * dx + dy * dy);
        let d = w.r - rr;
        if (d >= rad || rr <= 0.0) { return out; }
        normal = vec3<f32>(-dx / rr, -dy / rr, 0.0);
        dist = d;
        point = vec3<f32>(w.a.x + dx / rr * w.r, w.a.y + dy / rr * w.r, p.z);
    } else {
        let dz = p.z - w.z0;
        if (abs(dz) >= rad) { return out; }
        let dx = p.x - w.a.x;
        let dy = p.y - w.a.y;
        let rr = sqrt(dx * dx + dy * dy);
        if (rr >= w.r) {
            // Over the solid part: the plate's face, from whichever side.
            normal = vec3<f32>(0.0, 0.0, select(-1.0, 1.0, dz >= 0.0));
            dist = abs(dz);
            point = vec3<f32>(p.x, p.y, w.z0);
        } else {
            // Over the hole: the nearest solid point is on the rim.
            if (rr <= 0.0) { return out; }
            let q = vec3<f32>(w.a.x + dx / rr * w.r, w.a.y + dy / rr * w.r, w.z0);
            let d = p - q;
            let dd = sqrt(dot3(d, d));
            if (dd >= rad || dd <= 0.0) { return out; }
            normal = d * (1.0 / dd);
            dist = dd;
            point = q;
        }
    }
    var wv = vec3<f32>(0.0);
    let om = w.rot.w;
    if (om != 0.0) {
        // v = Ω ẑ × (q − c)
        let rel = point - w.rot.xyz;
        wv = vec3<f32>(-om * rel.y, om * rel.x, 0.0);
    }
    out.hit = true;
    out.normal = normal;
    out.overlap = rad - dist;
    out.wall_velocity = wv;
    return out;
}
