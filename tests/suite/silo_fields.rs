//! The silo's field observer end to end (`sweep launch`, `sweep fields`): a tiny silo campaign
//! with `observers.fields` stores its field sets and series; killed with SIGKILL after a
//! discharge checkpoint and resumed, it stores the same bytes as an uninterrupted run (the
//! observer's sums travel in the checkpoint); `sweep fields --job` lists the sets; settings that
//! do not fit the job are refused with file, path and expectation.

use std::path::{Path, PathBuf};
use std::process::{Output, Stdio};
use std::time::{Duration, Instant};

use rusqlite::{Connection, OpenFlags};
use serde_json::{json, Value};
use sweep::store::fields::{list_field_sets, load_field_arrays, load_field_series};
use tempfile::TempDir;

/// The tiny silo campaign (`common::cli::campaign`), one job (D = 20 mm, 1 Hz), with the
/// field observer.
fn campaign(checkpoint_interval_s: f64) -> Value {
    let mut c = crate::common::cli::campaign("tiny_fields", &[0.02], &[1.0], checkpoint_interval_s);
    c["observers"]["fields"] = json!({
        "sample_interval_s": 0.05,
        "map_times_s": [0.2],
        "map_window_s": 0.1,
        "mean_start_s": 0.1,
        "contact_stress": true
    });
    c
}

fn write(dir: &Path, c: &Value) -> PathBuf {
    let p = dir.join("tiny_fields.json");
    std::fs::write(&p, serde_json::to_string_pretty(c).unwrap()).unwrap();
    p
}

fn cmd(dir: &Path, args: &[&str]) -> Output {
    std::process::Command::new(crate::common::cli::bin())
        .args(args)
        .current_dir(dir)
        .env_remove("SWEEP_DB")
        .output()
        .unwrap()
}

fn launch_args<'a>(file: &'a str, db: &'a str) -> Vec<&'a str> {
    vec![
        "launch",
        file,
        "--db",
        db,
        "--backend",
        "cpu",
        "--threads",
        "1",
    ]
}

/// A field array as stored: (set name, field, bytes).
type StoredArray = (String, String, Vec<u8>);
/// A series row: (name, t, value, flowing).
type StoredSeries = (String, f64, f64, Option<i64>);

/// Every field array and series row of job 1, sorted.
fn stored(db: &Path) -> (Vec<StoredArray>, Vec<StoredSeries>) {
    let c = Connection::open_with_flags(db, OpenFlags::SQLITE_OPEN_READ_ONLY).unwrap();
    let mut q = c
        .prepare(
            "SELECT s.name, a.field, a.data FROM field_arrays a JOIN field_sets s ON a.set_id = s.id
             WHERE s.job_id = 1 ORDER BY s.name, a.field",
        )
        .unwrap();
    let arrays = q
        .query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))
        .unwrap()
        .collect::<Result<Vec<_>, _>>()
        .unwrap();
    let mut q = c
        .prepare(
            "SELECT name, t_s, value, flowing FROM silo_field_series WHERE job_id = 1 ORDER BY name, t_s",
        )
        .unwrap();
    let series = q
        .query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?)))
        .unwrap()
        .collect::<Result<Vec<_>, _>>()
        .unwrap();
    (arrays, series)
}

#[test]
fn fields_are_stored_listed_and_identical_after_kill_and_resume() {
    // Uninterrupted reference.
    let a = TempDir::new().unwrap();
    let file = write(a.path(), &campaign(0.05));
    let db = a.path().join("sweep.db");
    let o = cmd(
        a.path(),
        &launch_args(file.to_str().unwrap(), db.to_str().unwrap()),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let reference = stored(&db);
    let conn = sweep::store::open(&db).unwrap();
    let sets = list_field_sets(&conn, 1).unwrap();
    let names: Vec<&str> = sets.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["map_t0.200", "mean", "mean_flowing"]);
    let mean = &sets[1];
    assert_eq!(mean.grid_kind, "rz");
    // Samples every 0.05 s from 0.1 s to 0.4 s: 7; the map's window 0.15..0.25 s: 3.
    assert_eq!(mean.samples, 7, "{mean:?}");
    assert_eq!(sets[0].samples, 3, "{:?}", sets[0]);
    let arrays = load_field_arrays(&conn, mean.id).unwrap();
    let fields: Vec<&str> = arrays.iter().map(|a| a.field.as_str()).collect();
    for want in [
        "contact_stress",
        "density",
        "kinetic_pressure",
        "kinetic_stress",
        "momentum",
        "phi",
        "velocity",
    ] {
        assert!(fields.contains(&want), "{fields:?}");
    }
    let phi = arrays.iter().find(|a| a.field == "phi").unwrap();
    let max_phi = phi.data.iter().fold(0.0f64, |m, v| m.max(*v));
    assert!(
        max_phi > 0.4 && max_phi < 0.8,
        "the bed's solid fraction peaks at {max_phi}, expected a packing's 0.5–0.7"
    );
    let (pk, units) = load_field_series(&conn, 1, "orifice_kinetic_pressure")
        .unwrap()
        .unwrap();
    assert_eq!(units, "Pa");
    assert_eq!(pk.len(), 7);
    assert!(pk.iter().all(|(_, v)| *v >= 0.0), "tr σᵏ ≥ 0: {pk:?}");
    // The flowing mean holds exactly the samples flagged flowing in the series (same times).
    let flags =
        sweep::store::fields::load_flagged_series(&conn, 1, "orifice_kinetic_pressure").unwrap();
    assert!(flags.iter().all(|s| s.flowing.is_some()), "{flags:?}");
    let flowing = flags.iter().filter(|s| s.flowing == Some(true)).count();
    assert!(flowing > 0, "a 20 mm orifice at 1 Hz flows: {flags:?}");
    assert_eq!(sets[2].samples as usize, flowing, "{:?} {flags:?}", sets[2]);

    // `sweep fields --job 1` lists both sets and their fields with units.
    let o = cmd(
        a.path(),
        &["fields", "--job", "1", "--db", db.to_str().unwrap()],
    );
    assert!(o.status.success());
    let out = String::from_utf8_lossy(&o.stdout);
    for want in [
        "map_t0.200",
        "mean",
        "[rz]",
        "kinetic_pressure",
        "kg/m^3",
        "7 sample(s)",
    ] {
        assert!(out.contains(want), "missing {want:?} in:\n{out}");
    }
    let o = cmd(
        a.path(),
        &["fields", "--job", "99", "--db", db.to_str().unwrap()],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("no job 99"));

    // A round that runs the job on keeps it in the fields figures, from its earlier end, named
    // in the title (fig10 and fig11 draw every orifice and f: the only job).
    drop(conn);
    let mut conn = sweep::store::open(&db).unwrap();
    let figs = a.path().join("figs");
    let tx = conn.transaction().unwrap();
    assert!(sweep::store::targets::extend(&tx, 1, 0.8, 0.8).unwrap());
    tx.commit().unwrap();
    for figure in ["fig9", "fig10", "fig11"] {
        sweep::report::render_figure(&conn, figure, None, &figs).unwrap();
        let svg = std::fs::read_to_string(figs.join(format!("{figure}.svg"))).unwrap();
        assert!(
            svg.contains("earlier end of job(s) a round runs on: 1 (to 0.8 s)"),
            "{figure}'s title does not name job 1"
        );
    }

    // Killed after its first discharge checkpoint, then resumed: the same bytes.
    let b = TempDir::new().unwrap();
    let file = write(b.path(), &campaign(0.05));
    let db_b = b.path().join("sweep.db");
    let log = std::fs::File::create(b.path().join("launch.log")).unwrap();
    let mut child = std::process::Command::new(crate::common::cli::bin())
        .args(launch_args(file.to_str().unwrap(), db_b.to_str().unwrap()))
        .current_dir(b.path())
        .env_remove("SWEEP_DB")
        .stdin(Stdio::null())
        .stdout(log.try_clone().unwrap())
        .stderr(log)
        .spawn()
        .unwrap();
    let jobs = b.path().join("sweep-work").join("sweep").join("jobs");
    let t0 = Instant::now();
    loop {
        let any = std::fs::read_dir(&jobs)
            .into_iter()
            .flatten()
            .flatten()
            .any(|e| !sweep::checkpoint::list(&e.path()).is_empty());
        if any {
            break;
        }
        assert!(
            child.try_wait().unwrap().is_none(),
            "the job finished before a discharge checkpoint was seen"
        );
        assert!(t0.elapsed() < Duration::from_secs(120), "no checkpoint");
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let o = cmd(
        b.path(),
        &[
            "resume",
            "--db",
            db_b.to_str().unwrap(),
            "--stale-after",
            "0",
            "--backend",
            "cpu",
            "--threads",
            "1",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let resumed = stored(&db_b);
    assert_eq!(resumed.1, reference.1, "series differ after resume");
    assert_eq!(resumed.0.len(), reference.0.len());
    for (x, y) in resumed.0.iter().zip(&reference.0) {
        assert!(x == y, "{} {} differs after resume", x.0, x.1);
    }
}

#[test]
fn field_settings_that_do_not_fit_the_job_are_refused() {
    let d = TempDir::new().unwrap();
    let refused = |edit: &dyn Fn(&mut Value), wants: &[&str]| {
        let mut c = campaign(0.05);
        edit(&mut c);
        let file = write(d.path(), &c);
        let db = d.path().join("s.db");
        let o = cmd(
            d.path(),
            &launch_args(file.to_str().unwrap(), db.to_str().unwrap()),
        );
        assert_eq!(o.status.code(), Some(2));
        let err = String::from_utf8_lossy(&o.stderr);
        for want in wants {
            assert!(err.contains(want), "missing {want:?} in:\n{err}");
        }
    };
    refused(
        &|c| c["observers"]["fields"]["cutoff_widths"] = json!(-1.0),
        &[
            "tiny_fields.json",
            "observers.fields.cutoff_widths: expected widths > 0, got -1",
        ],
    );
    refused(
        &|c| {
            c["observers"]["fields"]["map_times_s"] = json!([0.2, 3.0]);
            c["observers"]["fields"]["sample_interval_s"] = json!(0.015);
        },
        &[
            "tiny_fields.json",
            "observers.fields.map_times_s[1]: expected a time within discharge_time_s = 0.4 s, got 3",
            "observers.fields.sample_interval_s: expected a whole multiple of observers.discharge.sample_interval_s",
        ],
    );
}

/// A field set saved, listed and loaded gives back its grid, window and arrays exactly (blobs
/// are little-endian f64, point-major); saving a set of the same name replaces it; a job-local
/// store's sets copy into another store with fresh ids (the Slurm ingestion path).
#[test]
fn field_sets_round_trip_through_the_store() {
    use sweep::store::fields::{
        copy_job_fields, save_field_series, save_field_set, FieldArray, FieldSet,
    };
    let d = TempDir::new().unwrap();
    let add_job = |c: &Connection, hash: &str| {
        c.execute(
            "INSERT INTO jobs (hash, scene, params_json, seed, target_time_s) VALUES (?1, 'silo', '{}', 1, 1.0)",
            [hash],
        )
        .unwrap();
        c.last_insert_rowid()
    };
    let set = FieldSet {
        id: 0,
        job_id: 0,
        name: "mean".into(),
        grid_kind: "rz".into(),
        origin_m: [0.00145, -0.0203, 0.0],
        spacing_m: [0.0029, 0.0029, 0.0],
        shape: [2, 3, 1],
        kernel_width_m: 0.0029,
        cutoff_widths: 3.0,
        t_start_s: 0.5,
        t_end_s: 2.5,
        samples: 41,
    };
    let arrays = vec![
        FieldArray {
            field: "phi".into(),
            units: "1".into(),
            components: 1,
            data: vec![0.1, 0.2, 0.3, 0.4, 0.5, 0.6],
        },
        FieldArray {
            field: "velocity".into(),
            units: "m/s".into(),
            components: 3,
            data: (0..18).map(|k| k as f64 * -0.25).collect(),
        },
    ];
    let src_path = d.path().join("local.db");
    let src = sweep::store::open(&src_path).unwrap();
    let job = add_job(&src, "a");
    save_field_set(&src, job, &set, &arrays).unwrap();
    save_field_set(&src, job, &set, &arrays).unwrap(); // replaces, not duplicates
    save_field_series(
        &src,
        job,
        "orifice_kinetic_pressure",
        "Pa",
        &[(0.5, 1.5), (0.55, 2.5)],
        None,
    )
    .unwrap();
    let sets = list_field_sets(&src, job).unwrap();
    assert_eq!(sets.len(), 1);
    assert_eq!(
        sets[0],
        FieldSet {
            id: sets[0].id,
            job_id: job,
            ..set.clone()
        }
    );
    assert_eq!(load_field_arrays(&src, sets[0].id).unwrap(), arrays);
    let blob: Vec<u8> = src
        .query_row(
            "SELECT data FROM field_arrays WHERE field = 'phi'",
            [],
            |r| r.get(0),
        )
        .unwrap();
    assert_eq!(
        &blob[8..16],
        &0.2f64.to_le_bytes(),
        "point 1 is the second 8 bytes"
    );
    let (series, units) = load_field_series(&src, job, "orifice_kinetic_pressure")
        .unwrap()
        .unwrap();
    assert_eq!(
        (series, units.as_str()),
        (vec![(0.5, 1.5), (0.55, 2.5)], "Pa")
    );
    // A wrong length is refused.
    let mut bad = arrays.clone();
    bad[1].data.pop();
    assert!(save_field_set(&src, job, &set, &bad).is_err());
    drop(src);

    // Into a main store where another job's set already holds the ids the local store used.
    let mut main = sweep::store::open(&d.path().join("main.db")).unwrap();
    let job_main = add_job(&main, "a");
    assert_eq!(job_main, job);
    let other = add_job(&main, "x");
    for k in 0..3 {
        let s = FieldSet {
            name: format!("other{k}"),
            ..set.clone()
        };
        save_field_set(&main, other, &s, &arrays).unwrap();
    }
    main.execute(
        "ATTACH DATABASE ?1 AS job_result",
        [src_path.to_str().unwrap()],
    )
    .unwrap();
    let tx = main.transaction().unwrap();
    assert_eq!(copy_job_fields(&tx, "job_result", job_main).unwrap(), 1);
    tx.commit().unwrap();
    let got = list_field_sets(&main, job_main).unwrap();
    assert_eq!(got.len(), 1);
    assert_eq!(load_field_arrays(&main, got[0].id).unwrap(), arrays);
    let o = list_field_sets(&main, other).unwrap();
    assert_eq!(load_field_arrays(&main, o[0].id).unwrap(), arrays);
}

/// The kinetic stress σᵏ = Σ m (v − V)⊗(v − V) φ at one grid point, against a case worked by
/// hand: three particles 2 mm from the point (so one kernel value φ for all), w = 3 mm, c = 3.
/// φ(a) = e^{−a²/2w²} / ((2π w²)^{3/2} [erf(3/√2) − √(2/π) 3 e^{−9/2}]) = 1.9398468e6 m⁻³;
/// V = Σ m v / Σ m = (−2/9, 2/9, 2/3) m/s; tr σᵏ = φ Σ m |v − V|² = 13 686.697 Pa and
/// σᵏ_xy = −1 508.7698 Pa (worked out with these numbers in Python, not with sweep's code).
#[test]
fn kinetic_stress_matches_a_hand_computed_case() {
    use sweep::observe::coarse_grain::{FieldGrid, GridFields, Kernel};
    let (w, a) = (0.003, 0.002);
    let grid = FieldGrid::xyz([-0.01; 3], [0.01; 3], 0.005);
    let mut f = GridFields::new(grid);
    let pos = [[a, 0.0, 0.0], [-a, 0.0, 0.0], [0.0, a, 0.0]];
    let vel = [[1.0, 0.0, 0.0], [-1.0, 0.5, 0.0], [0.0, 0.0, 2.0]];
    let mass = [1e-3, 2e-3, 1.5e-3];
    f.deposit_particles(&Kernel::new(w, 3.0), &pos, &vel, &mass);
    let origin = grid.index(2, 2, 2);
    assert_eq!(grid.coord(0, 2), 0.0);

    // By hand: the truncated Gaussian's normalisation and its value at a.
    let erf_3_over_sqrt2 = 0.997_300_203_936_739_8; // P(|Z| < 3) of a standard normal
    let inner = erf_3_over_sqrt2 - (2.0 / std::f64::consts::PI).sqrt() * 3.0 * (-4.5f64).exp();
    let phi =
        (-a * a / (2.0 * w * w)).exp() / ((2.0 * std::f64::consts::PI * w * w).powf(1.5) * inner);
    assert!(
        (phi / 1.939_846_838_826_286_6e6 - 1.0).abs() < 1e-12,
        "φ = {phi}"
    );
    let v_mean = [-2.0 / 9.0, 2.0 / 9.0, 2.0 / 3.0];
    let mut hand = [0.0; 9];
    for (v, m) in vel.iter().zip(mass) {
        for i in 0..3 {
            for j in 0..3 {
                hand[3 * i + j] += phi * m * (v[i] - v_mean[i]) * (v[j] - v_mean[j]);
            }
        }
    }
    let s = f.kinetic_stress(origin);
    let rel = |x: f64, y: f64| ((x - y) / y).abs();
    let trace = s[0] + s[4] + s[8];
    assert!(rel(trace, 13_686.697_140_607_692) < 1e-9, "tr σᵏ = {trace}");
    assert!(
        rel(s[1], -1_508.769_763_531_556_5) < 1e-9,
        "σᵏ_xy = {}",
        s[1]
    );
    for k in 0..9 {
        assert!(
            (s[k] - hand[k]).abs() <= 1e-9 * trace,
            "σᵏ[{k}] = {} vs {} by hand",
            s[k],
            hand[k]
        );
    }
    // The density and the velocity at the point, by the same hand.
    assert!(rel(f.density[origin], phi * 4.5e-3) < 1e-12);
    assert!(rel(f.momentum[3 * origin + 2], phi * 1.5e-3 * 2.0) < 1e-12);
}
