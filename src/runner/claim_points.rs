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
use crate::observe::claims::{Estimate, PointData, SceneConstants};
use crate::observe::fits::mean_ci95;
use crate::observe::fits::t_975;
use crate::pooled::replica_results::chute_replica_results;
use crate::pooled::silo::gravity_m_per_s2;
use crate::store::chute_reads::{blocks, done_chute_jobs};

use super::evaluation::Evaluation;

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
            replicas_short: 0,
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
            field_results(conn, campaign_id, &pooled, &keys, &mut out)?;
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
                    per_replica.push(chute_replica_results(
                        &blocks(conn, j.job_id)?,
                        j.bed_height_m,
                        j.d_perp_m,
                    ));
                }
                if steady.len() < CHUTE_MIN_REPLICAS as usize {
                    p.replicas_short = CHUTE_MIN_REPLICAS - steady.len() as u32;
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

/// Each silo point's results from the fields observer, over its replicas with field sets:
/// ⟨p^k⟩ at the orifice (`kinetic_pressure`, Pa) as fig11 pools it, and the flow pattern's
/// `wall_to_axis_descent` (`pooled::flow_pattern`). Points without fields get neither.
fn field_results(
    conn: &Connection,
    campaign_id: i64,
    pooled: &[crate::pooled::silo::QPoint],
    keys: &[String],
    out: &mut [PointData],
) -> Result<()> {
    use crate::pooled::flow_pattern::{job_wall_to_axis, replicas_estimate, WALL_TO_AXIS_DESCENT};
    use crate::pooled::orifice_pressure::{point_pk, PkJob};
    use crate::store::fields::list_field_sets;
    let rows = crate::store::silo_reads::done_discharge_rows(conn, campaign_id)?;
    for (k, p) in keys.iter().zip(out.iter_mut()) {
        let Some((_, _, ids, _)) = pooled.iter().find(|(key, ..)| key == k) else {
            continue;
        };
        // Each replica's field sets, listed once for both results.
        let mut jobs = Vec::new();
        let mut ratios = Vec::new();
        for r in rows.iter().filter(|r| ids.contains(&r.job_id)) {
            let sets = list_field_sets(conn, r.job_id)?;
            jobs.push(PkJob::with_sets(r, &sets));
            let params: serde_json::Value = serde_json::from_str(&r.params_json)?;
            let radius = params["silo"]["cylinder_radius_m"]
                .as_f64()
                .unwrap_or(f64::NAN);
            if let Some(x) = job_wall_to_axis(conn, &sets, radius, r.particle_diameter_m)? {
                ratios.push(x);
            }
        }
        let refs: Vec<&PkJob> = jobs.iter().collect();
        if let (Some(pk), ..) = point_pk(conn, &refs)? {
            if let Some(se) = pk.se {
                p.results.insert(
                    "kinetic_pressure".into(),
                    Estimate {
                        mean: pk.mean,
                        se,
                        dof: pk.dof,
                    },
                );
            }
        }
        if let Some((mean, se, dof)) = replicas_estimate(&ratios) {
            p.results
                .insert(WALL_TO_AXIS_DESCENT.into(), Estimate { mean, se, dof });
        }
    }
    Ok(())
}
