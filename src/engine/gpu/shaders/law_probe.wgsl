
// The law probe (engine/gpu/law_probe.rs): contact_force and elastic_energy of law.wgsl on a
// table of contacts, one invocation each. Input per contact (16 words): overlap, r_eff, m_eff,
// dt, normal, -, v_rel, -, spring, -; output (8 words): force, new spring, the elastic energy
// with the stored spring, -.
@group(0) @binding(40) var<storage, read> probe_laws: array<Law>;
@group(0) @binding(41) var<storage, read> probe_in: array<f32>;
@group(0) @binding(42) var<storage, read_write> probe_out: array<f32>;

fn probe_v3(at: u32) -> vec3<f32> {
    return vec3<f32>(probe_in[at], probe_in[at + 1u], probe_in[at + 2u]);
}

@compute @workgroup_size(64)
fn probe_law(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x;
    if (k >= arrayLength(&probe_laws)) {
        return;
    }
    let b = k * 16u;
    let law = probe_laws[k];
    let stored = probe_v3(b + 12u);
    var spring = stored;
    let f = contact_force(law, probe_in[b], probe_v3(b + 4u), probe_v3(b + 8u), probe_in[b + 1u],
                          probe_in[b + 2u], probe_in[b + 3u], &spring);
    let o = k * 8u;
    probe_out[o] = f.x;
    probe_out[o + 1u] = f.y;
    probe_out[o + 2u] = f.z;
    probe_out[o + 3u] = spring.x;
    probe_out[o + 4u] = spring.y;
    probe_out[o + 5u] = spring.z;
    probe_out[o + 6u] = elastic_energy(law, probe_in[b], probe_in[b + 1u], stored);
}
