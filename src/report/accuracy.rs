//! The accuracy–cost map: for an accuracy campaign (one scene, settings that differ in numerical
//! choices: n_c = t_c/dt, stiffness, precision, where the scene sits, observers, …, each run as
//! one or more replicas), each setting's shift of its observable against the most accurate
//! setting, with a 95 % confidence interval, plotted against its measured cost (the CPU time per
//! replica where every job counted it, else the wall time). The reference is
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

use std::fmt::Write as _;

use anyhow::{bail, Result};
use rusqlite::Connection;

use super::accuracy_runs::*;
use super::accuracy_shift::{shift, Shift};
use super::campaign::CampaignRef;
use super::drawn::{write_all, Drawn, Output};
use super::plot::{Axis, Figure, Legend, Panel, Series};
use super::table::{fixed, sci, Table};
use crate::campaign::SceneKind;
use crate::observe::fits::{pool, Pooled, ReplicaEstimate};

/// `sweep report --figure accuracy`: the map for the campaign's scene.
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
    let map = Map::of(conn, campaign, &runs)?;
    let mut text = map.summary();
    let table = map.table();
    text.push_str(&table.to_text());
    let fig = map.figure(&campaign.name);
    let stem = format!("{}_accuracy", campaign.scene);
    let files = write_all(&fig, &table, out_dir, &stem)?;
    Ok(Drawn { text, files })
}

/// The campaign's settings, each pooled over its replicas and compared with the reference (or
/// an observer-only variant with its twin).
struct Map<'a> {
    runs: &'a [Run],
    /// Each setting's runs (indices into `runs`), by first job id.
    settings: Vec<Vec<usize>>,
    /// Each setting's first run.
    first: Vec<&'a Run>,
    /// The reference setting, and the paper's.
    r0: usize,
    paper_k: Option<usize>,
    chute: bool,
    /// The observable: "D" (chute) or "Q" (silo).
    name: &'static str,
    /// The setting each is compared with.
    against: Vec<usize>,
    pooled: Vec<Option<Pooled>>,
    shifts: Vec<Option<Shift>>,
    /// Per run: the chute's bulk γ̇.
    shear: Vec<Option<f64>>,
}

impl<'a> Map<'a> {
    fn of(conn: &Connection, campaign: &CampaignRef, runs: &'a [Run]) -> Result<Self> {
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
        let chute = first[r0].spec.scene == SceneKind::Chute;
        let against = compared_with(&first, r0);
        // Per run: its estimate of the observable (and the chute's bulk γ̇).
        let mut estimate: Vec<Option<ReplicaEstimate>> = Vec::with_capacity(runs.len());
        let mut shear: Vec<Option<f64>> = Vec::with_capacity(runs.len());
        if chute {
            for r in runs {
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
        let shifts = (0..settings.len())
            .map(|k| shift(pooled[k].as_ref()?, pooled[against[k]].as_ref()?))
            .collect();
        Ok(Map {
            runs,
            paper_k: paper(&first),
            settings,
            first,
            r0,
            chute,
            name: if chute { "D" } else { "Q" },
            against,
            pooled,
            shifts,
            shear,
        })
    }

    fn pooled_count(&self, k: usize) -> usize {
        self.pooled[k].map_or(0, |p| p.replicas)
    }

    fn wall(&self, k: usize) -> Option<f64> {
        mean_over(self.runs, &self.settings[k], |r| Some(r.wall_s))
    }

    /// The mean CPU time of the setting's replicas, if each of them counted it.
    fn cpu(&self, k: usize) -> Option<f64> {
        let s = &self.settings[k];
        s.iter()
            .all(|&j| self.runs[j].cpu_s.is_some())
            .then(|| mean_over(self.runs, s, |r| r.cpu_s))
            .flatten()
    }

    /// The map's cost per replica and its axis: the CPU time where every job counted it (what
    /// the setting costs whatever else shared the cores), else the wall time.
    fn cost(&self, k: usize) -> Option<f64> {
        if self.cpu_counted() {
            self.cpu(k)
        } else {
            self.wall(k)
        }
    }

    fn cpu_counted(&self) -> bool {
        self.runs.iter().all(|r| r.cpu_s.is_some())
    }

    fn cost_axis(&self) -> &'static str {
        if self.cpu_counted() {
            "CPU time per replica (s)"
        } else {
            "wall time per replica (s)"
        }
    }

    fn energy(&self, k: usize) -> Option<f64> {
        mean_over(self.runs, &self.settings[k], |r| r.energy)
    }

    fn shear_of(&self, k: usize) -> Option<f64> {
        let v: Vec<f64> = self.settings[k]
            .iter()
            .filter_map(|&j| self.shear[j])
            .collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    }

    /// The largest overlap over the setting's replicas.
    fn overlap(&self, k: usize) -> Option<f64> {
        self.settings[k]
            .iter()
            .filter_map(|&j| self.runs[j].max_overlap)
            .reduce(f64::max)
    }

    fn label_of(&self, k: usize) -> String {
        let (r0, first) = (self.r0, &self.first);
        let base = if k == r0 {
            "reference".to_string()
        } else {
            first[k].delta(first[r0])
        };
        let base = if Some(k) == self.paper_k && k != r0 {
            format!("paper: {base}")
        } else {
            base
        };
        format!("{base} (n={})", self.pooled_count(k))
    }

    fn replicas(&self) -> String {
        replica_range((0..self.settings.len()).map(|k| self.pooled_count(k)))
    }

    /// The text above the table: the settings, the reference, how shifts are read.
    fn summary(&self) -> String {
        let (r0, first, name) = (self.r0, &self.first, self.name);
        let mut text = String::new();
        let _ = writeln!(
            text,
            "{} done job(s) in {} setting(s); reference (most accurate): setting {} [{}]; paper \
             setting: {}",
            self.runs.len(),
            self.settings.len(),
            r0 + 1,
            first[r0].setting(),
            self.paper_k
                .map_or("not in this campaign".to_string(), |k| format!(
                    "setting {} [{}]",
                    k + 1,
                    first[k].setting()
                ))
        );
        let _ = writeln!(
            text,
            "replicas pooled per setting: {} (reference: {}); shift = ({name} − {name}_ref) / \
             {name}_ref with its 95 % CI (Welch): within noise when the CI covers 0",
            self.replicas(),
            self.pooled_count(r0)
        );
        let why = if self.cpu_counted() {
            "every job counted it"
        } else {
            "some jobs ran before CPU time was counted, or where the system gives no thread clocks"
        };
        let _ = writeln!(text, "cost drawn: {} ({why})", self.cost_axis());
        if let Some(p) = self.pooled[r0] {
            let _ = writeln!(
                text,
                "the reference's own 95 % CI: {:.2} % of {name} (from {})",
                100.0 * p.ci95_rel(),
                p.from.name()
            );
        }
        text
    }

    fn table(&self) -> Table {
        let name = self.name;
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
            "cpu_s_per_replica".into(),
            "particle_steps_per_replica".into(),
            "max_overlap_d".into(),
            "kinetic_drift_per_s".into(),
            "kinetic_energy_diff".into(),
        ];
        if self.chute {
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
        for k in 0..self.settings.len() {
            table.push(self.row(k));
        }
        table
    }

    fn row(&self, k: usize) -> Vec<String> {
        let (r0, runs, s, r) = (self.r0, self.runs, &self.settings[k], self.first[k]);
        let against = self.against[k];
        let jobs: Vec<String> = s.iter().map(|&j| runs[j].id.to_string()).collect();
        let or_reference = |v: String| if k == r0 { "reference".into() } else { v };
        let mut row = vec![
            (k + 1).to_string(),
            jobs.join(" "),
            r.setting(),
            or_reference(r.delta(self.first[r0])),
            r.spec.precision.name().to_string(),
            r.backend.clone(),
            sci(r.dt_s, 3),
            self.pooled_count(k).to_string(),
            self.pooled_count(against).to_string(),
            fixed(self.wall(k), 1),
            fixed(self.cpu(k), 1),
            sci(mean_over(runs, s, |r| Some(r.particle_steps)), 3),
            sci(self.overlap(k), 3),
            sci(mean_over(runs, s, |r| r.drift), 3),
            or_reference(sci(rel_diff(self.energy(k), self.energy(against)), 3)),
        ];
        if self.chute {
            row.push(or_reference(sci(
                rel_diff(self.shear_of(k), self.shear_of(against)),
                3,
            )));
        }
        row.push((against + 1).to_string());
        let from = self.pooled[k].map_or("-".into(), |p| p.from.name().to_string());
        if k == r0 {
            // Its own interval, for scale.
            row.push("reference".into());
            row.push(fixed(self.pooled[k].map(|p| 100.0 * p.ci95_rel()), 2));
            row.push(from);
            row.push("reference".into());
        } else {
            let x = self.shifts[k];
            row.push(fixed(x.map(|x| 100.0 * x.rel), 2));
            row.push(fixed(x.map(|x| 100.0 * x.ci95_rel), 2));
            row.push(from);
            row.push(x.map_or("-".into(), |x| x.verdict().to_string()));
        }
        row
    }

    /// The shift ± its interval against cost, and the largest overlap against cost.
    fn figure(&self, campaign: &str) -> Figure {
        let (r0, name, replicas) = (self.r0, self.name, self.replicas());
        let n = self.settings.len();
        let (lo, hi) = (0..n)
            .filter_map(|k| self.cost(k))
            .fold((f64::INFINITY, 0.0f64), |(a, b), w| (a.min(w), b.max(w)));
        let mut p = Panel::new(
            Axis::log(self.cost_axis()),
            Axis::linear(format!("shift of {name} against the reference (%)")),
        );
        p.title = Some(format!("{name}: shift ± 95 % CI vs cost"));
        p.notes = vec![
            format!(
                "n = replicas pooled ({replicas} per setting; reference: {})",
                self.pooled_count(r0)
            ),
            "within noise: the CI covers 0".into(),
            "reference: its own 95 % CI at 0".into(),
        ];
        for k in 0..n {
            let Some(w) = self.cost(k) else { continue };
            let shift = if k == r0 {
                self.pooled[k].map(|q| (0.0, q.ci95_rel()))
            } else {
                self.shifts[k].map(|x| (x.rel, x.ci95_rel))
            };
            let Some((y, err)) = shift else { continue };
            let err = Some(100.0 * err).filter(|e| e.is_finite());
            p.series.push(
                Series::points(Some(self.label_of(k)), k % 10, vec![w], vec![100.0 * y])
                    .with_errors(vec![err]),
            );
        }
        if lo <= hi {
            p.series
                .push(Series::line(None, 7, vec![lo, hi], vec![0.0, 0.0]));
        }
        let mut ov = Panel::new(
            Axis::log(self.cost_axis()),
            Axis::log("largest overlap / d"),
        );
        ov.title = Some("largest overlap (over replicas) vs cost".into());
        ov.legend = Legend::Hidden;
        for k in 0..n {
            if let (Some(o), Some(w)) = (self.overlap(k), self.cost(k)) {
                ov.series.push(Series::points(
                    Some(self.label_of(k)),
                    k % 10,
                    vec![w],
                    vec![o],
                ));
            }
        }
        Figure {
            title: Some(format!(
                "Accuracy vs cost, campaign {campaign}: shift of {name} against setting {} \
                 (replicas per setting: {replicas}; reference: {})",
                r0 + 1,
                self.pooled_count(r0)
            )),
            columns: 1,
            panels: vec![p, ov],
            panel_size: (1300, 560),
        }
    }
}

/// The setting each is compared with: the reference, except an observer-only variant, which is
/// compared with its twin on the same trajectories (same parameters, the paper's observers):
/// its shift is then the observer's alone.
fn compared_with(first: &[&Run], r0: usize) -> Vec<usize> {
    (0..first.len())
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
        .collect()
}
