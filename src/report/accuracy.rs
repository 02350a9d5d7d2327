//! The accuracy–cost map: for an accuracy campaign (one scene, settings that differ in numerical
//! choices: n_c = t_c/dt, stiffness, precision, where the scene sits, observers, …, each run as
//! one or more replicas), each setting's shift of its observable against the most accurate
//! setting, with a 95 % confidence interval, plotted against its measured cost. The reference is
//! the f64 setting with the largest stiffness and then the smallest dt (then at the origin,
//! observed as the paper does); the "paper" setting is the one at the paper's stiffness, f64,
//! with n_c closest to the paper's (silo: dt = 1 µs; chute: n_c = 50).
//!
//! A setting is a point of the campaign (`campaign::point_key`: all parameters but the replica
//! index); its replicas are pooled (`observe::fits::pool`), each bringing its own mean and
//! standard error: silo, Q with the error of its blocks (`DischargeRow::q_estimate`); chute, the
//! bulk diffusivity D, the mean of D_z over the central blocks (0.2 H < z < 0.8 H), with the
//! error from each block's `msd_error_windows` time windows (blocks taken as independent). The
//! shift is (mean − mean_ref)/mean_ref with Welch's interval (`report::accuracy_shift`): "within
//! noise" if it covers zero, "shifted" if not. A setting of one replica keeps its own block (or
//! window) interval; from three replicas on, their spread can widen it.
//!
//! Also tabled, without intervals: the relative difference of the replicas' mean kinetic energy
//! over the measurement window (and its trend, the drift, `job_energy`), the chute's bulk shear
//! rate, and the largest overlap.
//!
//! Settings may also differ only in how they are observed (coarse-graining width, sampling
//! interval): they follow the trajectories of their twin observed as the paper does (w = L/4,
//! every 0.05 s; the seed ignores observers), and are compared with that twin, so their shift is
//! the observer's alone (the table's `compared_with`; the interval, which treats the two as
//! independent, is then conservative). Among otherwise equal settings the reference is the one
//! observed as the paper does.

use std::collections::HashMap;
use std::fmt::Write as _;

use anyhow::{bail, Result};
use rusqlite::Connection;

use super::accuracy_shift::{shift, Shift};
use super::campaign::CampaignRef;
use super::drawn::{write_all, Drawn, Output};
use super::plot::{Axis, Figure, Legend, Panel, Series};
use super::table::{fixed, sci, Table};
use crate::campaign::{point_key, JobSpec, Precision, SceneKind};
use crate::observe::fits::{pool, Pooled, ReplicaEstimate};
use crate::store::accuracy_reads::accuracy_rows;
use crate::store::chute_reads::{bed_height, block_transport};
use crate::store::silo_reads;

/// One done job of the campaign, with its settings and costs.
struct Run {
    id: i64,
    label: String,
    spec: JobSpec,
    /// Its point: the setting it is a replica of.
    point: String,
    wall_s: f64,
    particle_steps: f64,
    dt_s: Option<f64>,
    max_overlap: Option<f64>,
    /// The engine that ran it ("cpu" or "gpu").
    backend: String,
    /// Mean kinetic energy over the measurement window (J) and its relative trend (1/s).
    energy: Option<f64>,
    drift: Option<f64>,
}

impl Run {
    fn stiffness(&self) -> f64 {
        match self.spec.scene {
            SceneKind::Silo => self.spec.silo().youngs_modulus_pa,
            SceneKind::Chute => self.spec.chute().stiffness_factor,
        }
    }

    fn contact_steps(&self) -> Option<f64> {
        match self.spec.scene {
            SceneKind::Silo => self.spec.silo().contact_steps,
            SceneKind::Chute => Some(self.spec.chute().contact_steps),
        }
    }

    /// The setting as the campaign wrote it (its label without the replica).
    fn setting(&self) -> String {
        self.parts()
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// (key, value) of the label, without the replica, numbers written short (3e9, 50).
    fn parts(&self) -> Vec<(String, String)> {
        split_label(&self.label)
            .into_iter()
            .filter_map(|p| p.split_once('='))
            .filter(|(k, _)| *k != "replica")
            .map(|(k, v)| (k.to_string(), short_number(v.trim_matches('"'))))
            .collect()
    }

    /// What differs from `reference`'s setting ("contact_steps=10"); "reference" for itself.
    fn delta(&self, reference: &Run) -> String {
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
fn split_label(label: &str) -> Vec<&str> {
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
fn short_number(v: &str) -> String {
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

fn runs(conn: &Connection, campaign: &CampaignRef) -> Result<Vec<Run>> {
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
fn observer_distance(r: &Run) -> f64 {
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
fn without_observers(r: &Run) -> String {
    let mut v = serde_json::to_value(&r.spec).expect("serializable");
    if let serde_json::Value::Object(m) = &mut v {
        m.remove("observers");
    }
    v.to_string()
}

/// How far the scene sits from the origin, m.
fn offset(r: &Run) -> f64 {
    let o = r.spec.origin_m();
    (o[0] * o[0] + o[1] * o[1] + o[2] * o[2]).sqrt()
}

/// Index of the most accurate setting (each given by one of its runs): f64, then the stiffest,
/// then the smallest dt, then at the origin, then observed as the paper does.
fn reference(runs: &[&Run]) -> Option<usize> {
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
fn paper(runs: &[&Run]) -> Option<usize> {
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
fn q_estimates(conn: &Connection, campaign_id: i64) -> Result<HashMap<i64, ReplicaEstimate>> {
    Ok(silo_reads::done_discharge_rows(conn, campaign_id)?
        .iter()
        .filter_map(|r| Some((r.job_id, r.q_estimate()?)))
        .collect())
}

/// Chute: a job's bulk observables over its central blocks (0.2 H < z < 0.8 H).
struct ChuteBulk {
    /// The mean of D_z over the blocks with its standard error √(Σ se²)/n (blocks taken as
    /// independent), dof = error windows − 1, weighted by the measurement time; None when a
    /// central block has D_z without an error.
    diffusion: Option<ReplicaEstimate>,
    /// The mean of γ̇ over the blocks.
    shear_rate: Option<f64>,
}

fn chute_bulk(conn: &Connection, r: &Run) -> Result<ChuteBulk> {
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
fn mean_over(runs: &[Run], setting: &[usize], f: impl Fn(&Run) -> Option<f64>) -> Option<f64> {
    let v: Vec<f64> = setting.iter().filter_map(|&k| f(&runs[k])).collect();
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// (a − b) / b, when both are known and b ≠ 0.
fn rel_diff(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    match (a, b) {
        (Some(a), Some(b)) if b != 0.0 => Some((a - b) / b.abs()),
        _ => None,
    }
}

/// "3" or "1–3": how many replicas the settings pooled.
fn replica_range(counts: impl Iterator<Item = usize>) -> String {
    let (lo, hi) = counts.fold((usize::MAX, 0), |(lo, hi), n| (lo.min(n), hi.max(n)));
    if lo > hi {
        "0".into()
    } else if lo == hi {
        lo.to_string()
    } else {
        format!("{lo}–{hi}")
    }
}

/// `sweep report --figure accuracy`: the map for the campaign's scene.
/// Settings an accuracy campaign varies: how the same physics is computed (and observed, any
/// `observers.*` key). A run differing in anything else is another experiment.
const NUMERICAL_KEYS: [&str; 8] = [
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
fn physical_keys_that_vary(runs: &[Run]) -> Vec<String> {
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

pub(crate) fn accuracy(
    conn: &Connection,
    campaign: &CampaignRef,
    out_dir: &Output,
) -> Result<Drawn> {
    let runs = runs(conn, campaign)?;
    let physical = physical_keys_that_vary(&runs);
    if !physical.is_empty() {
        bail!(
            "campaign '{}' sweeps {}: its runs differ in physics, not only in numerical \
             settings, so their differences are not errors; the accuracy map is drawn for \
             campaigns that vary {} only",
            campaign.name,
            physical.join(", "),
            NUMERICAL_KEYS.join(", ")
        )
    }
    // Settings: the campaign's points, each with its replicas (runs), by first job id.
    let mut settings: Vec<Vec<usize>> = Vec::new();
    for (k, r) in runs.iter().enumerate() {
        match settings.iter_mut().find(|s| runs[s[0]].point == r.point) {
            Some(s) => s.push(k),
            None => settings.push(vec![k]),
        }
    }
    let first: Vec<&Run> = settings.iter().map(|s| &runs[s[0]]).collect();
    let Some(r0) = reference(&first) else {
        bail!(
            "campaign '{}' has no done job: the accuracy map needs at least the reference run",
            campaign.name
        )
    };
    let paper_k = paper(&first);
    let chute = first[r0].spec.scene == SceneKind::Chute;
    let name = if chute { "D" } else { "Q" };
    // Each setting is compared with the reference, except an observer-only variant, which is
    // compared with its twin on the same trajectories (same parameters, the paper's
    // observers): its shift is then the observer's alone.
    let against: Vec<usize> = (0..first.len())
        .map(|k| {
            if observer_distance(first[k]) == 0.0 {
                return r0;
            }
            (0..first.len())
                .find(|&t| {
                    t != k
                        && observer_distance(first[t]) == 0.0
                        && without_observers(first[t]) == without_observers(first[k])
                })
                .unwrap_or(r0)
        })
        .collect();

    // Per run: its estimate of the observable (and the chute's bulk γ̇).
    let mut estimate: Vec<Option<ReplicaEstimate>> = Vec::with_capacity(runs.len());
    let mut shear: Vec<Option<f64>> = Vec::with_capacity(runs.len());
    if chute {
        for r in &runs {
            let b = chute_bulk(conn, r)?;
            estimate.push(b.diffusion);
            shear.push(b.shear_rate);
        }
    } else {
        let q = q_estimates(conn, campaign.id)?;
        estimate.extend(runs.iter().map(|r| q.get(&r.id).copied()));
        shear.resize(runs.len(), None);
    }
    let pooled: Vec<Option<Pooled>> = settings
        .iter()
        .map(|s| {
            let e: Vec<ReplicaEstimate> = s.iter().filter_map(|&k| estimate[k]).collect();
            pool(&e)
        })
        .collect();
    let shifts: Vec<Option<Shift>> = (0..settings.len())
        .map(|k| shift(pooled[k].as_ref()?, pooled[against[k]].as_ref()?))
        .collect();
    let pooled_count = |k: usize| pooled[k].map_or(0, |p| p.replicas);
    let wall = |k: usize| mean_over(&runs, &settings[k], |r| Some(r.wall_s));
    let energy = |k: usize| mean_over(&runs, &settings[k], |r| r.energy);
    let shear_of = |k: usize| {
        let v: Vec<f64> = settings[k].iter().filter_map(|&j| shear[j]).collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    let label_of = |k: usize| {
        let base = if k == r0 {
            "reference".to_string()
        } else {
            first[k].delta(first[r0])
        };
        let base = if Some(k) == paper_k && k != r0 {
            format!("paper: {base}")
        } else {
            base
        };
        format!("{base} (n={})", pooled_count(k))
    };
    let replicas = replica_range((0..settings.len()).map(pooled_count));

    let mut text = String::new();
    let _ = writeln!(
        text,
        "{} done job(s) in {} setting(s); reference (most accurate): setting {} [{}]; paper \
         setting: {}",
        runs.len(),
        settings.len(),
        r0 + 1,
        first[r0].setting(),
        paper_k.map_or("not in this campaign".to_string(), |k| format!(
            "setting {} [{}]",
            k + 1,
            first[k].setting()
        ))
    );
    let _ = writeln!(
        text,
        "replicas pooled per setting: {replicas} (reference: {}); shift = ({name} − {name}_ref) / \
         {name}_ref with its 95 % CI (Welch): within noise when the CI covers 0",
        pooled_count(r0)
    );
    if let Some(p) = pooled[r0] {
        let _ = writeln!(
            text,
            "the reference's own 95 % CI: {:.2} % of {name} (from {})",
            100.0 * p.ci95_rel(),
            p.from.name()
        );
    }
    let mut headers = vec![
        "setting".to_string(),
        "jobs".into(),
        "parameters".into(),
        "differs_from_reference".into(),
        "precision".into(),
        "backend".into(),
        "dt_s".into(),
        "replicas".into(),
        "reference_replicas".into(),
        "wall_s_per_replica".into(),
        "particle_steps_per_replica".into(),
        "max_overlap_d".into(),
        "kinetic_drift_per_s".into(),
        "kinetic_energy_diff".into(),
    ];
    if chute {
        headers.push("shear_rate_diff".into());
    }
    headers.extend([
        "compared_with".to_string(),
        format!("shift_{name}_pct"),
        format!("ci95_{name}_pct"),
        "ci_from".into(),
        "verdict".into(),
    ]);
    let mut table = Table::new(&headers);
    for (k, s) in settings.iter().enumerate() {
        let r = first[k];
        let jobs: Vec<String> = s.iter().map(|&j| runs[j].id.to_string()).collect();
        let overlap = s
            .iter()
            .filter_map(|&j| runs[j].max_overlap)
            .fold(None, |m: Option<f64>, o| Some(m.map_or(o, |m| m.max(o))));
        let mut row = vec![
            (k + 1).to_string(),
            jobs.join(" "),
            r.setting(),
            if k == r0 {
                "reference".into()
            } else {
                r.delta(first[r0])
            },
            r.spec.precision.name().to_string(),
            r.backend.clone(),
            sci(r.dt_s, 3),
            pooled_count(k).to_string(),
            pooled_count(against[k]).to_string(),
            fixed(wall(k), 1),
            sci(mean_over(&runs, s, |r| Some(r.particle_steps)), 3),
            sci(overlap, 3),
            sci(mean_over(&runs, s, |r| r.drift), 3),
            if k == r0 {
                "reference".into()
            } else {
                sci(rel_diff(energy(k), energy(against[k])), 3)
            },
        ];
        if chute {
            row.push(if k == r0 {
                "reference".into()
            } else {
                sci(rel_diff(shear_of(k), shear_of(against[k])), 3)
            });
        }
        row.push((against[k] + 1).to_string());
        if k == r0 {
            // Its own interval, for scale.
            row.push("reference".into());
            row.push(fixed(pooled[k].map(|p| 100.0 * p.ci95_rel()), 2));
            row.push(pooled[k].map_or("-".into(), |p| p.from.name().to_string()));
            row.push("reference".into());
        } else {
            row.push(fixed(shifts[k].map(|x| 100.0 * x.rel), 2));
            row.push(fixed(shifts[k].map(|x| 100.0 * x.ci95_rel), 2));
            row.push(pooled[k].map_or("-".into(), |p| p.from.name().to_string()));
            row.push(shifts[k].map_or("-".into(), |x| x.verdict().to_string()));
        }
        table.push(row);
    }
    text.push_str(&table.to_text());

    let (lo, hi) = (0..settings.len())
        .filter_map(wall)
        .fold((f64::INFINITY, 0.0f64), |(a, b), w| (a.min(w), b.max(w)));
    let mut p = Panel::new(
        Axis::log("wall time per replica (s)"),
        Axis::linear(format!("shift of {name} against the reference (%)")),
    );
    p.title = Some(format!("{name}: shift ± 95 % CI vs cost"));
    p.notes = vec![
        format!(
            "n = replicas pooled ({replicas} per setting; reference: {})",
            pooled_count(r0)
        ),
        "within noise: the CI covers 0".into(),
        "reference: its own 95 % CI at 0".into(),
    ];
    for k in 0..settings.len() {
        let Some(w) = wall(k) else { continue };
        let (y, err) = if k == r0 {
            match pooled[k] {
                Some(q) => (0.0, q.ci95_rel()),
                None => continue,
            }
        } else {
            match shifts[k] {
                Some(x) => (x.rel, x.ci95_rel),
                None => continue,
            }
        };
        let err = Some(100.0 * err).filter(|e| e.is_finite());
        p.series.push(
            Series::points(Some(label_of(k)), k % 10, vec![w], vec![100.0 * y])
                .with_errors(vec![err]),
        );
    }
    if lo <= hi {
        p.series
            .push(Series::line(None, 7, vec![lo, hi], vec![0.0, 0.0]));
    }
    let mut ov = Panel::new(
        Axis::log("wall time per replica (s)"),
        Axis::log("largest overlap / d"),
    );
    ov.title = Some("largest overlap (over replicas) vs cost".into());
    ov.legend = Legend::Hidden;
    for (k, s) in settings.iter().enumerate() {
        let overlap = s
            .iter()
            .filter_map(|&j| runs[j].max_overlap)
            .reduce(f64::max);
        if let (Some(o), Some(w)) = (overlap, wall(k)) {
            ov.series
                .push(Series::points(Some(label_of(k)), k % 10, vec![w], vec![o]));
        }
    }
    let panels = vec![p, ov];
    let fig = Figure {
        title: Some(format!(
            "Accuracy vs cost, campaign {}: shift of {name} against setting {} (replicas per \
             setting: {replicas}; reference: {})",
            campaign.name,
            r0 + 1,
            pooled_count(r0)
        )),
        columns: 1,
        panels,
        panel_size: (1300, 560),
    };
    let stem = format!("{}_accuracy", campaign.scene);
    let files = write_all(&fig, &table, out_dir, &stem)?;
    Ok(Drawn { text, files })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_split_outside_brackets() {
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
    fn replica_counts_read_as_one_number_or_a_range() {
        assert_eq!(replica_range([4, 4].into_iter()), "4");
        assert_eq!(replica_range([1, 4, 3].into_iter()), "1–4");
        assert_eq!(replica_range(std::iter::empty()), "0");
    }
}
