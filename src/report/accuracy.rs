//! The accuracy–cost map: for an accuracy campaign (one scene, jobs that differ in numerical
//! settings: n_c = t_c/dt, stiffness, precision, …), each job's error on the observables against
//! the most accurate job, plotted against its measured wall time. The reference is the f64 job
//! with the largest stiffness and then the smallest dt; the "paper" job is the one at the paper's
//! stiffness, f64, with n_c closest to the paper's (silo: dt = 1 µs; chute: n_c = 50).
//!
//! Errors: silo, |Q − Q_ref| / Q_ref; chute, the rms over the central blocks (0.2 H < z < 0.8 H)
//! of (D − D_ref) / ⟨D_ref⟩ and of (γ̇ − γ̇_ref) / ⟨γ̇_ref⟩, blocks matched by index; both scenes,
//! |⟨E_k⟩ − ⟨E_k⟩_ref| / ⟨E_k⟩_ref of the kinetic energy over the measurement window, whose
//! trend (the energy drift, `job_energy`) is tabled. The reference's own 95 % confidence
//! half-width (silo) is drawn as the noise floor: an error below it is not resolved by the run
//! length.
//!
//! Jobs may also differ only in how they are observed (coarse-graining width, sampling
//! interval): they follow the trajectory of their twin observed as the paper does (w = L/4,
//! every 0.05 s; the seed ignores observers), and are compared with that twin, so their error is
//! the observer's alone (the table's `compared_with_job`). Among otherwise equal runs the
//! reference is the one observed as the paper does.

use std::fmt::Write as _;

use anyhow::{bail, Result};
use rusqlite::Connection;

use super::campaign::CampaignRef;
use super::drawn::{write_all, Drawn, Output};
use super::plot::{Axis, Figure, Legend, Panel, Series};
use super::table::{sci, Table};
use crate::campaign::{JobSpec, Precision, SceneKind};
use crate::store::accuracy_reads::accuracy_rows;
use crate::store::chute_reads::{bed_height, block_transport};
use crate::store::silo_reads;

/// One done job of the campaign, with its settings and costs.
struct Run {
    id: i64,
    label: String,
    spec: JobSpec,
    wall_s: f64,
    rate: f64,
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
        self.label
            .split(',')
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
            wall_s,
            rate: row.particle_steps as f64 / wall_s.max(1e-9),
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

/// Index of the most accurate run: f64, then the stiffest, then the smallest dt, then observed
/// as the paper does.
fn reference(runs: &[Run]) -> Option<usize> {
    (0..runs.len()).max_by(|&a, &b| {
        let key = |r: &Run| {
            (
                r.spec.precision == Precision::F64,
                r.stiffness(),
                -r.dt_s.unwrap_or(f64::INFINITY),
                -observer_distance(r),
            )
        };
        let (ka, kb) = (key(&runs[a]), key(&runs[b]));
        ka.0.cmp(&kb.0)
            .then(ka.1.total_cmp(&kb.1))
            .then(ka.2.total_cmp(&kb.2))
            .then(ka.3.total_cmp(&kb.3))
            .then(b.cmp(&a))
    })
}

/// Index of the run at the paper's setting, if the campaign has one.
fn paper(runs: &[Run]) -> Option<usize> {
    let mut best: Option<(usize, f64)> = None;
    for (k, r) in runs.iter().enumerate() {
        if r.spec.precision != Precision::F64 || observer_distance(r) > 0.0 {
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

/// Silo: (Q, CI) of a job.
fn flow_rate(conn: &Connection, job: i64) -> Result<Option<(f64, f64)>> {
    Ok(match silo_reads::flow_rate(conn, job) {
        Ok(silo_reads::FlowRate {
            q_kg_per_s: Some(q),
            q_ci95_kg_per_s: ci,
        }) => Some((q, ci.unwrap_or(f64::NAN))),
        _ => None,
    })
}

/// Chute: per block (D, γ̇) in the central bed of a job.
fn profiles(conn: &Connection, job: i64) -> Result<Vec<(u32, Option<f64>, f64)>> {
    let h: f64 = bed_height(conn, job).unwrap_or(0.0);
    let mut out = Vec::new();
    for b in block_transport(conn, job)? {
        if b.z_m > 0.2 * h && b.z_m < 0.8 * h {
            out.push((b.block, b.diffusion_m2_per_s, b.shear_rate_per_s));
        }
    }
    Ok(out)
}

/// rms over common blocks of (x − x_ref) / mean(x_ref).
fn profile_error(
    run: &[(u32, Option<f64>, f64)],
    reference: &[(u32, Option<f64>, f64)],
    pick: impl Fn(&(u32, Option<f64>, f64)) -> Option<f64>,
) -> Option<f64> {
    let pairs: Vec<(f64, f64)> = reference
        .iter()
        .filter_map(|r| {
            let x = run.iter().find(|q| q.0 == r.0)?;
            Some((pick(x)?, pick(r)?))
        })
        .collect();
    if pairs.is_empty() {
        return None;
    }
    let scale = pairs.iter().map(|p| p.1).sum::<f64>() / pairs.len() as f64;
    if scale == 0.0 {
        return None;
    }
    let ms = pairs
        .iter()
        .map(|p| ((p.0 - p.1) / scale).powi(2))
        .sum::<f64>()
        / pairs.len() as f64;
    Some(ms.sqrt())
}

/// `sweep report --figure accuracy`: the map for the campaign's scene.
/// Settings an accuracy campaign varies: how the same physics is computed (and observed, any
/// `observers.*` key). A run differing in anything else is another experiment.
const NUMERICAL_KEYS: [&str; 7] = [
    "contact_steps",
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
    let Some(r0) = reference(&runs) else {
        bail!(
            "campaign '{}' has no done job: the accuracy map needs at least the reference run",
            campaign.name
        )
    };
    let paper_k = paper(&runs);
    let chute = runs[r0].spec.scene == SceneKind::Chute;
    let names: Vec<&str> = if chute {
        vec!["D(z)", "shear rate(z)", "kinetic energy"]
    } else {
        vec!["Q", "kinetic energy"]
    };
    // Each run is compared with the reference, except an observer-only variant, which is
    // compared with its twin on the same trajectory (same parameters, the paper's observers):
    // its error is then the observer's alone, not the trajectory's.
    let against: Vec<usize> = (0..runs.len())
        .map(|k| {
            if observer_distance(&runs[k]) == 0.0 {
                return r0;
            }
            (0..runs.len())
                .find(|&t| {
                    t != k
                        && observer_distance(&runs[t]) == 0.0
                        && without_observers(&runs[t]) == without_observers(&runs[k])
                })
                .unwrap_or(r0)
        })
        .collect();
    let energy_error = |k: usize| match (runs[k].energy, runs[against[k]].energy) {
        (Some(e), Some(e0)) if e0 > 0.0 => Some((e - e0).abs() / e0),
        _ => None,
    };
    // errors[k][m]: run k, observable m.
    let mut errors: Vec<Vec<Option<f64>>> = Vec::new();
    let mut floor: Option<f64> = None;
    if chute {
        for (k, r) in runs.iter().enumerate() {
            let p = profiles(conn, r.id)?;
            let p_ref = profiles(conn, runs[against[k]].id)?;
            errors.push(vec![
                profile_error(&p, &p_ref, |x| x.1),
                profile_error(&p, &p_ref, |x| Some(x.2)),
                energy_error(k),
            ]);
        }
    } else {
        let q_ref = flow_rate(conn, runs[r0].id)?;
        floor = q_ref.map(|(q, ci)| ci / q).filter(|f| f.is_finite());
        for (k, r) in runs.iter().enumerate() {
            let e = match (
                flow_rate(conn, r.id)?,
                flow_rate(conn, runs[against[k]].id)?,
            ) {
                (Some((q, _)), Some((qr, _))) if qr != 0.0 => Some((q - qr).abs() / qr),
                _ => None,
            };
            errors.push(vec![e, energy_error(k)]);
        }
    }

    let mut text = String::new();
    let _ = writeln!(
        text,
        "{} done job(s); reference (most accurate): job {} [{}]; paper setting: {}",
        runs.len(),
        runs[r0].id,
        runs[r0].setting(),
        paper_k.map_or("not in this campaign".to_string(), |k| format!(
            "job {} [{}]",
            runs[k].id,
            runs[k].setting()
        ))
    );
    if let Some(f) = floor {
        let _ = writeln!(
            text,
            "noise floor: the reference's own 95 % CI is {:.1} % of Q",
            100.0 * f
        );
    }
    let mut headers = vec![
        "job".to_string(),
        "setting".into(),
        "precision".into(),
        "backend".into(),
        "dt_s".into(),
        "wall_s".into(),
        "particle_steps_per_s".into(),
        "max_overlap_d".into(),
        "kinetic_drift_per_s".into(),
        "compared_with_job".into(),
    ];
    for n in &names {
        headers.push(format!("error_{n}"));
    }
    let mut table = Table::new(&headers);
    for (k, r) in runs.iter().enumerate() {
        let mut row = vec![
            r.id.to_string(),
            r.setting(),
            r.spec.precision.name().to_string(),
            r.backend.clone(),
            sci(r.dt_s, 3),
            format!("{:.1}", r.wall_s),
            sci(Some(r.rate), 3),
            sci(r.max_overlap, 3),
            sci(r.drift, 3),
            runs[against[k]].id.to_string(),
        ];
        for e in &errors[k] {
            row.push(if k == r0 {
                "reference".into()
            } else {
                sci(*e, 3)
            });
        }
        table.push(row);
    }
    text.push_str(&table.to_text());

    let mut panels = Vec::new();
    for (m, name) in names.iter().enumerate() {
        let mut p = Panel::new(
            Axis::log("wall time (s)"),
            Axis::log(format!("relative error of {name}")),
        );
        // Colours as in the overlap panel's legend (one per job); the grey line is the noise floor.
        p.title = Some(format!(
            "{name}: error vs cost (grey line: reference's 95 % CI)"
        ));
        p.legend = Legend::Hidden;
        for (k, r) in runs.iter().enumerate() {
            if k == r0 {
                continue;
            }
            if let Some(e) = errors[k][m] {
                let label = if Some(k) == paper_k {
                    format!("paper: {}", r.delta(&runs[r0]))
                } else {
                    r.delta(&runs[r0])
                };
                p.series
                    .push(Series::points(Some(label), k % 10, vec![r.wall_s], vec![e]));
            }
        }
        if let Some(f) = floor {
            let (lo, hi) = runs.iter().fold((f64::INFINITY, 0.0f64), |(a, b), r| {
                (a.min(r.wall_s), b.max(r.wall_s))
            });
            p.series.push(Series::line(
                Some("reference 95 % CI (noise floor)".into()),
                7,
                vec![lo, hi],
                vec![f, f],
            ));
        }
        panels.push(p);
    }
    let mut ov = Panel::new(Axis::log("wall time (s)"), Axis::log("largest overlap / d"));
    ov.title = Some("largest overlap vs cost".into());
    ov.legend = Legend::Outside;
    for (k, r) in runs.iter().enumerate() {
        if let Some(o) = r.max_overlap {
            let label = if k == r0 {
                "reference".to_string()
            } else {
                r.delta(&runs[r0])
            };
            ov.series
                .push(Series::points(Some(label), k % 10, vec![r.wall_s], vec![o]));
        }
    }
    panels.push(ov);
    let fig = Figure {
        title: Some(format!(
            "Accuracy vs cost, campaign {} (reference: job {})",
            campaign.name, runs[r0].id
        )),
        columns: panels.len(),
        panels,
        panel_size: (720, 560),
    };
    let stem = format!("{}_accuracy", campaign.scene);
    let files = write_all(&fig, &table, out_dir, &stem)?;
    Ok(Drawn { text, files })
}
