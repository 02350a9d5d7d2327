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
    return wall_touch_split(w, p, vec3<f32>(0.0), rad);
}

// wall_touch for a split position p + lo (position.rs): the centre's offset from the wall's
// anchor a is formed as (p − a) + lo, as WallKernel::touch_split.
fn wall_touch_split(w: Wall, p: vec3<f32>, lo: vec3<f32>, rad: f32) -> WallContact {
    var out: WallContact;
    let rel = (p - w.a.xyz) + lo;
    out.hit = false;
    var normal: vec3<f32>;
    var dist: f32;
    var point: vec3<f32>;
    if (w.kind == 0u) {
        let d = dot3(rel, w.b.xyz);
        if (d >= rad) { return out; }
        normal = w.b.xyz;
        dist = d;
        point = p - w.b.xyz * d;
    } else if (w.kind == 1u) {
        if (p.z < w.z0 || p.z > w.z1) { return out; }
        let dx = rel.x;
        let dy = rel.y;
        let rr = sqrt(dx * dx + dy * dy);
        let d = w.r - rr;
        if (d >= rad || rr <= 0.0) { return out; }
        normal = vec3<f32>(-dx / rr, -dy / rr, 0.0);
        dist = d;
        point = vec3<f32>(w.a.x + dx / rr * w.r, w.a.y + dy / rr * w.r, p.z);
    } else {
        // The anchor is the orifice's centre on the plate (a.z = z0).
        let dz = rel.z;
        if (abs(dz) >= rad) { return out; }
        let dx = rel.x;
        let dy = rel.y;
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
            let d = vec3<f32>(rel.x - dx / rr * w.r, rel.y - dy / rr * w.r, rel.z);
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
