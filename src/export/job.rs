//! Exporting one job for ParaView: its snapshot frames (or, without frames, its latest
//! checkpoint) as `.vtu` files with a `particles.pvd` time series, and its coarse-grained field
//! sets as `.vti` files with a `fields.pvd`. Reads the job directory and the store; writes only
//! under the output directory.
//!
//! Layout of the output directory:
//! ```text
//! particles.pvd                      frames at the job's clock (s)
//! particles/frame-<chunk>.vtu        one per exported frame
//! particles/checkpoint-<step>.vtu    instead, when the job has no frames
//! fields.pvd                         field sets at the middle of their time windows
//! fields/<set name>.vti              one per field set; the chute's z profiles as
//!                                    fields/chute_profile.vti
//! ```
//! Earlier exports' files of these names are removed first, so the directory holds one export.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use rusqlite::Connection;

use super::chute_profiles::chute_profile_set;
use super::data_array::Encoding;
use super::error::ExportError;
use super::pvd::{collection, PvdEntry};
use super::vti::field_set_to_vti;
use super::vtu::frame_to_vtu;
use crate::campaign::job_dir;
use crate::checkpoint;
use crate::observe::snapshots::{list_frames, read_frame, snapshot_dir, Frame};
use crate::store::fields::{list_field_sets, load_field_arrays, FieldArray, FieldSet};

/// What to export and how.
#[derive(Clone, Copy, Debug)]
pub struct ExportOptions {
    /// Every k-th frame (1 = all), counted from the first.
    pub every: usize,
    pub encoding: Encoding,
}

impl Default for ExportOptions {
    fn default() -> Self {
        Self {
            every: 1,
            encoding: Encoding::Base64,
        }
    }
}

/// What an export wrote.
#[derive(Debug, Default)]
pub struct ExportReport {
    /// Particle datasets written (`.vtu`), in time order.
    pub frames: Vec<PathBuf>,
    pub particles_pvd: Option<PathBuf>,
    /// Field datasets written (`.vti`).
    pub fields: Vec<PathBuf>,
    pub fields_pvd: Option<PathBuf>,
    /// Things the user should know (the checkpoint fallback, no field sets).
    pub notes: Vec<String>,
    /// Frames or checkpoints refused, with the reason; the export goes on without them.
    pub refused: Vec<String>,
}

/// Exports job `job_id` (its files under `work_dir`, its fields in `conn`) into `out`.
///
/// # Errors
/// An unknown job, nothing to export, `out` not writable, or database errors. A corrupt frame is
/// not an error: it is skipped and listed in `refused`.
pub fn export_job(
    conn: &Connection,
    work_dir: &Path,
    job_id: i64,
    out: &Path,
    opts: &ExportOptions,
) -> Result<ExportReport, ExportError> {
    let store = |e: &dyn std::fmt::Display| ExportError::Store {
        job_id,
        message: e.to_string(),
    };
    let hash: String = crate::store::jobs::job_hash(conn, job_id)
        .map_err(|e| store(&e))?
        .ok_or(ExportError::UnknownJob { job_id })?;
    let dir = job_dir(work_dir, &hash);
    let mut report = ExportReport::default();

    let frames = particle_frames(&dir, &hash, job_id, opts, &mut report);

    // Stored field sets (arrays loaded one set at a time), then the chute's z profiles.
    let mut sets: Vec<(FieldSet, Option<Vec<FieldArray>>)> = list_field_sets(conn, job_id)
        .map_err(|e| store(&format!("{e:#}")))?
        .into_iter()
        .map(|s| (s, None))
        .collect();
    match chute_profile_set(conn, job_id) {
        Ok(Some((set, arrays))) => sets.push((set, Some(arrays))),
        Ok(None) => {}
        Err(e) => report
            .notes
            .push(format!("job {job_id}: {e:#}; profiles not exported")),
    }
    if frames.is_empty() && sets.is_empty() && report.refused.is_empty() {
        return Err(ExportError::Nothing {
            job_id,
            snapshots: snapshot_dir(&dir),
            job_dir: dir,
        });
    }
    make_dir(out)?;
    if !frames.is_empty() {
        write_frames(out, &frames, opts, &mut report)?;
    }
    write_fields(conn, out, sets, job_id, opts, &mut report)?;
    Ok(report)
}

/// The particles to export: the snapshot frames (every `opts.every`-th), or else the latest
/// valid checkpoint as one frame; each with its file under `out`. Refused frames and
/// checkpoints, and what was chosen, go to `report`.
fn particle_frames(
    dir: &Path,
    hash: &str,
    job_id: i64,
    opts: &ExportOptions,
    report: &mut ExportReport,
) -> Vec<(Frame, String)> {
    let listed = list_frames(&snapshot_dir(dir));
    let mut frames: Vec<(Frame, String)> = Vec::new();
    for (_, path) in listed.iter().step_by(opts.every.max(1)) {
        match read_frame(path, Some(hash)) {
            Ok(f) => {
                let file = format!("particles/frame-{:012}.vtu", f.chunk);
                frames.push((f, file));
            }
            Err(e) => report.refused.push(format!("refused snapshot frame {e}")),
        }
    }
    if listed.is_empty() {
        let (found, refused) = checkpoint::load_latest(dir, hash);
        report.refused.extend(refused);
        if let Some((path, _, s, extra)) = found {
            // The job's clock, as snapshot frames are stamped; a checkpoint from before it was
            // recorded has only the engine's.
            let job_time = serde_json::from_str::<serde_json::Value>(&extra)
                .ok()
                .and_then(|v| v.get("job_time_s").and_then(serde_json::Value::as_f64));
            let (t, clock) = match job_time {
                Some(t) => (t, "the job's clock, as snapshot frames"),
                None => (
                    s.time,
                    "the engine's clock: the checkpoint predates the job's",
                ),
            };
            report.notes.push(format!(
            "job {job_id} has no snapshot frames (set observers.snapshots.interval_s to record them): exported its latest checkpoint {} (t = {t:.4} s, {clock}) as one frame",
            path.display(),
        ));
            let f = Frame::of_state(&s, hash, 0, t);
            frames.push((f, format!("particles/checkpoint-{:012}.vtu", s.step)));
        } else {
            report.notes.push(format!(
            "job {job_id} has no snapshot frames and no valid checkpoint in {}: no particles exported",
            dir.display()
        ));
        }
    }
    frames
}

/// Writes `frames` as VTU files under `out/particles/` and their collection `particles.pvd`.
fn write_frames(
    out: &Path,
    frames: &[(Frame, String)],
    opts: &ExportOptions,
    report: &mut ExportReport,
) -> Result<(), ExportError> {
    let pdir = out.join("particles");
    make_dir(&pdir)?;
    remove_stale(&pdir, &["frame-", "checkpoint-"], ".vtu");
    let mut entries = Vec::new();
    for (f, file) in frames {
        let path = out.join(file);
        write(&path, &frame_to_vtu(f, opts.encoding))?;
        report.frames.push(path);
        entries.push(PvdEntry {
            time_s: f.job_time_s,
            file: file.clone(),
            name: "particles".into(),
        });
    }
    let pvd = out.join("particles.pvd");
    write(&pvd, &collection(&entries))?;
    report.particles_pvd = Some(pvd);
    Ok(())
}

/// Writes the field sets (arrays loaded one set at a time unless given) as VTI files under
/// `out/fields/` and the collection `fields.pvd` of those that are moments of the run.
fn write_fields(
    conn: &Connection,
    out: &Path,
    sets: Vec<(FieldSet, Option<Vec<FieldArray>>)>,
    job_id: i64,
    opts: &ExportOptions,
    report: &mut ExportReport,
) -> Result<(), ExportError> {
    let store = |e: &dyn std::fmt::Display| ExportError::Store {
        job_id,
        message: e.to_string(),
    };
    if sets.is_empty() {
        report.notes.push(format!(
            "job {job_id} has no coarse-grained field sets or profiles"
        ));
    } else {
        let fdir = out.join("fields");
        make_dir(&fdir)?;
        remove_stale(&fdir, &[""], ".vti");
        let mut taken = HashSet::new();
        let mut entries = Vec::new();
        for (set, arrays) in sets {
            let arrays = match arrays {
                Some(a) => a,
                None => load_field_arrays(conn, set.id).map_err(|e| store(&format!("{e:#}")))?,
            };
            let text = field_set_to_vti(&set, &arrays, opts.encoding)
                .map_err(|message| ExportError::Fields { job_id, message })?;
            let mut stem = file_stem(&set.name);
            if !taken.insert(stem.clone()) {
                stem = format!("{stem}-{}", set.id);
                taken.insert(stem.clone());
            }
            let file = format!("fields/{stem}.vti");
            let path = out.join(&file);
            write(&path, &text)?;
            report.fields.push(path);
            // A run's time averages (`mean`, `mean_flowing`, `mean_xyz`) are not moments of its
            // time series: written beside it, not as its time steps.
            if is_time_average(&set.name) {
                report.notes.push(format!(
                    "{file}: time average over {:.3}–{:.3} s, not a step of fields.pvd",
                    set.t_start_s, set.t_end_s
                ));
                continue;
            }
            entries.push(PvdEntry {
                time_s: 0.5 * (set.t_start_s + set.t_end_s),
                file,
                name: set.name,
            });
        }
        if !entries.is_empty() {
            let pvd = out.join("fields.pvd");
            write(&pvd, &collection(&entries))?;
            report.fields_pvd = Some(pvd);
        }
    }
    Ok(())
}

fn write(path: &Path, text: &str) -> Result<(), ExportError> {
    std::fs::write(path, text).map_err(|source| ExportError::Write {
        path: path.to_path_buf(),
        source,
    })
}

fn make_dir(path: &Path) -> Result<(), ExportError> {
    std::fs::create_dir_all(path).map_err(|source| ExportError::Write {
        path: path.to_path_buf(),
        source,
    })
}

/// A field set's name as a file name: letters, digits, '.', '-' and '_' kept, others '_'.
fn file_stem(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '_') {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() || s.starts_with('.') {
        format!("set{s}")
    } else {
        s
    }
}

/// Removes files of an earlier export in `dir`: names starting with one of `prefixes` and
/// ending with `suffix`.
fn remove_stale(dir: &Path, prefixes: &[&str], suffix: &str) {
    for e in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if name.ends_with(suffix) && prefixes.iter().any(|p| name.starts_with(p)) {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

/// Whether a field set averages a whole run (the silo observer's `mean…` sets) rather than one
/// window of its time series.
fn is_time_average(name: &str) -> bool {
    name == "mean" || name.starts_with("mean_")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_names_become_safe_file_names() {
        assert_eq!(file_stem("map_t3.000"), "map_t3.000");
        assert_eq!(file_stem("a/b c"), "a_b_c");
        assert_eq!(file_stem(".."), "set..");
        assert_eq!(file_stem(""), "set");
    }
}
