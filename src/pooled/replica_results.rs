//! One steady chute replica's results as claims read them (`observe::claims::CHUTE_RESULTS`):
//! per block ("D@k"), over the central bed (the mean of its blocks), and over the parts of the
//! bed where the paper sees the profiles part (the base, under the surface). The profiles of
//! Figs. 3–4 are normalised within the replica, by its own D_max and γ̇_max, as the paper
//! normalises each run, so the spread between replicas includes that of the maxima.

use std::collections::BTreeMap;

use crate::observe::claims::result_key;
use crate::store::chute_reads::BlockRow;

use super::chute::CENTRAL_BED;

/// The base, in bed heights: the paper's z ≲ 5 L of a 20 L bed, where D and γ̇ part.
pub const BASE_BED: f64 = 0.25;

/// The replica's results by key: every per-block result in its block, their means over the
/// central bed (0.3 H < z < 0.7 H), and the bed-part results (`CHUTE_BED_ONLY`).
pub fn chute_replica_results(
    rows: &[BlockRow],
    bed_height_m: f64,
    d_perp_m: f64,
) -> BTreeMap<String, f64> {
    let mut out = BTreeMap::new();
    let d2 = d_perp_m * d_perp_m;
    // The maxima come from the bed's full blocks: the dilute block the free surface cuts holds
    // a few particles whose shear rate can exceed the bed's and would shrink the whole profile.
    let full = full_blocks(rows, |r| r.solid_fraction);
    let d_max = positive_max(full.iter().filter_map(|r| r.diffusion_m2_per_s));
    let shear_max = positive_max(full.iter().map(|r| r.shear_rate_per_s));
    let mut bulk: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
    let mut gap_sq = (Vec::new(), Vec::new());
    for r in rows {
        let d = r.diffusion_m2_per_s;
        let shear = r.shear_rate_per_s;
        let d_norm = d.zip(d_max).map(|(d, m)| d / m);
        let shear_norm = shear_max.map(|m| shear / m);
        let gap = d_norm.zip(shear_norm).map(|(a, b)| a - b);
        let values = [
            ("D", d),
            ("shear_rate", Some(shear)),
            (
                "D_over_shear_rate",
                d.filter(|_| shear != 0.0).map(|d| d / shear),
            ),
            ("V_x", Some(r.velocity_x_m_per_s)),
            ("phi", Some(r.solid_fraction)),
            ("d_perp2", Some(d2)),
            ("shear_rate_d_perp2", Some(shear * d2)),
            ("vz_skewness", r.vz_skewness),
            ("correlation_length", r.correlation_length_m),
            ("D_norm", d_norm),
            ("shear_rate_norm", shear_norm),
            ("profile_gap", gap),
        ];
        let z = r.z_m / bed_height_m;
        let central = z > CENTRAL_BED.0 && z < CENTRAL_BED.1;
        for (name, v) in values {
            let Some(v) = v.filter(|x| x.is_finite()) else {
                continue;
            };
            out.insert(result_key(name, Some(r.block)), v);
            if central {
                bulk.entry(name).or_default().push(v);
            }
        }
        if let Some(g) = gap.filter(|g| g.is_finite()) {
            if central {
                gap_sq.0.push(g * g);
            } else if z < BASE_BED {
                gap_sq.1.push(g * g);
            }
        }
    }
    let mean = |v: &[f64]| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
    for (name, v) in &bulk {
        out.insert(name.to_string(), mean(v).expect("one value at least"));
    }
    let parts = [
        ("profile_gap_rms", mean(&gap_sq.0).map(f64::sqrt)),
        ("profile_gap_rms_base", mean(&gap_sq.1).map(f64::sqrt)),
        (
            "vz_skewness_base",
            base_block(rows).and_then(|r| r.vz_skewness),
        ),
        (
            "vz_skewness_surface",
            surface_block(rows).and_then(|r| r.vz_skewness),
        ),
    ];
    for (name, v) in parts {
        if let Some(v) = v {
            out.insert(name.to_string(), v);
        }
    }
    out
}

/// The largest finite positive value: a profile's maximum, which normalises it.
fn positive_max(v: impl Iterator<Item = f64>) -> Option<f64> {
    v.filter(|x| x.is_finite() && *x > 0.0).reduce(f64::max)
}

/// The lowest block: the paper's block next to the base of Fig. 5.
fn base_block(rows: &[BlockRow]) -> Option<&BlockRow> {
    rows.iter().min_by(|a, b| a.z_m.total_cmp(&b.z_m))
}

/// The full blocks: those whose solid fraction `phi` is at least half the densest block's, so
/// not the dilute block the free surface cuts. Claims and Figs. 3–4 take the maxima over them.
pub fn full_blocks<T>(rows: &[T], phi: impl Fn(&T) -> f64) -> Vec<&T> {
    let dense = rows
        .iter()
        .map(&phi)
        .filter(|x| x.is_finite())
        .fold(0.0, f64::max);
    rows.iter().filter(|r| phi(r) >= 0.5 * dense).collect()
}

/// The highest full block (the paper's block "close to the surface" of Fig. 5).
fn surface_block(rows: &[BlockRow]) -> Option<&BlockRow> {
    full_blocks(rows, |r| r.solid_fraction)
        .into_iter()
        .max_by(|a, b| a.z_m.total_cmp(&b.z_m))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observe::claims::{CHUTE_BED_ONLY, CHUTE_RESULTS};

    fn row(block: i64, z_m: f64, d: f64, shear: f64) -> BlockRow {
        BlockRow {
            block,
            z_m,
            diffusion_m2_per_s: Some(d),
            diffusion_stderr_m2_per_s: None,
            msd_fit_r: None,
            shear_rate_per_s: shear,
            velocity_x_m_per_s: 2.0 * z_m,
            solid_fraction: 0.55,
            vz_std_m_per_s: None,
            vz_skewness: Some(z_m),
            correlation_length_m: Some(0.1 * z_m),
            nematic_order: None,
            mean_abs_cos_flow: None,
            diffusion_y_m2_per_s: None,
            diffusion_y_stderr_m2_per_s: None,
        }
    }

    /// D peaks at block 0 (4), γ̇ at block 3 (8); blocks 1 and 2 lie in the central bed.
    fn four_blocks() -> [BlockRow; 4] {
        [
            row(0, 0.1, 4.0, 4.0),
            row(1, 0.4, 1.0, 2.0),
            row(2, 0.5, 2.0, 6.0),
            row(3, 0.9, 1.0, 8.0),
        ]
    }

    #[test]
    fn a_replica_gives_bulk_means_and_block_values() {
        // H = 1 m: blocks centred at 0.1, 0.3 and 0.9 m are outside the central bed (0.3 H,
        // 0.7 H).
        let rows = [
            row(0, 0.1, 9.0, 9.0),
            row(4, 0.3, 9.0, 9.0),
            row(1, 0.4, 1.0, 2.0),
            row(2, 0.5, 3.0, 2.0),
            row(3, 0.9, 9.0, 9.0),
        ];
        let v = chute_replica_results(&rows, 1.0, 0.1);
        assert_eq!(v["D"], 2.0);
        assert_eq!(v["shear_rate"], 2.0);
        assert_eq!(v["D_over_shear_rate"], 1.0);
        assert!((v["V_x"] - 0.9).abs() < 1e-12);
        assert!((v["d_perp2"] - 0.01).abs() < 1e-15);
        assert!((v["shear_rate_d_perp2"] - 0.02).abs() < 1e-15);
        assert_eq!(v["D@0"], 9.0);
        assert_eq!(v["D_over_shear_rate@2"], 1.5);
        assert!((v["vz_skewness"] - 0.45).abs() < 1e-12);
        assert!((v["correlation_length@3"] - 0.09).abs() < 1e-12);
        assert_eq!(v["vz_skewness_base"], 0.1);
        assert_eq!(v["vz_skewness_surface"], 0.9);
    }

    #[test]
    fn the_surface_block_is_the_highest_full_one() {
        let mut rows = vec![
            row(0, 0.1, 1.0, 1.0),
            row(1, 0.5, 1.0, 1.0),
            row(2, 0.9, 1.0, 1.0),
        ];
        rows[2].solid_fraction = 0.1;
        let v = chute_replica_results(&rows, 1.0, 0.1);
        assert_eq!(v["vz_skewness_surface"], 0.5);
        assert_eq!(v["vz_skewness_base"], 0.1);
    }

    #[test]
    fn profiles_are_normalised_by_the_replicas_own_maxima() {
        // D peaks at 4 and γ̇ at 8. Central blocks (z = 0.4, 0.5): D/D_max = 0.25, 0.5 and
        // γ̇/γ̇_max = 0.25, 0.75, so gaps 0 and −0.25; the base block (z = 0.1): 1 − 0.5.
        let v = chute_replica_results(&four_blocks(), 1.0, 0.1);
        assert_eq!(v["D_norm@0"], 1.0);
        assert_eq!(v["shear_rate_norm@3"], 1.0);
        assert_eq!(v["profile_gap@1"], 0.0);
        assert_eq!(v["profile_gap@2"], -0.25);
        assert_eq!(v["profile_gap"], -0.125);
        assert!((v["profile_gap_rms"] - (0.0625f64 / 2.0).sqrt()).abs() < 1e-15);
        assert_eq!(v["profile_gap_rms_base"], 0.5);
    }

    #[test]
    fn a_dilute_surface_block_does_not_set_the_maxima() {
        // The surface block (φ a tenth of the bed's) shears at 20, twice the bed's 8: the
        // profile is still normalised by the bed's maximum, as without that block.
        let mut rows = four_blocks().to_vec();
        let mut surface = row(4, 0.95, 9.0, 20.0);
        surface.solid_fraction = 0.055;
        rows.push(surface);
        let with = chute_replica_results(&rows, 1.0, 0.1);
        let without = chute_replica_results(&four_blocks(), 1.0, 0.1);
        for key in [
            "shear_rate_norm@3",
            "D_norm@0",
            "profile_gap_rms",
            "profile_gap_rms_base",
        ] {
            assert_eq!(with[key], without[key], "{key}");
        }
        assert_eq!(with["shear_rate_norm@4"], 2.5);
    }

    #[test]
    fn full_blocks_keep_half_the_densest_and_skip_an_unknown_density() {
        // φ per block; NaN (no replica measured it) neither sets the densest nor is full.
        let phi = [0.56, 0.55, 0.30, 0.27, f64::NAN, 0.02];
        let full: Vec<f64> = full_blocks(&phi, |p| *p).into_iter().copied().collect();
        assert_eq!(full, vec![0.56, 0.55, 0.30]);
    }

    #[test]
    fn every_result_claims_name_is_given() {
        let v = chute_replica_results(&four_blocks(), 1.0, 0.1);
        for name in CHUTE_RESULTS {
            assert!(v.contains_key(*name), "no bed value of {name}");
            if !CHUTE_BED_ONLY.contains(name) {
                assert!(
                    v.contains_key(&format!("{name}@1")),
                    "no block value of {name}"
                );
            }
        }
        for name in CHUTE_BED_ONLY {
            assert!(
                !v.contains_key(&format!("{name}@1")),
                "{name} has a block value"
            );
        }
    }
}
