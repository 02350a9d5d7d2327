// The integrate module's bindings: its kernels update the state in place (step.wgsl's `put_*`).
@group(0) @binding(2) var<storage, read_write> pos_r: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> vel_im: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> omega: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> info: array<Info>;
@group(0) @binding(6) var<storage, read> load: array<Load>;
@group(0) @binding(9) var<storage, read> ref_pos: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read_write> status: array<atomic<u32>>;
@group(0) @binding(11) var<storage, read_write> events: array<vec2<u32>>;
@group(0) @binding(18) var<storage, read_write> rod: array<Rod>;

fn put_pos(x: u32, v: vec4<f32>) {
    pos_r[x] = v;
}

fn put_vel(x: u32, v: vec4<f32>) {
    vel_im[x] = v;
}

fn put_omega(x: u32, v: vec4<f32>) {
    omega[x] = v;
}

// The position particle i's step wrote.
fn moved_pos(i: u32) -> vec4<f32> {
    return pos_r[i];
}

// Particle i crossed the sink in the drift of step k: no kernel reads it in place after this.
fn mark_dead(i: u32, k: u32) {
    info[i].alive = 0u;
}
