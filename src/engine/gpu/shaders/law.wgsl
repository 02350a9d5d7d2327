// The contact law (contact/hertz_mindlin.rs): the force of one contact and the elastic energy it
// stores, in the CPU engine's order of operations. Needs only Law, dot3 and the law overrides
// of common.wgsl, so that a probe kernel can run it alone (engine/gpu/law_probe.rs).

// The force on i (contact_force in contact/hertz_mindlin.rs); updates the tangential spring in place.
fn contact_force(law: Law, overlap: f32, n: vec3<f32>, v_rel: vec3<f32>, r_eff: f32, m_eff: f32,
                 dt: f32, spring: ptr<function, vec3<f32>>) -> vec3<f32> {
    let vn = dot3(v_rel, n);
    // Hertz stiffnesses grow as √(R*δ); computed once for both directions.
    // Folds to a constant unless the run mixes both laws.
    let hertz = ANY_HERTZ && (!ANY_LINEAR || law.hertz != 0u);
    var sq = 1.0;
    if (hertz) {
        sq = sqrt(r_eff * overlap);
    }
    var kn = law.kn;
    var sn = law.kn;
    if (hertz) {
        kn = law.kn * sq;
        // S_n = 2 Y* √(Rδ) = 3/2 k_n.
        sn = kn * 1.5;
    }
    let gamma_n = law.damp_n * sqrt(sn * m_eff);
    let fn_mag = kn * overlap - gamma_n * vn;
    var f = n * fn_mag;
    if (law.tangential != 0u) {
        let kt = law.kt * sq;
        let gamma_t = law.damp_t * sqrt(kt * m_eff);
        let vt = v_rel - n * vn;
        // Turn the old spring into the tangent plane, keeping its length.
        let old = *spring;
        let old2 = dot3(old, old);
        var s = old - n * dot3(old, n);
        let s2 = dot3(s, s);
        if (s2 > 0.0) {
            s = s * sqrt(old2 / s2);
        }
        s = s + vt * dt;
        var ft = -(s * kt) - vt * gamma_t;
        let limit = law.mu * abs(fn_mag);
        let ft2 = dot3(ft, ft);
        if (ft2 > limit * limit) {
            ft = ft * (limit / sqrt(ft2));
            s = -(ft + vt * gamma_t) * (1.0 / kt);
        }
        *spring = s;
        f = f + ft;
    }
    return f;
}

// Elastic energy stored in one contact (contact::elastic_energy): the normal spring's
// potential (Hertz 2/5 k_n δ², linear ½ k_n δ²) plus ½ k_t |ξ|², k_t at the current overlap.
fn elastic_energy(law: Law, overlap: f32, r_eff: f32, spring: vec3<f32>) -> f32 {
    let hertz = ANY_HERTZ && (!ANY_LINEAR || law.hertz != 0u);
    var sq = 1.0;
    var share = 0.5;
    if (hertz) {
        sq = sqrt(r_eff * overlap);
        share = 0.4;
    }
    var u = share * law.kn * sq * overlap * overlap;
    if (law.tangential != 0u) {
        u += 0.5 * law.kt * sq * dot3(spring, spring);
    }
    return u;
}

