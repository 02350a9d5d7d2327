//! The silo paper's coarse-grained field figures, fig6–fig11, from the field sets and series the
//! field observer stored (`field_sets`, `field_arrays`, `silo_field_series`) and nothing else:
//! φ maps over time (fig6), |V| with streamlines of (V_r, V_z) (fig7), V_θ (fig8), profiles across
//! the orifice (fig9) and mean kinetic-pressure maps (fig10); ⟨p^k⟩ in the orifice cylinder vs f
//! (fig11) is in `orifice_pressure`. Lengths are in units of the silo radius R_c, as in the paper.

use anyhow::{bail, Result};
use rusqlite::Connection;

use crate::observe::silo_fields::MEAN_FLOWING;
use crate::pooled::silo::{distinct, drawable_discharge_rows, same_value};
use crate::report::campaign::CampaignRef;
use crate::report::drawn::{write_all, Drawn, Output};
use crate::report::field_map::{MapFigure, MapPanel, MapRow};
use crate::report::plot::{Axis, Figure, Legend, Panel, Series};
use crate::report::streamlines::Field2d;
use crate::report::table::{csv_num, mm, short, Table};
use crate::store::fields::{list_field_sets, load_field_arrays, FieldArray, FieldSet};

/// Cells with a solid fraction below this hold (almost) no particles: left white in the maps.
const EMPTY_PHI: f64 = 0.02;

/// One ended job with field sets (or, while a round runs it on, its earlier end).
pub(super) struct FieldJob {
    pub(super) job_id: i64,
    /// Set while a round runs the job on: the discharge time it runs to, s.
    pub(super) running_on_to_s: Option<f64>,
    pub(super) d_m: f64,
    pub(super) f_hz: f64,
    pub(super) particle_d_m: f64,
    pub(super) silo_radius_m: f64,
    /// The job's flow rate; None when it clogged before one could be measured.
    pub(super) q_kg_per_s: Option<f64>,
    /// Time between field samples (s), from the job's parameters.
    pub(super) sample_interval_s: Option<f64>,
    pub(super) sets: Vec<FieldSet>,
}

impl FieldJob {
    /// What fig11's ⟨p^k⟩ needs of the job (`pooled::orifice_pressure`).
    pub(super) fn pk_job(&self) -> crate::pooled::orifice_pressure::PkJob {
        crate::pooled::orifice_pressure::PkJob {
            job_id: self.job_id,
            d_m: self.d_m,
            f_hz: self.f_hz,
            q_kg_per_s: self.q_kg_per_s,
            reaches_cylinder: crate::pooled::orifice_pressure::reaches_orifice_cylinder(
                self.d_m, &self.sets,
            ),
            has_fields: !self.sets.is_empty(),
        }
    }

    fn set(&self, name: &str) -> Option<&FieldSet> {
        self.sets.iter().find(|s| s.name == name)
    }

    /// The time average fig9 and fig10 show: the flowing samples' mean, and a phrase saying
    /// how much time it averages. A job of an older sweep has only the whole-run mean, which
    /// includes clogged time: it is used and said so. None when the job has no flowing sample.
    fn flowing_mean(&self) -> Option<(&FieldSet, String)> {
        if let Some(set) = self.set(MEAN_FLOWING) {
            let secs = self.sample_interval_s.map(|h| h * set.samples as f64);
            let how = match secs {
                Some(s) => format!("{s:.2} s flowing"),
                None => format!("{} flowing samples", set.samples),
            };
            return Some((set, how));
        }
        // A job with Q has flowing samples, so without a flowing mean it was stored before
        // sweep kept one: its whole-run mean is shown, and said to include clogged time.
        self.q_kg_per_s?;
        self.set("mean")
            .map(|set| (set, "whole run incl. clogs (older sweep)".to_string()))
    }

    /// The map sets (`map_t…`), by time.
    pub(super) fn maps(&self) -> Vec<&FieldSet> {
        let mut m: Vec<&FieldSet> = self
            .sets
            .iter()
            .filter(|s| s.name.starts_with("map_t"))
            .collect();
        // By time, not by name: "map_t10.000" sorts before "map_t5.000".
        m.sort_by(|a, b| a.t_start_s.total_cmp(&b.t_start_s));
        m
    }
}

/// The campaign's drawn jobs (`drawable_discharge_rows`) that have field sets, by D, f, an
/// ended job before one a round runs on, job id.
pub(super) fn field_jobs(conn: &Connection, c: &CampaignRef) -> Result<Vec<FieldJob>> {
    let mut out = Vec::new();
    for r in drawable_discharge_rows(conn, c.id)? {
        let sets = list_field_sets(conn, r.job_id)?;
        if sets.is_empty() {
            continue;
        }
        let p: serde_json::Value = serde_json::from_str(&r.params_json)?;
        let silo_radius_m = p["silo"]["cylinder_radius_m"].as_f64().unwrap_or(f64::NAN);
        out.push(FieldJob {
            job_id: r.job_id,
            running_on_to_s: r.running_on_to_s,
            d_m: r.orifice_diameter_m,
            f_hz: r.rotation_frequency_hz,
            particle_d_m: r.particle_diameter_m,
            silo_radius_m,
            q_kg_per_s: r.q_kg_per_s,
            sample_interval_s: p["observers"]["fields"]["sample_interval_s"].as_f64(),
            sets,
        });
    }
    // Stable: job ids stay in order within each group.
    out.sort_by(|a, b| {
        (a.d_m.total_cmp(&b.d_m))
            .then(a.f_hz.total_cmp(&b.f_hz))
            .then(
                a.running_on_to_s
                    .is_some()
                    .cmp(&b.running_on_to_s.is_some()),
            )
    });
    if out.is_empty() {
        bail!(
            "campaign '{}' has no done job with coarse-grained fields: add \"fields\" to its observers (see campaigns/silo_QvsF_quick.json) and run it",
            c.name
        );
    }
    Ok(out)
}

/// The arrays of a set, by field name.
fn arrays(conn: &Connection, set: &FieldSet) -> Result<Vec<FieldArray>> {
    load_field_arrays(conn, set.id)
}

fn field<'a>(a: &'a [FieldArray], name: &str) -> Result<&'a FieldArray> {
    a.iter()
        .find(|x| x.field == name)
        .ok_or_else(|| anyhow::anyhow!("field set lacks '{name}'"))
}

/// Up to `n` of `values` (sorted), spread over their range: first, last and evenly between.
fn spread(values: &[f64], n: usize) -> Vec<f64> {
    if values.len() <= n {
        return values.to_vec();
    }
    (0..n)
        .map(|k| values[k * (values.len() - 1) / (n - 1)])
        .collect()
}

/// The jobs of orifice `d` at the chosen frequencies (first job of each (D, f)).
fn rows_of<'a>(jobs: &'a [FieldJob], d: f64, fs: &[f64]) -> Vec<&'a FieldJob> {
    fs.iter()
        .filter_map(|f| {
            jobs.iter()
                .find(|j| same_value(j.d_m, d) && same_value(j.f_hz, *f))
        })
        .collect()
}

/// "; earlier end of job(s) a round runs on: N (to T s), …" for those of `jobs` a round runs on,
/// or "" (a figure's title names them).
pub(super) fn running_on_suffix<'a>(jobs: impl IntoIterator<Item = &'a FieldJob>) -> String {
    let named: Vec<String> = jobs
        .into_iter()
        .filter_map(|j| Some(format!("{} (to {} s)", j.job_id, short(j.running_on_to_s?))))
        .collect();
    if named.is_empty() {
        return String::new();
    }
    format!(
        "; earlier end of job(s) a round runs on: {}",
        named.join(", ")
    )
}

/// The largest orifice (the paper's fig6–9 show its large D = 36 mm) and up to 3 frequencies.
fn showcase(jobs: &[FieldJob]) -> (f64, Vec<&FieldJob>) {
    let ds = distinct(jobs.iter().map(|j| j.d_m));
    let d = *ds.last().expect("jobs is not empty");
    let fs = distinct(jobs.iter().filter(|j| same_value(j.d_m, d)).map(|j| j.f_hz));
    (d, rows_of(jobs, d, &spread(&fs, 3)))
}

/// A map panel of `values` (one per point of `set`), NaN where φ < EMPTY_PHI.
fn panel(title: String, set: &FieldSet, values: Vec<f64>, phi: &[f64]) -> MapPanel {
    MapPanel {
        title,
        r0_m: set.origin_m[0],
        dr_m: set.spacing_m[0],
        z0_m: set.origin_m[1],
        dz_m: set.spacing_m[1],
        nr: set.shape[0],
        nz: set.shape[1],
        values: values
            .into_iter()
            .zip(phi)
            .map(|(v, p)| if *p >= EMPTY_PHI { v } else { f64::NAN })
            .collect(),
        arrows: Vec::new(),
        streamlines: Vec::new(),
        boxes: Vec::new(),
    }
}

/// The z range (m) showing every panel's material: from the grid bottom to just above the
/// highest point with φ ≥ EMPTY_PHI.
fn material_z_range(panels: &[MapPanel]) -> (f64, f64) {
    let lo = panels.iter().map(|p| p.z0_m).fold(f64::INFINITY, f64::min);
    let mut hi = f64::NEG_INFINITY;
    for p in panels {
        for j in 0..p.nz {
            if (0..p.nr).any(|i| p.values[j * p.nr + i].is_finite()) {
                hi = hi.max(p.z0_m + (j as f64 + 1.0) * p.dz_m);
            }
        }
    }
    if hi > lo {
        (lo, hi)
    } else {
        (lo, lo + 1.0)
    }
}

fn finite_range(rows: &[MapPanel]) -> (f64, f64) {
    let (lo, hi) = rows
        .iter()
        .flat_map(|p| p.values.iter())
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(*v), b.max(*v))
        });
    if lo.is_finite() {
        (lo, hi)
    } else {
        (0.0, 1.0)
    }
}

/// Component `c` of a vector array per point.
fn component(a: &FieldArray, c: usize) -> Vec<f64> {
    a.data
        .iter()
        .skip(c)
        .step_by(a.components)
        .copied()
        .collect()
}

/// Which map quantity a time-series figure shows.
#[derive(Clone, Copy)]
enum MapQuantity {
    Phi,
    Speed,
    Azimuthal,
}

/// fig6–fig8: rows = frequencies of the largest D, columns = the map times.
fn time_maps(
    conn: &Connection,
    c: &CampaignRef,
    out: &Output,
    fig: &str,
    q: MapQuantity,
) -> Result<Drawn> {
    let jobs = field_jobs(conn, c)?;
    let (d, chosen) = showcase(&jobs);
    let mut rows = Vec::new();
    let mut csv = Table::new(&[
        "job_id",
        "f_hz",
        "set",
        "t_start_s",
        "t_end_s",
        "samples",
        "min",
        "max",
    ]);
    let rc = chosen[0].silo_radius_m;
    for j in &chosen {
        let mut panels = Vec::new();
        for set in j.maps() {
            let a = arrays(conn, set)?;
            let phi = &field(&a, "phi")?.data;
            let v = field(&a, "velocity")?;
            let values = match q {
                MapQuantity::Phi => phi.clone(),
                MapQuantity::Speed => v
                    .data
                    .chunks_exact(3)
                    .map(|u| (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt())
                    .collect(),
                MapQuantity::Azimuthal => component(v, 1),
            };
            let mid = 0.5 * (set.t_start_s + set.t_end_s);
            let mut p = panel(format!("t = {} s", short(mid)), set, values, phi);
            if matches!(q, MapQuantity::Speed) {
                // Streamlines of (V_r, V_z) where there is material, seeded every 4th point.
                let (nr, nz) = (set.shape[0], set.shape[1]);
                let masked = |c: usize| -> Vec<f64> {
                    (0..nr * nz)
                        .map(|k| {
                            if phi[k] >= EMPTY_PHI {
                                v.data[3 * k + c]
                            } else {
                                f64::NAN
                            }
                        })
                        .collect()
                };
                let (ur, uz) = (masked(0), masked(2));
                let f = Field2d {
                    r0: set.origin_m[0],
                    dr: set.spacing_m[0],
                    nr,
                    z0: set.origin_m[1],
                    dz: set.spacing_m[1],
                    nz,
                    ur: &ur,
                    uz: &uz,
                };
                // At rest below 1 % of the panel's fastest flow: no direction to follow there.
                let fastest = ur
                    .iter()
                    .zip(&uz)
                    .map(|(a, b)| a.hypot(*b))
                    .filter(|x| x.is_finite())
                    .fold(0.0, f64::max);
                p.streamlines = f.streamlines(4, 4 * (nr + nz), 0.01 * fastest);
            }
            let (lo, hi) = finite_range(std::slice::from_ref(&p));
            csv.push(vec![
                j.job_id.to_string(),
                short(j.f_hz),
                set.name.clone(),
                csv_num(Some(set.t_start_s)),
                csv_num(Some(set.t_end_s)),
                set.samples.to_string(),
                csv_num(Some(lo)),
                csv_num(Some(hi)),
            ]);
            panels.push(p);
        }
        rows.push(MapRow {
            label: format!("f = {} Hz", short(j.f_hz)),
            panels,
            range: (0.0, 0.0),
            bar_label: match q {
                MapQuantity::Phi => "φ".into(),
                MapQuantity::Speed => "|V| (m/s)".into(),
                MapQuantity::Azimuthal => "V_θ (m/s)".into(),
            },
        });
    }
    let all: Vec<MapPanel> = rows.iter().flat_map(|r| r.panels.clone()).collect();
    let range = match q {
        MapQuantity::Phi => (0.0, finite_range(&all).1),
        _ => finite_range(&all),
    };
    for r in &mut rows {
        r.range = range;
    }
    let z_range = material_z_range(&all);
    let what = match q {
        MapQuantity::Phi => "solid fraction φ(r, z, t)",
        MapQuantity::Speed => "speed |V|(r, z, t), streamlines of (V_r, V_z)",
        MapQuantity::Azimuthal => "azimuthal velocity V_θ(r, z, t)",
    };
    let figure = MapFigure {
        title: format!(
            "{fig}: {what}, D = {} mm ({:.2} d), w = {} mm{}",
            mm(d),
            d / chosen[0].particle_d_m,
            mm(chosen[0].sets[0].kernel_width_m),
            running_on_suffix(chosen.iter().copied())
        ),
        rows,
        length_m: rc,
        length_name: "R_c".into(),
        z_range_m: z_range,
        arrow_scale: 0.0,
    };
    let mut files = figure.write(out, fig)?;
    let csv_path = out.join(format!("{fig}.csv"));
    csv.write_csv(&csv_path)?;
    files.push(csv_path);
    Ok(Drawn {
        text: csv.to_text(),
        files,
    })
}

/// Fig. 6: φ maps at the map times, one row per f, largest D.
pub(crate) fn fig6(conn: &Connection, c: &CampaignRef, out: &Output) -> Result<Drawn> {
    time_maps(conn, c, out, "fig6", MapQuantity::Phi)
}

/// Fig. 7: |V| maps with streamlines of (V_r, V_z).
pub(crate) fn fig7(conn: &Connection, c: &CampaignRef, out: &Output) -> Result<Drawn> {
    time_maps(conn, c, out, "fig7", MapQuantity::Speed)
}

/// Fig. 8: V_θ maps.
pub(crate) fn fig8(conn: &Connection, c: &CampaignRef, out: &Output) -> Result<Drawn> {
    time_maps(conn, c, out, "fig8", MapQuantity::Azimuthal)
}

/// Fig. 9: ⟨φ⟩, −⟨P_z⟩ and −⟨V_z⟩ on the row z = 0 of the whole-run mean vs r/R (R = D/2), one
/// line per f, largest D.
pub(crate) fn fig9(conn: &Connection, c: &CampaignRef, out: &Output) -> Result<Drawn> {
    let jobs = field_jobs(conn, c)?;
    let (d, _) = showcase(&jobs);
    let fs = distinct(jobs.iter().filter(|j| same_value(j.d_m, d)).map(|j| j.f_hz));
    let chosen = rows_of(&jobs, d, &fs);
    let r_orifice = 0.5 * d;
    let mut panels = [
        Panel::new(Axis::linear("r / R"), Axis::linear("⟨φ⟩ at z = 0")),
        Panel::new(
            Axis::linear("r / R"),
            Axis::linear("−⟨P_z⟩ at z = 0 (kg m⁻² s⁻¹)"),
        ),
        Panel::new(Axis::linear("r / R"), Axis::linear("−⟨V_z⟩ at z = 0 (m/s)")),
    ];
    let mut csv = Table::new(&[
        "job_id",
        "f_hz",
        "r_m",
        "phi",
        "momentum_z_kg_per_m2_s",
        "velocity_z_m_per_s",
    ]);
    let mut notes = Vec::new();
    for (k, j) in chosen.iter().enumerate() {
        let Some((set, how)) = j.flowing_mean() else {
            notes.push(format!(
                "f = {} Hz: clogged, no flowing sample",
                short(j.f_hz)
            ));
            continue;
        };
        notes.push(format!("f = {} Hz: {how}", short(j.f_hz)));
        let a = arrays(conn, set)?;
        let (phi, p, v) = (
            field(&a, "phi")?,
            field(&a, "momentum")?,
            field(&a, "velocity")?,
        );
        let Some(row) =
            (0..set.shape[1]).find(|&jz| set.coordinate(1, jz).abs() < 0.25 * set.spacing_m[1])
        else {
            continue;
        };
        let (mut x, mut y0, mut y1, mut y2) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for ir in 0..set.shape[0] {
            let r = set.coordinate(0, ir);
            if r > 1.5 * r_orifice {
                break;
            }
            let q = row * set.shape[0] + ir;
            x.push(r / r_orifice);
            y0.push(phi.data[q]);
            y1.push(-p.data[3 * q + 2]);
            y2.push(if phi.data[q] >= EMPTY_PHI {
                -v.data[3 * q + 2]
            } else {
                f64::NAN
            });
            csv.push(vec![
                j.job_id.to_string(),
                short(j.f_hz),
                csv_num(Some(r)),
                csv_num(Some(phi.data[q])),
                csv_num(Some(p.data[3 * q + 2])),
                csv_num(Some(v.data[3 * q + 2])),
            ]);
        }
        let label = Some(format!("f = {} Hz", short(j.f_hz)));
        panels[0]
            .series
            .push(Series::line(label.clone(), k, x.clone(), y0));
        panels[1]
            .series
            .push(Series::line(label.clone(), k, x.clone(), y1));
        panels[2].series.push(Series::line(label, k, x, y2));
    }
    for p in &mut panels {
        p.legend = Legend::Hidden;
    }
    // One legend for the three panels, with what each f averages, beside the last one.
    panels[2].legend = Legend::Outside;
    panels[2].notes = notes;
    let fig = Figure {
        title: Some(format!(
            "fig9: profiles across the orifice (z = 0), D = {} mm ({:.2} d), mean over flowing samples{}",
            mm(d),
            d / chosen[0].particle_d_m,
            running_on_suffix(chosen.iter().copied())
        )),
        panels: panels.to_vec(),
        columns: 3,
        panel_size: (520, 440),
    };
    let files = write_all(&fig, &csv, out, "fig9")?;
    Ok(Drawn {
        text: format!("{} rows (see fig9.csv)\n", csv.to_csv().lines().count() - 1),
        files,
    })
}

/// Fig. 10: p^k = tr⟨σᵏ⟩ maps of the whole-run mean, rows = D, columns = f; the dashed
/// rectangle is fig11's orifice cylinder (r ≤ R, |z| ≤ R/2).
pub(crate) fn fig10(conn: &Connection, c: &CampaignRef, out: &Output) -> Result<Drawn> {
    let jobs = field_jobs(conn, c)?;
    let ds = distinct(jobs.iter().map(|j| j.d_m));
    let fs = distinct(jobs.iter().map(|j| j.f_hz));
    let mut rows = Vec::new();
    let mut clogged = Vec::new();
    let mut csv = Table::new(&[
        "job_id",
        "d_m",
        "f_hz",
        "t_start_s",
        "t_end_s",
        "samples",
        "max_pk_pa",
    ]);
    for &d in &ds {
        let mut panels = Vec::new();
        for j in rows_of(&jobs, d, &fs) {
            let Some((set, how)) = j.flowing_mean() else {
                clogged.push(format!("D = {} mm, f = {} Hz", mm(d), short(j.f_hz)));
                // An empty panel keeps the columns aligned with f and says why it is empty.
                if let Some(any) = j.sets.iter().find(|s| s.grid_kind == "rz") {
                    let empty = vec![f64::NAN; any.shape[0] * any.shape[1]];
                    let title = format!("f = {} Hz: clogged, no flowing sample", short(j.f_hz));
                    panels.push(panel(title, any, empty.clone(), &empty));
                }
                continue;
            };
            let a = arrays(conn, set)?;
            let phi = &field(&a, "phi")?.data;
            let pk = field(&a, "kinetic_pressure")?.data.clone();
            let mut p = panel(format!("f = {} Hz, {how}", short(j.f_hz)), set, pk, phi);
            p.boxes.push((0.5 * d, -0.25 * d, 0.25 * d));
            let (_, hi) = finite_range(std::slice::from_ref(&p));
            csv.push(vec![
                j.job_id.to_string(),
                csv_num(Some(d)),
                short(j.f_hz),
                csv_num(Some(set.t_start_s)),
                csv_num(Some(set.t_end_s)),
                set.samples.to_string(),
                csv_num(Some(hi)),
            ]);
            panels.push(p);
        }
        if panels.is_empty() {
            continue;
        }
        let range = (0.0, finite_range(&panels).1);
        rows.push(MapRow {
            label: format!("D = {} mm", mm(d)),
            panels,
            range,
            bar_label: "p^k (Pa)".into(),
        });
    }
    let all: Vec<MapPanel> = rows.iter().flat_map(|r| r.panels.clone()).collect();
    let rc = jobs[0].silo_radius_m;
    let w = jobs[0].sets[0].kernel_width_m;
    let figure = MapFigure {
        title: format!(
            "fig10: p^k = tr⟨σᵏ⟩_t over flowing samples, w = {} mm; dashed: r ≤ R, |z| ≤ R/2{}{}",
            mm(w),
            running_on_suffix(ds.iter().flat_map(|&d| rows_of(&jobs, d, &fs))),
            if clogged.is_empty() {
                String::new()
            } else {
                format!("; clogged, not drawn: {}", clogged.join("; "))
            }
        ),
        rows,
        length_m: rc,
        length_name: "R_c".into(),
        z_range_m: material_z_range(&all),
        arrow_scale: 0.0,
    };
    let mut files = figure.write(out, "fig10")?;
    let csv_path = out.join("fig10.csv");
    csv.write_csv(&csv_path)?;
    files.push(csv_path);
    Ok(Drawn {
        text: csv.to_text(),
        files,
    })
}
