//! `sweep export --job ID --vtk DIR`: snapshot frames written by tiny silo and chute jobs
//! (`observers.snapshots`) come out as `.vtu` files and a `particles.pvd` time series; field
//! sets from the store and the chute's z profiles as `.vti` images and `fields.pvd`. Every file
//! is read back with an XML parser (roxmltree) and a decoder written here (base64 with VTK's
//! UInt64 byte-count header, or ASCII), and compared with the frames and field arrays it came
//! from: counts, ids, positions, orientations, a field value at a known point, the times in the
//! `.pvd`. Also: `--every 2` keeps every second frame; corrupt and truncated frames are refused
//! by name; a job without frames exports its latest checkpoint and says so; a job resumed from
//! a checkpoint rewrites its frames byte for byte; bad settings and bad arguments give errors
//! that name what was expected.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Output;

use serde_json::{json, Value};
use sweep::observe::snapshots::{list_frames, read_frame, Frame};
use sweep::store::fields::{save_field_set, FieldArray, FieldSet};
use tempfile::TempDir;

fn sweep(dir: &Path, args: &[&str]) -> Output {
    std::process::Command::new(crate::common::cli::bin())
        .args(args)
        .current_dir(dir)
        .env_remove("SWEEP_DB")
        .output()
        .unwrap()
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn ok(o: Output) -> Output {
    assert!(
        o.status.success(),
        "sweep failed:\n{}\n{}",
        stdout(&o),
        stderr(&o)
    );
    o
}

/// A tiny silo (300 spheres, 0.4 s of discharge in chunks of ≈ 0.01 s) with a frame every
/// 0.1 s: frames at chunks 0, 10, 20, 30, 40.
fn silo_campaign(snapshots: Value) -> Value {
    json!({
        "name": "tiny",
        "scene": "silo",
        "base": {
            "cylinder_radius_m": 0.03, "cylinder_height_m": 0.2, "particle_count": 300,
            "youngs_modulus_pa": 3.0e6, "shear_modulus_pa": 1.0e5, "dt_s": null,
            "contact_steps": 20, "discharge_time_s": 0.4, "settle_max_time_s": 0.2,
            "orifice_diameter_m": 0.02, "rotation_frequency_hz": 1.0
        },
        "observers": {
            "discharge": { "skip_initial_s": 0.1, "block_s": 0.05 },
            "snapshots": snapshots
        },
        "run": { "precision": "f64", "checkpoint_interval_s": 0.1 }
    })
}

/// A tiny chute of spherocylinders (ξ = 1.5) over a rough base, 0.85 s in all, a frame every
/// 0.2 s.
fn chute_campaign() -> Value {
    json!({
        "name": "chute_tiny",
        "scene": "chute",
        "base": {
            "aspect_ratio": 1.5, "inclination_deg": 28.0,
            "box_x_lengths": 4.0, "box_y_lengths": 4.0, "bed_height_lengths": 2.0,
            "contact_steps": 10.0,
            "steady_min_time_s": 0.2, "steady_max_time_s": 0.4, "steady_window_s": 0.2,
            "measure_time_s": 0.4, "measure_unsteady": true
        },
        "observers": {
            "chute": { "max_lag_s": 0.2, "fit_min_lag_s": 0.1, "correlation_every": 2 },
            "snapshots": { "interval_s": 0.2 }
        },
        "run": { "precision": "f64", "checkpoint_interval_s": 0.2 }
    })
}

/// Launches `campaign` (one job) in a new directory and returns it; the database is `sweep.db`.
fn run_job(campaign: &Value) -> TempDir {
    let dir = TempDir::new().unwrap();
    let file = dir.path().join("c.json");
    std::fs::write(&file, serde_json::to_string_pretty(campaign).unwrap()).unwrap();
    ok(sweep(
        dir.path(),
        &[
            "launch",
            "c.json",
            "--db",
            "sweep.db",
            "--backend",
            "cpu",
            "--threads",
            "1",
        ],
    ));
    dir
}

/// The one job directory under a run's work directory.
fn job_dir(run: &Path) -> PathBuf {
    let jobs = run.join("sweep-work/sweep/jobs");
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(&jobs)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(dirs.len(), 1, "one job in {}", jobs.display());
    dirs.pop().unwrap()
}

fn frames(run: &Path) -> Vec<(u64, PathBuf)> {
    list_frames(&job_dir(run).join("snapshots"))
}

/// Copies a run's directory (database and work directory) into a new one.
fn copy_run(run: &Path) -> TempDir {
    fn copy(from: &Path, to: &Path) {
        std::fs::create_dir_all(to).unwrap();
        for e in std::fs::read_dir(from).unwrap() {
            let e = e.unwrap();
            let target = to.join(e.file_name());
            if e.file_type().unwrap().is_dir() {
                copy(&e.path(), &target);
            } else {
                std::fs::copy(e.path(), target).unwrap();
            }
        }
    }
    let dir = TempDir::new().unwrap();
    copy(run, dir.path());
    dir
}

// ---- A reader of the VTK XML files, independent of the writer ----

/// One `<DataArray>` decoded.
#[derive(Debug)]
struct Array {
    components: usize,
    values: Vec<f64>,
}

/// A VTK XML file: attributes of its elements by tag (first of each tag) and its arrays by name.
struct Vtk {
    attrs: HashMap<String, HashMap<String, String>>,
    arrays: HashMap<String, Array>,
    datasets: Vec<HashMap<String, String>>,
}

impl Vtk {
    fn read(path: &Path) -> Self {
        let text = std::fs::read_to_string(path).unwrap();
        let doc = roxmltree::Document::parse(&text)
            .unwrap_or_else(|e| panic!("{}: not well-formed XML: {e}", path.display()));
        let root = doc.root_element();
        assert_eq!(root.tag_name().name(), "VTKFile");
        assert_eq!(root.attribute("byte_order"), Some("LittleEndian"));
        let header = root.attribute("header_type").unwrap_or("UInt32");
        assert_eq!(header, "UInt64", "{}", path.display());
        let mut attrs = HashMap::new();
        let mut arrays = HashMap::new();
        let mut datasets = Vec::new();
        for n in doc.descendants().filter(|n| n.is_element()) {
            let a: HashMap<String, String> = n
                .attributes()
                .map(|a| (a.name().to_string(), a.value().to_string()))
                .collect();
            match n.tag_name().name() {
                "DataArray" => {
                    let name = a["Name"].clone();
                    let arr = decode(&a, n.text().unwrap_or(""));
                    assert!(arrays.insert(name.clone(), arr).is_none(), "{name} twice");
                }
                "DataSet" => datasets.push(a),
                tag => {
                    attrs.entry(tag.to_string()).or_insert(a);
                }
            }
        }
        Self {
            attrs,
            arrays,
            datasets,
        }
    }

    fn attr(&self, tag: &str, name: &str) -> &str {
        &self.attrs[tag][name]
    }

    fn array(&self, name: &str) -> &Array {
        self.arrays
            .get(name)
            .unwrap_or_else(|| panic!("no array {name:?}: {:?}", self.arrays.keys()))
    }

    /// The values of `name` as tuples of `components`.
    fn tuples(&self, name: &str, components: usize) -> Vec<Vec<f64>> {
        let a = self.array(name);
        assert_eq!(a.components, components, "{name}");
        a.values.chunks(components).map(|c| c.to_vec()).collect()
    }
}

fn decode(a: &HashMap<String, String>, text: &str) -> Array {
    let components: usize = a["NumberOfComponents"].parse().unwrap();
    let ty = a["type"].as_str();
    let values: Vec<f64> = match a["format"].as_str() {
        "ascii" => text
            .split_whitespace()
            .map(|t| t.parse::<f64>().unwrap())
            .collect(),
        "binary" => {
            let raw = unbase64(text.trim());
            let n = u64::from_le_bytes(raw[..8].try_into().unwrap()) as usize;
            let data = &raw[8..];
            assert_eq!(n, data.len(), "byte-count header of {}", a["Name"]);
            match ty {
                "Float64" => data
                    .chunks(8)
                    .map(|b| f64::from_le_bytes(b.try_into().unwrap()))
                    .collect(),
                "Int64" => data
                    .chunks(8)
                    .map(|b| i64::from_le_bytes(b.try_into().unwrap()) as f64)
                    .collect(),
                "UInt32" => data
                    .chunks(4)
                    .map(|b| u32::from_le_bytes(b.try_into().unwrap()) as f64)
                    .collect(),
                "UInt8" => data.iter().map(|&b| b as f64).collect(),
                other => panic!("unexpected type {other}"),
            }
        }
        other => panic!("unexpected format {other}"),
    };
    if let Some(t) = a.get("NumberOfTuples") {
        assert_eq!(t.parse::<usize>().unwrap() * components, values.len());
    }
    Array { components, values }
}

fn unbase64(s: &str) -> Vec<u8> {
    let val = |c: u8| -> u32 {
        match c {
            b'A'..=b'Z' => (c - b'A') as u32,
            b'a'..=b'z' => (c - b'a') as u32 + 26,
            b'0'..=b'9' => (c - b'0') as u32 + 52,
            b'+' => 62,
            b'/' => 63,
            _ => panic!("not base64: {c}"),
        }
    };
    let b = s.as_bytes();
    assert_eq!(b.len() % 4, 0, "base64 length");
    let mut out = Vec::new();
    for q in b.chunks(4) {
        let pad = q.iter().filter(|&&c| c == b'=').count();
        let n = q[..4 - pad].iter().fold(0u32, |n, &c| (n << 6) | val(c)) << (6 * pad);
        let bytes = [(n >> 16) as u8, (n >> 8) as u8, n as u8];
        out.extend_from_slice(&bytes[..3 - pad]);
    }
    out
}

/// Checks a `.vtu` against the frame it came from, value for value.
fn assert_vtu_is_frame(path: &Path, f: &Frame) {
    let v = Vtk::read(path);
    let n = f.len();
    assert_eq!(v.attr("Piece", "NumberOfPoints"), n.to_string());
    assert_eq!(v.attr("Piece", "NumberOfCells"), n.to_string());
    let pos: Vec<Vec<f64>> = f.pos.iter().map(|p| p.to_vec()).collect();
    assert_eq!(v.tuples("position [m]", 3), pos, "{}", path.display());
    let ids: Vec<f64> = f.id.iter().map(|&i| i as f64).collect();
    assert_eq!(v.array("id").values, ids);
    assert_eq!(v.array("velocity [m/s]").values, f.vel.as_flattened());
    assert_eq!(v.array("radius [m]").values, f.radius);
    assert_eq!(
        v.array("angular_velocity [rad/s]").values,
        f.omega.as_flattened()
    );
    assert_eq!(v.array("TimeValue").values, vec![f.job_time_s]);
    assert_eq!(v.array("types").values, vec![1.0; n], "vertex cells");
    assert_eq!(
        v.array("offsets").values,
        (1..=n).map(|k| k as f64).collect::<Vec<_>>()
    );
}

/// The `.pvd`'s datasets as (time, file).
fn pvd(path: &Path) -> Vec<(f64, String)> {
    let v = Vtk::read(path);
    assert_eq!(v.attr("VTKFile", "type"), "Collection");
    v.datasets
        .iter()
        .map(|d| (d["timestep"].parse().unwrap(), d["file"].clone()))
        .collect()
}

#[test]
fn silo_frames_export_as_a_paraview_time_series() {
    let run = run_job(&silo_campaign(json!({ "interval_s": 0.1 })));
    let d = run.path();
    let listed = frames(d);
    assert_eq!(
        listed.iter().map(|f| f.0).collect::<Vec<_>>(),
        vec![0, 10, 20, 30, 40],
        "a frame every 10 chunks of 0.01 s"
    );
    let o = ok(sweep(
        d,
        &["export", "--job", "1", "--vtk", "vtk", "--db", "sweep.db"],
    ));
    assert!(stdout(&o).contains("5 particle frame(s)"), "{}", stdout(&o));
    let series = pvd(&d.join("vtk/particles.pvd"));
    assert_eq!(series.len(), 5);
    for ((t, file), (chunk, frame_path)) in series.iter().zip(&listed) {
        let f = read_frame(frame_path, None).unwrap();
        assert_eq!(f.chunk, *chunk);
        assert_eq!(*t, f.job_time_s, "the .pvd time is the job's clock");
        assert!(file.ends_with(&format!("frame-{chunk:012}.vtu")), "{file}");
        assert_vtu_is_frame(&d.join("vtk").join(file), &f);
    }
    // Times since the orifice opened: 0, 0.1, … 0.4 s (chunks of ≈ 0.01 s).
    assert_eq!(series[0].0, 0.0);
    assert!((series[4].0 - 0.4).abs() < 1e-3, "{}", series[4].0);

    // Every second frame, as text: the same values.
    ok(sweep(
        d,
        &[
            "export", "--job", "1", "--vtk", "vtk2", "--every", "2", "--ascii", "--db", "sweep.db",
        ],
    ));
    let half = pvd(&d.join("vtk2/particles.pvd"));
    let kept: Vec<&str> = half.iter().map(|(_, f)| f.as_str()).collect();
    assert_eq!(
        kept,
        [
            "particles/frame-000000000000.vtu",
            "particles/frame-000000000020.vtu",
            "particles/frame-000000000040.vtu"
        ]
    );
    let f = read_frame(&listed[4].1, None).unwrap();
    assert_vtu_is_frame(&d.join("vtk2").join(kept[2]), &f);
    let text = std::fs::read_to_string(d.join("vtk2").join(kept[2])).unwrap();
    assert!(text.contains("format=\"ascii\"") && !text.contains("format=\"binary\""));
    // A re-export into the same directory leaves only its own frames.
    ok(sweep(
        d,
        &[
            "export", "--job", "1", "--vtk", "vtk", "--every", "4", "--db", "sweep.db",
        ],
    ));
    assert_eq!(
        std::fs::read_dir(d.join("vtk/particles")).unwrap().count(),
        2
    );
}

#[test]
fn a_chute_frame_carries_orientations() {
    let run = run_job(&chute_campaign());
    let d = run.path();
    let listed = frames(d);
    assert_eq!(listed.len(), 5, "{listed:?}");
    ok(sweep(d, &["export", "--job", "1", "--vtk", "vtk"]));
    let (chunk, path) = listed.last().unwrap();
    let f = read_frame(path, None).unwrap();
    assert!(f.oriented());
    let v = Vtk::read(&d.join(format!("vtk/particles/frame-{chunk:012}.vtu")));
    assert_vtu_is_frame(&d.join(format!("vtk/particles/frame-{chunk:012}.vtu")), &f);
    let q = v.tuples("orientation [1]", 4);
    let axis = v.tuples("axis [1]", 3);
    let half = &v.array("half_length [m]").values;
    let fixed = &v.array("fixed").values;
    let mut rods = 0;
    for k in 0..f.len() {
        assert_eq!(q[k], f.orientation[k].to_vec());
        let [x, y, z, w] = f.orientation[k];
        // The body z axis rotated into the lab frame: R(q) e_z.
        let expect = [
            2.0 * (x * z + w * y),
            2.0 * (y * z - w * x),
            1.0 - 2.0 * (x * x + y * y),
        ];
        for c in 0..3 {
            assert!((axis[k][c] - expect[c]).abs() < 1e-12);
        }
        let norm: f64 = axis[k].iter().map(|a| a * a).sum::<f64>().sqrt();
        assert!((norm - 1.0).abs() < 1e-9, "unit axis, got {norm}");
        if fixed[k] == 1.0 {
            assert_eq!(half[k], 0.0, "base spheres have no segment");
        } else {
            rods += 1;
            // ξ = 1.5, L = 1/8 m: d = L/ξ, l/2 = (L − d)/2.
            let l = 2.0 / 16.0;
            assert!((half[k] - (l - l / 1.5) / 2.0).abs() < 1e-12, "{}", half[k]);
        }
    }
    assert!(rods > 0 && rods < f.len(), "rods over a fixed base");

    // The chute's z profiles as a line of points along z.
    let conn = rusqlite::Connection::open(d.join("sweep.db")).unwrap();
    let mut q = conn
        .prepare("SELECT z_m, density_kg_per_m3, stress_zz_pa FROM chute_fields WHERE job_id = 1 ORDER BY z_m")
        .unwrap();
    let rows: Vec<(f64, f64, f64)> = q
        .query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))
        .unwrap()
        .map(|r| r.unwrap())
        .collect();
    assert!(rows.len() > 2);
    let fields = pvd(&d.join("vtk/fields.pvd"));
    assert_eq!(fields.len(), 1);
    assert_eq!(fields[0].1, "fields/chute_profile.vti");
    let p = Vtk::read(&d.join("vtk/fields/chute_profile.vti"));
    assert_eq!(
        p.attr("ImageData", "WholeExtent"),
        format!("0 0 0 0 0 {}", rows.len() - 1)
    );
    let origin: Vec<f64> = p
        .attr("ImageData", "Origin")
        .split_whitespace()
        .map(|t| t.parse().unwrap())
        .collect();
    let dz: f64 = p
        .attr("ImageData", "Spacing")
        .split_whitespace()
        .nth(2)
        .unwrap()
        .parse()
        .unwrap();
    let k = rows.len() / 2;
    assert!(
        (origin[2] + k as f64 * dz - rows[k].0).abs() < 1e-12,
        "height of point {k}"
    );
    assert_eq!(p.array("density [kg/m^3]").values[k], rows[k].1);
    assert_eq!(p.array("stress_zz [Pa]").values[k], rows[k].2);
}

#[test]
fn corrupt_and_truncated_frames_are_refused_by_name() {
    let run = run_job(&silo_campaign(json!({ "interval_s": 0.1 })));
    let listed = frames(run.path());
    let mut bytes = std::fs::read(&listed[2].1).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x10;
    std::fs::write(&listed[2].1, bytes).unwrap();
    let bytes = std::fs::read(&listed[3].1).unwrap();
    std::fs::write(&listed[3].1, &bytes[..bytes.len() - 100]).unwrap();
    let o = sweep(run.path(), &["export", "--job", "1", "--vtk", "vtk"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let err = stderr(&o);
    // The database path is relative, so are the frames' paths; each is named.
    assert!(
        err.contains("snapshots/frame-000000000020.snap: checksum mismatch"),
        "{err}"
    );
    assert!(
        err.contains("snapshots/frame-000000000030.snap: truncated frame"),
        "{err}"
    );
    let series = pvd(&run.path().join("vtk/particles.pvd"));
    let chunks: Vec<&str> = series.iter().map(|(_, f)| f.as_str()).collect();
    assert_eq!(
        chunks,
        [
            "particles/frame-000000000000.vtu",
            "particles/frame-000000000010.vtu",
            "particles/frame-000000000040.vtu"
        ]
    );
}

#[test]
fn without_frames_the_latest_checkpoint_is_exported_and_said() {
    let run = run_job(&silo_campaign(json!({ "interval_s": 0.1 })));
    let dir = job_dir(run.path());
    // The frames' times first: the checkpoint's frame must be on the same (the job's) clock.
    ok(sweep(
        run.path(),
        &["export", "--job", "1", "--vtk", "frames"],
    ));
    let frame_times: Vec<f64> = pvd(&run.path().join("frames/particles.pvd"))
        .into_iter()
        .map(|f| f.0)
        .collect();
    std::fs::remove_dir_all(dir.join("snapshots")).unwrap();
    let o = ok(sweep(run.path(), &["export", "--job", "1", "--vtk", "vtk"]));
    let err = stderr(&o);
    assert!(
        err.contains("job 1 has no snapshot frames")
            && err.contains("latest checkpoint")
            && err.contains("the job's clock"),
        "{err}"
    );
    let (found, _) = sweep::checkpoint::load_latest(&dir, &read_hash(run.path()));
    let (_, _, state, _) = found.unwrap();
    let series = pvd(&run.path().join("vtk/particles.pvd"));
    assert_eq!(series.len(), 1);
    // The silo's engine clock also counts the fill stage; the job's clock starts at the job.
    assert!(
        frame_times.iter().any(|&t| (t - series[0].0).abs() < 1e-12) && series[0].0 < state.time,
        "checkpoint frame at {} (engine clock {}), frames at {frame_times:?}",
        series[0].0,
        state.time
    );
    let v = Vtk::read(&run.path().join("vtk").join(&series[0].1));
    assert_eq!(v.attr("Piece", "NumberOfPoints"), state.len().to_string());
    // Particles in id order.
    let mut by_id: Vec<(u32, Vec<f64>)> = (0..state.len())
        .map(|k| (state.id[k], state.pos[k].to_f64().to_vec()))
        .collect();
    by_id.sort_by_key(|p| p.0);
    let ids: Vec<f64> = by_id.iter().map(|p| p.0 as f64).collect();
    assert!(v.array("id").values == ids, "ids in id order");
    let pos: Vec<Vec<f64>> = by_id.into_iter().map(|p| p.1).collect();
    assert!(
        v.tuples("position [m]", 3) == pos,
        "positions of the checkpoint"
    );
}

fn read_hash(run: &Path) -> String {
    rusqlite::Connection::open(run.join("sweep.db"))
        .unwrap()
        .query_row("SELECT hash FROM jobs WHERE id = 1", [], |r| r.get(0))
        .unwrap()
}

#[test]
fn a_job_resumed_from_a_checkpoint_rewrites_identical_frames() {
    let reference = run_job(&silo_campaign(json!({ "interval_s": 0.1 })));
    let expected: Vec<(u64, Vec<u8>)> = frames(reference.path())
        .into_iter()
        .map(|(c, p)| (c, std::fs::read(p).unwrap()))
        .collect();
    // Roll the job back to its older checkpoint (as after a crash), without the frames taken
    // since, and resume it.
    let run = copy_run(reference.path());
    let dir = job_dir(run.path());
    let ckpts = sweep::checkpoint::list(&dir);
    assert_eq!(ckpts.len(), 2);
    std::fs::remove_file(&ckpts[1]).unwrap();
    let (found, _) = sweep::checkpoint::load_latest(&dir, &read_hash(run.path()));
    let resume_step = found.unwrap().2.step;
    let mut removed = 0;
    for (_, p) in frames(run.path()) {
        if read_frame(&p, None).unwrap().step >= resume_step {
            std::fs::remove_file(p).unwrap();
            removed += 1;
        }
    }
    assert_eq!(
        removed, 2,
        "the frame at the checkpoint and the one after it"
    );
    rusqlite::Connection::open(run.path().join("sweep.db"))
        .unwrap()
        .execute(
            "UPDATE jobs SET status = 'paused', lease_owner = NULL WHERE id = 1",
            [],
        )
        .unwrap();
    let o = ok(sweep(
        run.path(),
        &[
            "resume",
            "--db",
            "sweep.db",
            "--backend",
            "cpu",
            "--threads",
            "1",
        ],
    ));
    assert!(stderr(&o).contains("resuming from"), "{}", stderr(&o));
    let again: Vec<(u64, Vec<u8>)> = frames(run.path())
        .into_iter()
        .map(|(c, p)| (c, std::fs::read(p).unwrap()))
        .collect();
    assert_eq!(again.len(), expected.len());
    for ((c, a), (_, b)) in again.iter().zip(&expected) {
        assert!(a == b, "frame at chunk {c} differs after the resume");
    }
}

/// A database with one registered job (id 1) that never ran.
fn store_with_a_job(dir: &Path) -> rusqlite::Connection {
    let conn = sweep::store::open(&dir.join("sweep.db")).unwrap();
    conn.execute(
        "INSERT INTO jobs (hash, scene, params_json, seed, target_time_s) VALUES (?1, 'silo', '{}', 1, 1.0)",
        ["0123456789abcdef0123456789abcdef"],
    )
    .unwrap();
    conn
}

#[test]
fn field_sets_export_as_images_with_units() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let conn = store_with_a_job(d);
    let set = |name: &str, kind: &str, shape: [usize; 3], t: (f64, f64)| FieldSet {
        id: 0,
        job_id: 1,
        name: name.into(),
        grid_kind: kind.into(),
        origin_m: [0.001, 0.02, 0.0],
        spacing_m: [0.002, 0.004, 0.0],
        shape,
        kernel_width_m: 0.003,
        cutoff_widths: 3.0,
        t_start_s: t.0,
        t_end_s: t.1,
        samples: 10,
    };
    // rz: 3 radii × 4 heights; phi = i + 10 k at radius i, height k.
    let (nr, nz) = (3, 4);
    let phi: Vec<f64> = (0..nz)
        .flat_map(|k| (0..nr).map(move |i| (i + 10 * k) as f64))
        .collect();
    let velocity: Vec<f64> = phi.iter().flat_map(|&p| [p, 0.0, -p]).collect();
    let stress: Vec<f64> = phi
        .iter()
        .flat_map(|&p| (0..9).map(move |c| p + c as f64 / 10.0))
        .collect();
    let arrays = [
        FieldArray {
            field: "phi".into(),
            units: "1".into(),
            components: 1,
            data: phi.clone(),
        },
        FieldArray {
            field: "velocity".into(),
            units: "m/s".into(),
            components: 3,
            data: velocity,
        },
        FieldArray {
            field: "contact_stress".into(),
            units: "Pa".into(),
            components: 9,
            data: stress,
        },
    ];
    save_field_set(
        &conn,
        1,
        &set("map_t0.500", "rz", [nr, nz, 1], (0.4, 0.6)),
        &arrays,
    )
    .unwrap();
    let line: Vec<f64> = (0..5).map(|k| 1000.0 + k as f64).collect();
    let density = FieldArray {
        field: "density".into(),
        units: "kg/m^3".into(),
        components: 1,
        data: line,
    };
    save_field_set(
        &conn,
        1,
        &set("profile/z", "z", [1, 1, 5], (0.0, 2.0)),
        std::slice::from_ref(&density),
    )
    .unwrap();
    // The run's time average: a file, not a time step of fields.pvd.
    save_field_set(
        &conn,
        1,
        &set("mean", "z", [1, 1, 5], (0.5, 2.5)),
        &[density],
    )
    .unwrap();
    drop(conn);

    let o = ok(sweep(d, &["export", "--job", "1", "--vtk", "out"]));
    assert!(stdout(&o).contains("3 field set(s)"), "{}", stdout(&o));
    assert!(d.join("out/fields/mean.vti").exists());
    assert!(
        stderr(&o).contains("no snapshot frames and no valid checkpoint"),
        "{}",
        stderr(&o)
    );
    assert!(!d.join("out/particles.pvd").exists());
    let series = pvd(&d.join("out/fields.pvd"));
    assert_eq!(
        series,
        vec![
            (0.5, "fields/map_t0.500.vti".to_string()),
            (1.0, "fields/profile_z.vti".to_string())
        ]
    );

    let v = Vtk::read(&d.join("out/fields/map_t0.500.vti"));
    // r along x, z along z, in the plane y = 0.
    assert_eq!(v.attr("ImageData", "WholeExtent"), "0 2 0 0 0 3");
    let nums = |s: &str| -> Vec<f64> { s.split_whitespace().map(|t| t.parse().unwrap()).collect() };
    let origin = nums(v.attr("ImageData", "Origin"));
    let spacing = nums(v.attr("ImageData", "Spacing"));
    assert_eq!(origin, vec![0.001, 0.0, 0.02]);
    assert_eq!((spacing[0], spacing[2]), (0.002, 0.004));
    // The point at r index 2, z index 3: VTK index (k·ny + j)·nx + i = 3·3 + 2.
    let p = 3 * nr + 2;
    let (x, z) = (origin[0] + 2.0 * spacing[0], origin[2] + 3.0 * spacing[2]);
    assert!((x - 0.005).abs() < 1e-15 && (z - 0.032).abs() < 1e-15);
    assert_eq!(v.array("phi [1]").values[p], 32.0);
    assert_eq!(v.array("phi [1]").values, phi);
    assert_eq!(v.tuples("velocity [m/s]", 3)[p], vec![32.0, 0.0, -32.0]);
    assert_eq!(v.tuples("contact_stress [Pa]", 9)[p][5], 32.5);
    assert_eq!(v.array("kernel_width [m]").values, vec![0.003]);
    assert_eq!(v.array("TimeValue").values, vec![0.5]);

    let v = Vtk::read(&d.join("out/fields/profile_z.vti"));
    assert_eq!(v.attr("ImageData", "WholeExtent"), "0 0 0 0 0 4");
    assert_eq!(v.array("density [kg/m^3]").values[4], 1004.0);
}

#[test]
fn export_errors_name_the_job_or_the_directory() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    drop(store_with_a_job(d));
    let o = sweep(d, &["export", "--job", "42", "--vtk", "out"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("no job 42 in the database"),
        "{}",
        stderr(&o)
    );

    let o = sweep(d, &["export", "--job", "1", "--vtk", "out"]);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert!(
        err.contains("job 1: nothing to export") && err.contains("observers.snapshots.interval_s"),
        "{err}"
    );

    let run = run_job(&silo_campaign(json!({ "interval_s": 0.2 })));
    std::fs::write(run.path().join("taken"), "a file, not a directory").unwrap();
    let o = sweep(run.path(), &["export", "--job", "1", "--vtk", "taken/vtk"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("taken/vtk: cannot write")
            && stderr(&o).contains("expected a writable directory"),
        "{}",
        stderr(&o)
    );
    let o = sweep(
        run.path(),
        &["export", "--job", "1", "--vtk", "v", "--every", "0"],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--every"), "{}", stderr(&o));
}

#[test]
fn snapshot_settings_are_validated_and_absent_ones_keep_job_hashes() {
    let dir = TempDir::new().unwrap();
    for (snapshots, expected) in [
        (
            json!({ "interval_s": 0.0 }),
            "observers.snapshots.interval_s: expected seconds > 0, got 0",
        ),
        (
            json!({ "interval_s": 0.1, "every": 2 }),
            "unknown field `every`",
        ),
    ] {
        let file = dir.path().join("bad.json");
        std::fs::write(&file, silo_campaign(snapshots).to_string()).unwrap();
        let o = sweep(dir.path(), &["launch", "bad.json", "--db", "bad.db"]);
        assert_eq!(o.status.code(), Some(2));
        assert!(stderr(&o).contains(expected), "{}", stderr(&o));
    }
    // A campaign without snapshots records no `snapshots` key, so its jobs keep their hashes.
    let mut c = silo_campaign(Value::Null);
    c["observers"].as_object_mut().unwrap().remove("snapshots");
    let file = sweep::campaign::CampaignFile::parse_str(&c.to_string(), "c.json").unwrap();
    let jobs = sweep::campaign::expand(&file, "c.json").unwrap();
    assert!(!jobs.get(0).resolved_json().contains("snapshots"));
    let with = silo_campaign(json!({ "interval_s": 0.1 }));
    let file = sweep::campaign::CampaignFile::parse_str(&with.to_string(), "c.json").unwrap();
    let with_jobs = sweep::campaign::expand(&file, "c.json").unwrap();
    assert!(with_jobs
        .get(0)
        .resolved_json()
        .contains("\"snapshots\":{\"interval_s\":0.1}"));
}
