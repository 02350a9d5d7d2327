//! The Student t quantile and the 95 % confidence interval of a mean.

/// Two-sided 95 % quantile of Student's t with `dof` degrees of freedom (t such that
/// P(T ≤ t) = 0.975). Infinite for dof = 0.
pub fn student_t_975(dof: usize) -> f64 {
    // Exact values for small dof, where the asymptotic series below is not accurate enough.
    const TABLE: [f64; 30] = [
        12.706204736174707,
        4.302652729749464,
        3.182446305284263,
        2.7764451051977934,
        2.570581835636314,
        2.4469118511449666,
        2.3646242515927853,
        2.306004135204168,
        2.2621571628540993,
        2.2281388519862744,
        2.200985160082949,
        2.1788128296672284,
        2.1603686564627926,
        2.1447866879178044,
        2.131449545559323,
        2.1199052992210112,
        2.1098155778333156,
        2.100922040241036,
        2.093024054408263,
        2.0859634472658364,
        2.079613844727662,
        2.0738730679040147,
        2.0686576104190406,
        2.0638985616280205,
        2.059538552753294,
        2.055529438642871,
        2.0518305164802833,
        2.048407141795244,
        2.045229642132703,
        2.0422724563012373,
    ];
    match dof {
        0 => f64::INFINITY,
        1..=30 => TABLE[dof - 1],
        _ => {
            // Cornish–Fisher expansion of the t quantile around the normal one (Abramowitz &
            // Stegun 26.7.5); with five terms it is good to ~1e-8 for dof > 30.
            let z: f64 = 1.959_963_984_540_054;
            let v = dof as f64;
            let (z3, z5, z7, z9) = (z.powi(3), z.powi(5), z.powi(7), z.powi(9));
            z + (z3 + z) / (4.0 * v)
                + (5.0 * z5 + 16.0 * z3 + 3.0 * z) / (96.0 * v * v)
                + (3.0 * z7 + 19.0 * z5 + 17.0 * z3 - 15.0 * z) / (384.0 * v.powi(3))
                + (79.0 * z9 + 776.0 * z7 + 1482.0 * z5 - 1920.0 * z3 - 945.0 * z)
                    / (92160.0 * v.powi(4))
        }
    }
}

/// Mean of `samples` and the half-width of its 95 % confidence interval, t_{n−1} s / √n.
///
/// None for fewer than 2 samples (no spread to estimate) or a non-finite sample.
pub fn mean_ci95(samples: &[f64]) -> Option<(f64, f64)> {
    let n = samples.len();
    if n < 2 || samples.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let nf = n as f64;
    let mean = samples.iter().sum::<f64>() / nf;
    let var = samples.iter().map(|s| (s - mean).powi(2)).sum::<f64>() / (nf - 1.0);
    Some((mean, student_t_975(n - 1) * (var / nf).sqrt()))
}
