//! Coarse-grained field sets in the store (`field_sets`, `field_arrays`, `silo_field_series`):
//! one set is a grid and a time window, its arrays the fields on that grid as little-endian f64
//! blobs (point index `(k*ny + j)*nx + i`, axis 0 fastest as in VTK, then components). This file
//! owns the encoding; what the fields mean is `observe::coarse_grain`'s, which also defines
//! `FieldSet` and `FieldArray` (re-exported here), so observers never import the store.

use anyhow::Context;
use rusqlite::{params, Connection, OptionalExtension};
use serde::{Deserialize, Serialize};

pub use crate::observe::coarse_grain::{FieldArray, FieldSet};
use crate::observe::silo_fields::SiloFieldObserver;

/// The JSON of `field_sets.grid_json`.
#[derive(Serialize, Deserialize)]
struct GridJson {
    origin_m: [f64; 3],
    spacing_m: [f64; 3],
    shape: [usize; 3],
}

const GRID_KINDS: [&str; 3] = ["z", "rz", "xyz"];

/// Stores `set` and its `arrays` for `job_id` (replacing a set of the same name) and returns the
/// new set id. Run it inside the caller's transaction to commit with the job's other results.
///
/// # Errors
/// An unknown grid kind, an array whose length is not points × components, a non-finite value,
/// or database errors.
pub fn save_field_set(
    conn: &Connection,
    job_id: i64,
    set: &FieldSet,
    arrays: &[FieldArray],
) -> anyhow::Result<i64> {
    anyhow::ensure!(
        GRID_KINDS.contains(&set.grid_kind.as_str()),
        "field set {}: grid kind '{}' is not one of z, rz, xyz",
        set.name,
        set.grid_kind
    );
    let n = set.points();
    for a in arrays {
        anyhow::ensure!(
            a.data.len() == n * a.components,
            "field set {}: {} has {} values, expected {} points × {} components",
            set.name,
            a.field,
            a.data.len(),
            n,
            a.components
        );
        if let Some(p) = a.data.iter().position(|v| !v.is_finite()) {
            anyhow::bail!(
                "field set {}: {} value {p} is {}, not a finite number",
                set.name,
                a.field,
                a.data[p]
            );
        }
    }
    delete_field_set(conn, job_id, &set.name)?;
    let grid = serde_json::to_string(&GridJson {
        origin_m: set.origin_m,
        spacing_m: set.spacing_m,
        shape: set.shape,
    })?;
    conn.execute(
        "INSERT INTO field_sets (job_id, name, grid_kind, grid_json, kernel_width_m, cutoff_widths, t_start_s, t_end_s, samples)
         VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)",
        params![
            job_id,
            set.name,
            set.grid_kind,
            grid,
            set.kernel_width_m,
            set.cutoff_widths,
            set.t_start_s,
            set.t_end_s,
            set.samples
        ],
    )
    .with_context(|| format!("storing field set {} of job {job_id}", set.name))?;
    let id = conn.last_insert_rowid();
    let mut ins = conn.prepare(
        "INSERT INTO field_arrays (set_id, field, units, components, data) VALUES (?1, ?2, ?3, ?4, ?5)",
    )?;
    for a in arrays {
        ins.execute(params![
            id,
            a.field,
            a.units,
            a.components as i64,
            encode(&a.data)
        ])
        .with_context(|| format!("storing field {} of set {}", a.field, set.name))?;
    }
    Ok(id)
}

/// Removes the set `name` of `job_id` and its arrays, if present.
///
/// # Errors
/// Database errors.
pub fn delete_field_set(conn: &Connection, job_id: i64, name: &str) -> anyhow::Result<()> {
    let old: Option<i64> = conn
        .query_row(
            "SELECT id FROM field_sets WHERE job_id = ?1 AND name = ?2",
            params![job_id, name],
            |r| r.get(0),
        )
        .optional()?;
    if let Some(id) = old {
        conn.execute("DELETE FROM field_arrays WHERE set_id = ?1", [id])?;
        conn.execute("DELETE FROM field_sets WHERE id = ?1", [id])?;
    }
    Ok(())
}

/// Removes every field set, array and series row of `job_id` (a retried commit replaces them).
///
/// # Errors
/// Database errors.
pub fn delete_job_fields(conn: &Connection, job_id: i64) -> anyhow::Result<()> {
    conn.execute(
        "DELETE FROM field_arrays WHERE set_id IN (SELECT id FROM field_sets WHERE job_id = ?1)",
        [job_id],
    )?;
    conn.execute("DELETE FROM field_sets WHERE job_id = ?1", [job_id])?;
    conn.execute("DELETE FROM silo_field_series WHERE job_id = ?1", [job_id])?;
    Ok(())
}

/// The field sets of `job_id`, by name.
///
/// # Errors
/// Database errors or a malformed `grid_json`.
pub fn list_field_sets(conn: &Connection, job_id: i64) -> anyhow::Result<Vec<FieldSet>> {
    let mut q = conn.prepare(
        "SELECT id, job_id, name, grid_kind, grid_json, kernel_width_m, cutoff_widths, t_start_s, t_end_s, samples
         FROM field_sets WHERE job_id = ?1 ORDER BY name",
    )?;
    let rows = q
        .query_map([job_id], |r| {
            Ok((
                r.get::<_, i64>(0)?,
                r.get::<_, i64>(1)?,
                r.get::<_, String>(2)?,
                r.get::<_, String>(3)?,
                r.get::<_, String>(4)?,
                r.get::<_, f64>(5)?,
                r.get::<_, f64>(6)?,
                r.get::<_, f64>(7)?,
                r.get::<_, f64>(8)?,
                r.get::<_, i64>(9)?,
            ))
        })?
        .collect::<Result<Vec<_>, _>>()?;
    rows.into_iter()
        .map(
            |(id, job_id, name, grid_kind, grid, w, c, t0, t1, samples)| {
                let g: GridJson = serde_json::from_str(&grid).with_context(|| {
                    format!("field set {name} of job {job_id}: grid_json '{grid}'")
                })?;
                Ok(FieldSet {
                    id,
                    job_id,
                    name,
                    grid_kind,
                    origin_m: g.origin_m,
                    spacing_m: g.spacing_m,
                    shape: g.shape,
                    kernel_width_m: w,
                    cutoff_widths: c,
                    t_start_s: t0,
                    t_end_s: t1,
                    samples,
                })
            },
        )
        .collect()
}

/// The set `name` of `job_id`, if stored.
///
/// # Errors
/// As `list_field_sets`.
pub fn find_field_set(
    conn: &Connection,
    job_id: i64,
    name: &str,
) -> anyhow::Result<Option<FieldSet>> {
    Ok(list_field_sets(conn, job_id)?
        .into_iter()
        .find(|s| s.name == name))
}

/// The arrays of set `set_id`, by field name.
///
/// # Errors
/// Database errors or a blob whose length is not a multiple of 8.
pub fn load_field_arrays(conn: &Connection, set_id: i64) -> anyhow::Result<Vec<FieldArray>> {
    let mut q = conn.prepare(
        "SELECT field, units, components, data FROM field_arrays WHERE set_id = ?1 ORDER BY field",
    )?;
    let rows = q
        .query_map([set_id], |r| {
            Ok((
                r.get::<_, String>(0)?,
                r.get::<_, String>(1)?,
                r.get::<_, i64>(2)?,
                r.get::<_, Vec<u8>>(3)?,
            ))
        })?
        .collect::<Result<Vec<_>, _>>()?;
    rows.into_iter()
        .map(|(field, units, components, blob)| {
            anyhow::ensure!(
                blob.len() % 8 == 0,
                "field set {set_id}: {field} blob has {} bytes, not a multiple of 8",
                blob.len()
            );
            Ok(FieldArray {
                field,
                units,
                components: components as usize,
                data: decode(&blob),
            })
        })
        .collect()
}

/// Appends one scalar time series of `job_id` (`(t (s), value)` pairs) to `silo_field_series`,
/// each sample with whether the silo was flowing then (`flowing`: None stores NULL, unknown).
///
/// # Errors
/// A non-finite value or database errors.
pub fn save_field_series(
    conn: &Connection,
    job_id: i64,
    name: &str,
    units: &str,
    samples: &[(f64, f64)],
    flowing: Option<&dyn Fn(f64) -> bool>,
) -> anyhow::Result<()> {
    let mut ins = conn.prepare(
        "INSERT OR REPLACE INTO silo_field_series (job_id, name, t_s, value, units, flowing) VALUES (?1, ?2, ?3, ?4, ?5, ?6)",
    )?;
    for &(t, v) in samples {
        anyhow::ensure!(
            v.is_finite(),
            "field series {name} of job {job_id}: value at t = {t} s is {v}"
        );
        let flag = flowing.map(|f| i64::from(f(t)));
        ins.execute(params![job_id, name, t, v, units, flag])?;
    }
    Ok(())
}

/// One sample of a stored series: time (s), value, and whether the silo was flowing (None:
/// not recorded, a series stored by an older sweep).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeriesSample {
    pub t_s: f64,
    pub value: f64,
    pub flowing: Option<bool>,
}

/// The series `name` of `job_id` with the flowing flag of each sample, in time order (empty
/// when the job has no such series).
///
/// # Errors
/// Database errors.
pub fn load_flagged_series(
    conn: &Connection,
    job_id: i64,
    name: &str,
) -> anyhow::Result<Vec<SeriesSample>> {
    let mut q = conn.prepare(
        "SELECT t_s, value, flowing FROM silo_field_series WHERE job_id = ?1 AND name = ?2 ORDER BY t_s",
    )?;
    let rows = q
        .query_map(params![job_id, name], |r| {
            Ok(SeriesSample {
                t_s: r.get(0)?,
                value: r.get(1)?,
                flowing: r.get::<_, Option<i64>>(2)?.map(|f| f != 0),
            })
        })?
        .collect::<Result<Vec<_>, _>>()?;
    Ok(rows)
}

/// A stored scalar series: `(t (s), value)` in time order, and its units.
pub type FieldSeries = (Vec<(f64, f64)>, String);

/// The series `name` of `job_id` (None when the job has no such series).
///
/// # Errors
/// Database errors.
pub fn load_field_series(
    conn: &Connection,
    job_id: i64,
    name: &str,
) -> anyhow::Result<Option<FieldSeries>> {
    let mut q = conn.prepare(
        "SELECT t_s, value, units FROM silo_field_series WHERE job_id = ?1 AND name = ?2 ORDER BY t_s",
    )?;
    let rows = q
        .query_map(params![job_id, name], |r| {
            Ok((
                r.get::<_, f64>(0)?,
                r.get::<_, f64>(1)?,
                r.get::<_, String>(2)?,
            ))
        })?
        .collect::<Result<Vec<_>, _>>()?;
    let Some(units) = rows.first().map(|r| r.2.clone()) else {
        return Ok(None);
    };
    Ok(Some((
        rows.into_iter().map(|r| (r.0, r.1)).collect(),
        units,
    )))
}

/// Copies the field sets of `job_id` and their arrays from the attached database `from` into
/// `main` (new set ids: a job-local store numbers its sets from 1), replacing what `main` had,
/// and returns the sets copied. Slurm ingestion uses it: `field_arrays` has no `job_id` column,
/// so the generic per-table copy cannot carry it.
///
/// # Errors
/// Database errors.
pub fn copy_job_fields(conn: &Connection, from: &str, job_id: i64) -> anyhow::Result<usize> {
    conn.execute(
        "DELETE FROM main.field_arrays WHERE set_id IN (SELECT id FROM main.field_sets WHERE job_id = ?1)",
        [job_id],
    )?;
    conn.execute("DELETE FROM main.field_sets WHERE job_id = ?1", [job_id])?;
    let n = conn.execute(
        &format!(
            "INSERT INTO main.field_sets (job_id, name, grid_kind, grid_json, kernel_width_m, cutoff_widths, t_start_s, t_end_s, samples)
             SELECT job_id, name, grid_kind, grid_json, kernel_width_m, cutoff_widths, t_start_s, t_end_s, samples
             FROM {from}.field_sets WHERE job_id = ?1"
        ),
        [job_id],
    )?;
    conn.execute(
        &format!(
            "INSERT INTO main.field_arrays (set_id, field, units, components, data)
             SELECT m.id, a.field, a.units, a.components, a.data
             FROM {from}.field_arrays a JOIN {from}.field_sets s ON a.set_id = s.id
             JOIN main.field_sets m ON m.job_id = s.job_id AND m.name = s.name
             WHERE s.job_id = ?1"
        ),
        [job_id],
    )?;
    Ok(n)
}

fn encode(data: &[f64]) -> Vec<u8> {
    data.iter().flat_map(|v| v.to_le_bytes()).collect()
}

fn decode(blob: &[u8]) -> Vec<f64> {
    blob.chunks_exact(8)
        .map(|b| f64::from_le_bytes(b.try_into().expect("chunks of 8")))
        .collect()
}

/// Stores every field set and series of a silo job's field observer for `job_id` (inside the
/// caller's transaction, so they commit with the job's other results), each series sample
/// flagged with `flowing(t)`.
///
/// # Errors
/// Database errors or non-finite values.
pub fn save_silo_fields(
    conn: &Connection,
    job_id: i64,
    fields: &SiloFieldObserver,
    flowing: &dyn Fn(f64) -> bool,
) -> anyhow::Result<()> {
    for (set, arrays) in fields.field_sets() {
        save_field_set(conn, job_id, &set, &arrays)?;
    }
    for s in fields.series() {
        save_field_series(conn, job_id, s.name, s.units, s.samples, Some(flowing))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blob_is_little_endian_f64() {
        let b = encode(&[1.0, -2.5]);
        assert_eq!(&b[..8], &1.0f64.to_le_bytes());
        assert_eq!(decode(&b), vec![1.0, -2.5]);
    }
}
