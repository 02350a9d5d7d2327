//! The accuracy map's runs: each done job of an accuracy campaign with its settings, costs and
//! observable (silo Q, chute bulk D), the choice of the reference and the paper's setting among
//! them, and the small helpers the map's table uses.

use std::collections::HashMap;

use anyhow::Result;
use rusqlite::Connection;

use super::campaign::CampaignRef;
use crate::campaign::{point_key, JobSpec, Precision, SceneKind};
use crate::observe::fits::ReplicaEstimate;
use crate::store::accuracy_reads::accuracy_rows;
use crate::store::chute_reads::{bed_height, block_transport};
use crate::store::silo_reads;

/// One done job of the campaign, with its settings and costs.
pub(super) struct Run {
    pub(super) id: i64,
    pub(super) label: String,
    pub(super) spec: JobSpec,
    /// Its point: the setting it is a replica of.
    pub(super) point: String,
    pub(super) wall_s: f64,
    /// CPU seconds of its threads, where every part of it counted them.
    pub(super) cpu_s: Option<f64>,
    pub(super) particle_steps: f64,
    pub(super) dt_s: Option<f64>,
    pub(super) max_overlap: Option<f64>,
    /// The engine that ran it ("cpu" or "gpu").
    pub(super) backend: String,
    /// Mean kinetic energy over the measurement window (J) and its relative trend (1/s).
    pub(super) energy: Option<f64>,
    pub(super) drift: Option<f64>,
}

impl Run {
    pub(super) fn stiffness(&self) -> f64 {
        match self.spec.scene {
            SceneKind::Silo => self.spec.silo().youngs_modulus_pa,
            SceneKind::Chute => self.spec.chute().stiffness_factor,
        }
    }

    pub(super) fn contact_steps(&self) -> Option<f64> {
        match self.spec.scene {
            SceneKind::Silo => self.spec.silo().contact_steps,
            SceneKind::Chute => Some(self.spec.chute().contact_steps),
        }
    }

    /// The setting as the campaign wrote it (its label without the replica).
    pub(super) fn setting(&self) -> String {
        self.parts()
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// (key, value) of the label, without the replica, numbers written short (3e9, 50).
    pub(super) fn parts(&self) -> Vec<(String, String)> {
        split_label(&self.label)
            .into_iter()
            .filter_map(|p| p.split_once('='))
            .filter(|(k, _)| *k != "replica")
            .map(|(k, v)| (k.to_string(), short_number(v.trim_matches('"'))))
            .collect()
    }

    /// What differs from `reference`'s setting ("contact_steps=10"); "reference" for itself.
    pub(super) fn delta(&self, reference: &Run) -> String {
        let theirs = reference.parts();
        let diff: Vec<String> = self
            .parts()
            .into_iter()
            .filter(|kv| !theirs.contains(kv))
            .map(|(k, v)| format!("{k}={v}"))
            .collect();
        if diff.is_empty() {
            "as the reference".into()
        } else {
            diff.join(", ")
        }
    }
}

/// A label's `key=value` parts: split at commas outside brackets (`origin_m=[100.0,0.0,0.0]`).
pub(super) fn split_label(label: &str) -> Vec<&str> {
    let (mut out, mut depth, mut start) = (Vec::new(), 0i32, 0);
    for (i, c) in label.char_indices() {
        match c {
            '[' | '{' => depth += 1,
            ']' | '}' => depth -= 1,
            ',' if depth == 0 => {
                out.push(&label[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    out.push(&label[start..]);
    out
}

/// A number in a label written as 3e9, 1e5, 0.5 or 50.
pub(super) fn short_number(v: &str) -> String {
    match v.parse::<f64>() {
        Ok(x) if x != 0.0 && (x.abs() >= 1e4 || x.abs() < 1e-3) => {
            let e = x.abs().log10().floor();
            let m = x / 10f64.powf(e);
            let m = format!("{m:.2}");
            let m = m.trim_end_matches('0').trim_end_matches('.');
            format!("{m}e{e}")
        }
        Ok(x) => format!("{x}"),
        Err(_) => v.to_string(),
    }
}

pub(super) fn runs(conn: &Connection, campaign: &CampaignRef) -> Result<Vec<Run>> {
    let mut out = Vec::new();
    for row in accuracy_rows(conn, campaign.id)? {
        let spec: JobSpec = serde_json::from_str(&row.params_json)?;
        let wall_s = row.wall_time_s;
        out.push(Run {
            id: row.job_id,
            label: row.label,
            spec,
            point: point_key(&row.params_json),
            wall_s,
            cpu_s: row.cpu_time_s,
            particle_steps: row.particle_steps as f64,
            dt_s: row.dt_s,
            max_overlap: row.max_overlap_ratio,
            backend: row.backend,
            energy: row.mean_kinetic_j,
            drift: row.drift_per_s,
        });
    }
    Ok(out)
}

/// How far a run's observers are from the paper's (chute: w = L/4, sampled every 0.05 s; the
/// silo's discharge observer is not varied): 0 for the paper's.
pub(super) fn observer_distance(r: &Run) -> f64 {
    match &r.spec.observers.chute {
        Some(o) => {
            let paper = crate::observe::chute::ChuteObserverSettings::default();
            (o.cg_width_over_length / paper.cg_width_over_length)
                .ln()
                .abs()
                + (o.sample_interval_s / paper.sample_interval_s).ln().abs()
        }
        None => 0.0,
    }
}

/// A run's parameters without its observers (what fixes its trajectory).
pub(super) fn without_observers(r: &Run) -> String {
    let mut v = serde_json::to_value(&r.spec).expect("serializable");
    if let serde_json::Value::Object(m) = &mut v {
        m.remove("observers");
    }
    v.to_string()
}

/// How far the scene sits from the origin, m.
pub(super) fn offset(r: &Run) -> f64 {
    let o = r.spec.origin_m();
    (o[0] * o[0] + o[1] * o[1] + o[2] * o[2]).sqrt()
}

/// Index of the most accurate setting (each given by one of its runs): f64, then the stiffest,
/// then the smallest dt, then at the origin, then observed as the paper does.
pub(super) fn reference(runs: &[&Run]) -> Option<usize> {
    (0..runs.len()).max_by(|&a, &b| {
        let key = |r: &Run| {
            (
                r.spec.precision == Precision::F64,
                r.stiffness(),
                -r.dt_s.unwrap_or(f64::INFINITY),
                -offset(r),
                -observer_distance(r),
            )
        };
        let (ka, kb) = (key(runs[a]), key(runs[b]));
        ka.0.cmp(&kb.0)
            .then(ka.1.total_cmp(&kb.1))
            .then(ka.2.total_cmp(&kb.2))
            .then(ka.3.total_cmp(&kb.3))
            .then(ka.4.total_cmp(&kb.4))
            .then(b.cmp(&a))
    })
}

/// Index of the paper's setting (each given by one of its runs), if the campaign has one.
pub(super) fn paper(runs: &[&Run]) -> Option<usize> {
    let mut best: Option<(usize, f64)> = None;
    for (k, r) in runs.iter().enumerate() {
        if r.spec.precision != Precision::F64 || observer_distance(r) > 0.0 || offset(r) > 0.0 {
            continue;
        }
        let (paper_stiffness, paper_nc) = match r.spec.scene {
            SceneKind::Silo => {
                let p = r.spec.silo();
                let scene = crate::scene::SiloScene::new(p.clone()).ok();
                let tc = scene.map_or(0.0, |s| s.p.contact_time());
                (
                    crate::scene::SiloParams::default().youngs_modulus_pa,
                    tc / 1e-6,
                )
            }
            SceneKind::Chute => (crate::scene::ChuteParams::default().stiffness_factor, 50.0),
        };
        if r.stiffness() != paper_stiffness {
            continue;
        }
        let nc = match (r.contact_steps(), r.dt_s) {
            (Some(nc), _) => nc,
            (None, Some(dt)) => match r.spec.scene {
                SceneKind::Silo => paper_nc * 1e-6 / dt,
                SceneKind::Chute => paper_nc,
            },
            _ => continue,
        };
        let miss = (nc / paper_nc).ln().abs();
        if best.is_none_or(|(_, m)| miss < m) {
            best = Some((k, miss));
        }
    }
    best.map(|(k, _)| k)
}

/// Silo: each done job's Q as one replica's estimate (`DischargeRow::q_estimate`), by job id.
pub(super) fn q_estimates(
    conn: &Connection,
    campaign_id: i64,
) -> Result<HashMap<i64, ReplicaEstimate>> {
    Ok(silo_reads::done_discharge_rows(conn, campaign_id)?
        .iter()
        .filter_map(|r| Some((r.job_id, r.q_estimate()?)))
        .collect())
}

/// Chute: a job's bulk observables over its central blocks (0.2 H < z < 0.8 H).
pub(super) struct ChuteBulk {
    /// The mean of D_z over the blocks with its standard error √(Σ se²)/n (blocks taken as
    /// independent), dof = error windows − 1, weighted by the measurement time; None when a
    /// central block has D_z without an error.
    pub(super) diffusion: Option<ReplicaEstimate>,
    /// The mean of γ̇ over the blocks.
    pub(super) shear_rate: Option<f64>,
}

pub(super) fn chute_bulk(conn: &Connection, r: &Run) -> Result<ChuteBulk> {
    let h: f64 = bed_height(conn, r.id).unwrap_or(0.0);
    let central: Vec<_> = block_transport(conn, r.id)?
        .into_iter()
        .filter(|b| b.z_m > 0.2 * h && b.z_m < 0.8 * h)
        .collect();
    let shear_rate = (!central.is_empty())
        .then(|| central.iter().map(|b| b.shear_rate_per_s).sum::<f64>() / central.len() as f64);
    let measured: Vec<(f64, Option<f64>)> = central
        .iter()
        .filter_map(|b| Some((b.diffusion_m2_per_s?, b.diffusion_stderr_m2_per_s)))
        .collect();
    let windows = r
        .spec
        .observers
        .chute
        .as_ref()
        .map_or(
            crate::observe::chute::ChuteObserverSettings::default(),
            |o| o.clone(),
        )
        .msd_error_windows;
    let diffusion = if measured.is_empty() || measured.iter().any(|m| m.1.is_none()) {
        None
    } else {
        let n = measured.len() as f64;
        Some(ReplicaEstimate {
            mean: measured.iter().map(|m| m.0).sum::<f64>() / n,
            se: measured
                .iter()
                .map(|m| m.1.unwrap_or(0.0).powi(2))
                .sum::<f64>()
                .sqrt()
                / n,
            dof: f64::from(windows.max(2) - 1),
            weight: r.spec.chute().measure_time_s,
        })
    };
    Ok(ChuteBulk {
        diffusion,
        shear_rate,
    })
}

/// The mean of `f` over a setting's runs that have it.
pub(super) fn mean_over(
    runs: &[Run],
    setting: &[usize],
    f: impl Fn(&Run) -> Option<f64>,
) -> Option<f64> {
    let v: Vec<f64> = setting.iter().filter_map(|&k| f(&runs[k])).collect();
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// (a − b) / b, when both are known and b ≠ 0.
pub(super) fn rel_diff(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    match (a, b) {
        (Some(a), Some(b)) if b != 0.0 => Some((a - b) / b.abs()),
        _ => None,
    }
}

/// "3" or "1–3": how many replicas the settings pooled.
pub(super) fn replica_range(counts: impl Iterator<Item = usize>) -> String {
    let (lo, hi) = counts.fold((usize::MAX, 0), |(lo, hi), n| (lo.min(n), hi.max(n)));
    if lo > hi {
        "0".into()
    } else if lo == hi {
        lo.to_string()
    } else {
        format!("{lo}–{hi}")
    }
}

/// Settings an accuracy campaign varies: how the same physics is computed (and observed, any
/// `observers.*` key). A run differing in anything else is another experiment.
pub(super) const NUMERICAL_KEYS: [&str; 8] = [
    "contact_steps",
    "origin_m",
    "youngs_modulus_pa",
    "shear_modulus_pa",
    "stiffness_factor",
    "dt_s",
    "precision",
    "backend",
];

/// The keys of the runs' labels that take more than one value and are not numerical settings.
pub(super) fn physical_keys_that_vary(runs: &[Run]) -> Vec<String> {
    let parts: Vec<Vec<(String, String)>> = runs.iter().map(Run::parts).collect();
    let mut keys: Vec<String> = parts.iter().flatten().map(|(k, _)| k.clone()).collect();
    keys.sort();
    keys.dedup();
    keys.into_iter()
        .filter(|k| !NUMERICAL_KEYS.contains(&k.as_str()) && !k.starts_with("observers."))
        .filter(|k| {
            let value = |p: &Vec<(String, String)>| {
                p.iter().find(|(key, _)| key == k).map(|(_, v)| v.clone())
            };
            let first = parts.first().and_then(value);
            parts.iter().any(|p| value(p) != first)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    pub(super) fn labels_split_outside_brackets() {
        assert_eq!(
            split_label("contact_steps=50,origin_m=[100.0,0.0,0.0],precision=\"f32\",replica=1"),
            [
                "contact_steps=50",
                "origin_m=[100.0,0.0,0.0]",
                "precision=\"f32\"",
                "replica=1"
            ]
        );
    }

    #[test]
    pub(super) fn replica_counts_read_as_one_number_or_a_range() {
        assert_eq!(replica_range([4, 4].into_iter()), "4");
        assert_eq!(replica_range([1, 4, 3].into_iter()), "1–4");
        assert_eq!(replica_range(std::iter::empty()), "0");
    }
}
