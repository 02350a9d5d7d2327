//! Ordered layers in a chute flow. Monodisperse spheres in a thin bed can order into layers
//! that slide over each other (Silbert, Landry & Grest, Phys. Fluids 15, 1 (2003)): the flow
//! is then faster and is no longer the disordered dense flow whose D(γ̇) the chute paper
//! studies, whose rough base is there "to avoid extreme crystallization". Layers show in the
//! coarse-grained density: ρ(z) oscillates with a period of about one diameter through the
//! whole bed, while a disordered bed's oscillations die out within a few diameters of the base.
//! Judged when the results are read, from the stored profile, so it applies to any stored job.

/// The central bed, as fractions of the bed height H, over which ρ(z) varies in a layered flow
/// (the claims' central bed).
pub const LAYERING_BED: (f64, f64) = (0.3, 0.7);

/// Above this coefficient of variation of ρ(z) over the central bed a flow is layered.
/// Disordered beds stay near 0.01 and layered ones near 0.2 (docs/reproduction.md).
pub const LAYERED_ABOVE: f64 = 0.1;

/// Fewest profile heights in the central bed for a verdict: the layers' period (about one
/// diameter) must be resolved.
const MIN_HEIGHTS: usize = 8;

/// The coefficient of variation (population standard deviation over mean) of the density
/// `density_kg_per_m3[i]` at heights `z_m[i]` within the central bed of a bed `bed_height_m`
/// high; None with fewer than 8 heights there, or a non-positive mean.
pub fn density_layering(z_m: &[f64], density_kg_per_m3: &[f64], bed_height_m: f64) -> Option<f64> {
    let (lo, hi) = (LAYERING_BED.0 * bed_height_m, LAYERING_BED.1 * bed_height_m);
    let central: Vec<f64> = z_m
        .iter()
        .zip(density_kg_per_m3)
        .filter(|(z, rho)| (lo..=hi).contains(*z) && rho.is_finite())
        .map(|(_, &rho)| rho)
        .collect();
    if central.len() < MIN_HEIGHTS {
        return None;
    }
    let n = central.len() as f64;
    let mean = central.iter().sum::<f64>() / n;
    if mean <= 0.0 {
        return None;
    }
    let variance = central.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / n;
    Some(variance.sqrt() / mean)
}

/// Whether a flow whose central density varies by `layering` is layered.
pub fn is_layered(layering: Option<f64>) -> bool {
    layering.is_some_and(|v| v > LAYERED_ABOVE)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A profile on a grid of L/8 up to H = 16 L (L = 1): mean 1500 with an oscillation of
    /// `amplitude` and period 0.87 L.
    fn profile(amplitude: f64) -> (Vec<f64>, Vec<f64>) {
        let z: Vec<f64> = (0..=128).map(|i| f64::from(i) / 8.0).collect();
        let period = 0.87;
        let rho = z
            .iter()
            .map(|z| 1500.0 + amplitude * (std::f64::consts::TAU * z / period).sin())
            .collect();
        (z, rho)
    }

    #[test]
    fn a_sinusoid_gives_its_amplitude_over_root_two() {
        for amplitude in [0.0, 15.0, 300.0] {
            let (z, rho) = profile(amplitude);
            let v = density_layering(&z, &rho, 16.0).expect("a verdict");
            let expected = amplitude / 2f64.sqrt() / 1500.0;
            // 52 samples over 7.4 periods: the sampled variance is within 5 % of the continuum's.
            assert!(
                (v - expected).abs() <= 0.05 * expected + 1e-12,
                "{amplitude}: {v}"
            );
        }
        assert!(!is_layered(density_layering(
            &profile(15.0).0,
            &profile(15.0).1,
            16.0
        )));
        assert!(is_layered(density_layering(
            &profile(300.0).0,
            &profile(300.0).1,
            16.0
        )));
    }

    #[test]
    fn only_the_central_bed_counts_and_too_few_heights_give_none() {
        let (z, mut rho) = profile(0.0);
        // Strong layering at the base only (below 0.3 H), as every bed has: not layered.
        for (zi, r) in z.iter().zip(rho.iter_mut()) {
            if *zi < 4.0 {
                *r += 600.0 * (std::f64::consts::TAU * zi / 0.87).sin();
            }
        }
        assert_eq!(density_layering(&z, &rho, 16.0), Some(0.0));
        let coarse: Vec<f64> = (0..=16).map(f64::from).collect();
        assert_eq!(density_layering(&coarse, &[1500.0; 17], 16.0), None);
        assert_eq!(density_layering(&[], &[], 16.0), None);
        assert!(!is_layered(None));
    }
}
