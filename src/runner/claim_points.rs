//! A campaign's points as its claims read them: each point's parameters and its pooled
//! results, read from the store exactly as the figures pool them. Silo: Q over replicas and
//! blocks (`pooled::silo`). Chute: every result is the mean over at least
//! [`CHUTE_MIN_REPLICAS`] steady replicas with the Student-t error of their spread, so the
//! interval includes the scatter between realisations.

use std::collections::BTreeMap;

use anyhow::Result;
use rusqlite::Connection;

use crate::campaign::claims::CHUTE_MIN_REPLICAS;
use crate::campaign::{point_key, point_params, SceneKind};
use crate::observe::claims::{result_key, Estimate, PointData, SceneConstants};
use crate::observe::fits::mean_ci95;
use crate::observe::fits::t_975;
use crate::pooled::chute::CENTRAL_BED;
use crate::pooled::silo::gravity_m_per_s2;
use crate::store::chute_reads::{blocks, done_chute_jobs, BlockRow};

use super::adaptive::Evaluation;

/// The points of `ev` (in its order) with their results, and the silo's constants (particle
/// diameter, bulk density, gravity) for the fits that need them.
///
/// # Errors
/// Database errors.
pub fn claim_points(
    conn: &Connection,
    campaign_id: i64,
    ev: &Evaluation,
) -> Result<(Vec<PointData>, Option<SceneConstants>)> {
    let mut out: Vec<PointData> = ev
        .points
        .iter()
        .map(|p| PointData {
            label: p.row.point.clone(),
            params: point_params(&p.next.resolved_json()),
            results: BTreeMap::new(),
            missing: None,
            clogged: false,
            particle_steps: p.row.particle_steps as f64,
        })
        .collect();
    let keys: Vec<String> = ev
        .points
        .iter()
        .map(|p| point_key(&p.next.resolved_json()))
        .collect();
    let mut constants = None;
    match ev.file.scene {
        SceneKind::Silo => {
            let pooled = crate::pooled::silo::pooled_q_points(conn, campaign_id)?;
            for (k, p) in keys.iter().zip(out.iter_mut()) {
                let found = pooled.iter().find(|(key, ..)| key == k);
                match found.and_then(|(_, _, _, fp)| fp.as_ref()) {
                    Some(fp) => match (fp.se, fp.ci) {
                        (Some(se), Some(_)) => {
                            p.results.insert(
                                "q".into(),
                                Estimate {
                                    mean: fp.q,
                                    se,
                                    dof: fp.dof,
                                },
                            );
                            if constants.is_none() {
                                let g = gravity_m_per_s2(&ev.points[0].next.resolved_json());
                                constants = Some(SceneConstants {
                                    particle_diameter_m: fp.particle_d_m,
                                    bulk_density_kg_per_m3: fp.bulk_density_kg_per_m3,
                                    gravity_m_per_s2: g.unwrap_or(9.81),
                                });
                            }
                        }
                        _ => p.missing = Some("Q has no interval (one block)".into()),
                    },
                    None if found.is_some() => {
                        p.missing = Some("every run clogged before Q could be measured".into());
                        p.clogged = true;
                    }
                    None => p.missing = Some("not run yet".into()),
                }
            }
        }
        SceneKind::Chute => {
            let jobs = done_chute_jobs(conn, campaign_id, false)?;
            for (k, p) in keys.iter().zip(out.iter_mut()) {
                let steady: Vec<_> = jobs
                    .iter()
                    .filter(|j| j.steady && point_key(&j.params_json) == *k)
                    .collect();
                let mut per_replica: Vec<BTreeMap<String, f64>> = Vec::new();
                for j in &steady {
                    per_replica.push(chute_values(
                        &blocks(conn, j.job_id)?,
                        j.bed_height_m,
                        j.d_perp_m,
                    ));
                }
                if steady.len() < CHUTE_MIN_REPLICAS as usize {
                    p.missing = Some(format!(
                        "{} of {CHUTE_MIN_REPLICAS} steady replicas",
                        steady.len()
                    ));
                    continue;
                }
                let mut names: Vec<&String> = per_replica.iter().flat_map(|m| m.keys()).collect();
                names.sort();
                names.dedup();
                for name in names {
                    let v: Vec<f64> = per_replica
                        .iter()
                        .filter_map(|m| m.get(name).copied())
                        .collect();
                    if v.len() < CHUTE_MIN_REPLICAS as usize {
                        continue;
                    }
                    if let Some((mean, hw)) = mean_ci95(&v) {
                        let dof = (v.len() - 1) as f64;
                        p.results.insert(
                            name.clone(),
                            Estimate {
                                mean,
                                se: hw / t_975(dof),
                                dof,
                            },
                        );
                    }
                }
            }
        }
    }
    Ok((out, constants))
}

/// One steady chute replica's results: over the central bed (blocks centred in 0.3 H < z < 0.7 H,
/// the paper's 6 L < z < 14 L, averaged) and per block ("D@k").
fn chute_values(rows: &[BlockRow], bed_height_m: f64, d_perp_m: f64) -> BTreeMap<String, f64> {
    let mut out = BTreeMap::new();
    let d2 = d_perp_m * d_perp_m;
    let mut bulk: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
    for r in rows {
        let ratio = r
            .diffusion_m2_per_s
            .filter(|_| r.shear_rate_per_s != 0.0)
            .map(|d| d / r.shear_rate_per_s);
        let values = [
            ("D", r.diffusion_m2_per_s),
            ("shear_rate", Some(r.shear_rate_per_s)),
            ("D_over_shear_rate", ratio),
            ("V_x", Some(r.velocity_x_m_per_s)),
            ("phi", Some(r.solid_fraction)),
            ("d_perp2", Some(d2)),
            ("shear_rate_d_perp2", Some(r.shear_rate_per_s * d2)),
        ];
        let in_bulk = r.z_m > CENTRAL_BED.0 * bed_height_m && r.z_m < CENTRAL_BED.1 * bed_height_m;
        for (name, v) in values {
            let Some(v) = v.filter(|x| x.is_finite()) else {
                continue;
            };
            out.insert(result_key(name, Some(r.block)), v);
            if in_bulk {
                bulk.entry(name).or_default().push(v);
            }
        }
    }
    for (name, v) in bulk {
        out.insert(name.to_string(), v.iter().sum::<f64>() / v.len() as f64);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

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
            vz_skewness: None,
            correlation_length_m: None,
        }
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
        let v = chute_values(&rows, 1.0, 0.1);
        assert_eq!(v["D"], 2.0);
        assert_eq!(v["shear_rate"], 2.0);
        assert_eq!(v["D_over_shear_rate"], 1.0);
        assert!((v["V_x"] - 0.9).abs() < 1e-12);
        assert!((v["d_perp2"] - 0.01).abs() < 1e-15);
        assert!((v["shear_rate_d_perp2"] - 0.02).abs() < 1e-15);
        assert_eq!(v["D@0"], 9.0);
        assert_eq!(v["D_over_shear_rate@2"], 1.5);
    }
}
