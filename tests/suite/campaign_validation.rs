//! Campaign integrity, end to end through the built `sweep` binary: `sweep schema` describes
//! every scene (each shipped campaign validates against it with a real JSON Schema validator,
//! misplaced or mistyped fields do not), and `sweep launch` / `sweep plan` refuse, with exit
//! status 2, a message naming the file and the JSON path, and nothing registered: impossible
//! geometry (a diameter typed in millimetres), a time step that is not finite and > 0, a job
//! larger than the machine's memory, and a key given twice.

use std::path::{Path, PathBuf};
use std::time::Duration;

use assert_cmd::Command;
use serde_json::{json, Value};
use tempfile::TempDir;

/// Longest a refused launch may take (a regression that runs the job instead is cut off here).
const PATIENCE: Duration = Duration::from_secs(120);

/// The binary, in `dir`, without a database, memory limit or log settings from the environment.
fn sweep(dir: &Path) -> Command {
    let mut c = Command::cargo_bin("sweep").unwrap();
    c.current_dir(dir)
        .env_remove("SWEEP_DB")
        .env_remove("SWEEP_MEMORY_LIMIT_BYTES")
        .timeout(PATIENCE);
    c
}

fn campaigns_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("campaigns")
}

fn read_campaign(name: &str) -> Value {
    let text = std::fs::read_to_string(campaigns_dir().join(name)).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn write(dir: &Path, file: &str, text: &str) -> PathBuf {
    let p = dir.join(file);
    std::fs::write(&p, text).unwrap();
    p
}

/// The tests' tiny silo campaign (`common::cli::campaign`), one job.
fn small_silo() -> Value {
    crate::common::cli::campaign("small_silo", &[0.02], &[0.0], 0.1)
}

struct Refusal {
    stderr: String,
    code: Option<i32>,
}

/// `sweep launch FILE --db DIR/x.db`; returns its stderr and exit status, and checks that no job
/// was registered.
fn launch(dir: &Path, campaign: &Value, extra_env: &[(&str, &str)]) -> Refusal {
    let file = write(
        dir,
        "campaign.json",
        &serde_json::to_string_pretty(campaign).unwrap(),
    );
    launch_file(dir, &file, extra_env)
}

fn launch_file(dir: &Path, file: &Path, extra_env: &[(&str, &str)]) -> Refusal {
    let db = dir.join("x.db");
    let mut c = sweep(dir);
    c.arg("launch").arg(file).arg("--db").arg(&db);
    for (k, v) in extra_env {
        c.env(k, v);
    }
    let out = c.output().unwrap();
    let r = Refusal {
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        code: out.status.code(),
    };
    assert_eq!(jobs_in(&db), 0, "jobs were registered:\n{}", r.stderr);
    r
}

/// `sweep plan FILE` (no database).
fn plan(dir: &Path, file: &Path, extra_env: &[(&str, &str)]) -> Refusal {
    let mut c = sweep(dir);
    c.arg("plan").arg(file).arg("--db").arg(dir.join("none.db"));
    for (k, v) in extra_env {
        c.env(k, v);
    }
    let out = c.output().unwrap();
    Refusal {
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        code: out.status.code(),
    }
}

/// Jobs registered in a database (0 when there is none).
fn jobs_in(db: &Path) -> i64 {
    if !db.exists() {
        return 0;
    }
    let conn = rusqlite::Connection::open(db).unwrap();
    conn.query_row("SELECT COUNT(*) FROM jobs", [], |r| r.get(0))
        .unwrap_or(0)
}

fn assert_refused(r: &Refusal, file: &str, needles: &[&str]) {
    assert_eq!(r.code, Some(2), "expected exit status 2:\n{}", r.stderr);
    assert!(
        r.stderr.contains(file),
        "the file is not named:\n{}",
        r.stderr
    );
    for n in needles {
        assert!(r.stderr.contains(n), "{n:?} missing from:\n{}", r.stderr);
    }
}

// 1. The schema.

fn schema(dir: &Path) -> Value {
    let out = sweep(dir).arg("schema").output().unwrap();
    assert!(out.status.success());
    serde_json::from_slice(&out.stdout).expect("sweep schema prints JSON")
}

#[test]
fn every_campaign_validates_against_the_schema_and_misplaced_fields_do_not() {
    let dir = TempDir::new().unwrap();
    let schema = schema(dir.path());
    let validator = jsonschema::validator_for(&schema).expect("a valid JSON Schema");
    let mut names: Vec<String> = std::fs::read_dir(campaigns_dir())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".json"))
        .collect();
    names.sort();
    let scenes: Vec<String> = names
        .iter()
        .map(|n| read_campaign(n)["scene"].as_str().unwrap().to_string())
        .collect();
    assert!(
        scenes.iter().any(|s| s == "silo") && scenes.iter().any(|s| s == "chute"),
        "campaigns/ should hold both scenes: {names:?}"
    );
    for name in &names {
        let c = read_campaign(name);
        let errors: Vec<String> = validator
            .iter_errors(&c)
            .map(|e| format!("{} at {}", e, e.instance_path()))
            .collect();
        assert!(errors.is_empty(), "{name}: {errors:#?}");
    }

    let chute = read_campaign("chute_DvsShear_quick.json");
    let refused = |c: &Value, what: &str| {
        assert!(!validator.is_valid(c), "the schema accepts {what}");
    };
    let mut c = chute.clone();
    c["base"]["inclination_deg"] = json!("steep");
    refused(&c, "a string for the chute's inclination_deg");
    let mut c = chute.clone();
    c["base"]["orifice_diameter_m"] = json!(0.02);
    refused(&c, "a silo parameter in a chute campaign's base");
    let mut c = chute.clone();
    c["zip"]["aspect_ratio"] = json!([1.3, "long", 2.0, 2.0]);
    refused(&c, "a string among a chute's zipped aspect ratios");
    let mut c = chute.clone();
    c["sweep"] = json!({ "rotation_frequency_hz": [0.0, 1.0] });
    refused(&c, "a silo parameter swept in a chute campaign");
    let mut c = read_campaign("silo_QvsF_quick.json");
    c["base"]["inclination_deg"] = json!(28.0);
    refused(&c, "a chute parameter in a silo campaign's base");
    let mut c = read_campaign("silo_QvsF_quick.json");
    c["sweep"]["orifice_diameter_m"] = json!([0.015, "wide"]);
    refused(&c, "a string among a silo's swept orifices");
    let mut c = chute;
    c["observers"]["chute"]["max_lag_s"] = json!("long");
    refused(&c, "a string for an observer setting");
}

/// Every shipped campaign passes the launch-time checks too (geometry, time step, memory).
#[test]
fn every_campaign_passes_the_launch_checks() {
    let dir = TempDir::new().unwrap();
    for e in std::fs::read_dir(campaigns_dir()).unwrap() {
        let path = e.unwrap().path();
        if path.extension().is_some_and(|x| x == "json") {
            let r = plan(dir.path(), &path, &[]);
            assert_eq!(r.code, Some(0), "{}:\n{}", path.display(), r.stderr);
        }
    }
}

// 2. Geometry.

#[test]
fn a_millimetre_orifice_is_refused_at_launch_naming_the_field_and_the_bound() {
    let dir = TempDir::new().unwrap();
    let mut c = small_silo();
    c["sweep"]["orifice_diameter_m"] = json!([0.02, 25]);
    let r = launch(dir.path(), &c, &[]);
    assert_refused(
        &r,
        "campaign.json",
        &[
            "sweep.orifice_diameter_m[1]",
            "d < D < 2 R_c − 2 d",
            "0.0484",
            "millimetres",
        ],
    );
    assert!(
        !r.stderr.contains("sweep.orifice_diameter_m[0]"),
        "{}",
        r.stderr
    );

    // A particle diameter in millimetres: larger than the container allows.
    let mut c = small_silo();
    c["base"]["particle_diameter_m"] = json!(5.8);
    let r = launch(dir.path(), &c, &[]);
    assert_refused(
        &r,
        "campaign.json",
        &["base.particle_diameter_m", "2 R_c / 3"],
    );

    // An orifice no wider than a particle.
    let mut c = small_silo();
    c["sweep"]["orifice_diameter_m"] = json!([0.005]);
    let r = launch(dir.path(), &c, &[]);
    assert_refused(
        &r,
        "campaign.json",
        &["sweep.orifice_diameter_m[0]", "d < D"],
    );
}

#[test]
fn a_bed_taller_than_the_silo_and_a_narrow_chute_box_are_refused() {
    let dir = TempDir::new().unwrap();
    let mut c = small_silo();
    c["base"]["particle_count"] = json!(20000);
    let r = launch(dir.path(), &c, &[]);
    assert_refused(
        &r,
        "campaign.json",
        &[
            "base.particle_count",
            "cylinder_height_m = 0.2",
            "at most about",
        ],
    );

    let mut c = read_campaign("chute_DvsShear_quick.json");
    // The quick campaign zips its box sizes; a narrow box set once for every job instead.
    c["zip"].as_object_mut().unwrap().remove("box_y_lengths");
    c["base"]["box_y_lengths"] = json!(2.0);
    let r = launch(dir.path(), &c, &[]);
    assert_refused(&r, "campaign.json", &["base.box_y_lengths", "≥ 4 L"]);
}

// 3. The time step.

#[test]
fn a_youngs_modulus_that_gives_no_time_step_is_refused_naming_it() {
    let dir = TempDir::new().unwrap();
    let mut c = small_silo();
    c["base"]["youngs_modulus_pa"] = json!(1e308);
    let r = launch(dir.path(), &c, &[]);
    assert_refused(
        &r,
        "campaign.json",
        &[
            "base.youngs_modulus_pa",
            "youngs_modulus_pa = 1e+308",
            "t_c = 0e0 s",
        ],
    );
    // Only the modulus is to blame, not the other inputs of t_c.
    assert!(
        !r.stderr.contains("base.particle_diameter_m"),
        "{}",
        r.stderr
    );

    // With dt_s given instead of contact_steps: the same field.
    let mut c = small_silo();
    c["base"]["youngs_modulus_pa"] = json!(1e308);
    c["base"]["dt_s"] = json!(1e-6);
    c["base"]["contact_steps"] = json!(null);
    let r = launch(dir.path(), &c, &[]);
    assert_refused(&r, "campaign.json", &["base.youngs_modulus_pa"]);

    // A finite dt whose step count does not fit in 64 bits: the modulus again.
    let mut c = small_silo();
    c["base"]
        .as_object_mut()
        .unwrap()
        .remove("youngs_modulus_pa");
    c["sweep"]["youngs_modulus_pa"] = json!([3.0e6, 1e150]);
    let r = launch(dir.path(), &c, &[]);
    assert_refused(
        &r,
        "campaign.json",
        &["sweep.youngs_modulus_pa[1]", "fits in 64 bits"],
    );

    // An endless run: the time field.
    let mut c = small_silo();
    c["base"]["discharge_time_s"] = json!(1e300);
    let r = launch(dir.path(), &c, &[]);
    assert_refused(&r, "campaign.json", &["base.discharge_time_s", "steps"]);

    // The chute: a stiffness that overflows k_n.
    let mut c = read_campaign("chute_DvsShear_quick.json");
    c["base"]["stiffness_factor"] = json!(1e308);
    let r = launch(dir.path(), &c, &[]);
    assert_refused(&r, "campaign.json", &["base.stiffness_factor"]);
}

// 4. Memory.

#[test]
fn a_billion_particles_are_refused_naming_the_field_and_the_limit() {
    let dir = TempDir::new().unwrap();
    // A silo wide and tall enough for the bed, so that memory alone is the problem.
    let mut c = small_silo();
    c["base"]["particle_count"] = json!(1_000_000_000u64);
    c["base"]["cylinder_radius_m"] = json!(5.0);
    c["base"]["cylinder_height_m"] = json!(3.0);
    let limit = (16u64 << 30).to_string();
    let r = launch(
        dir.path(),
        &c,
        &[("SWEEP_MEMORY_LIMIT_BYTES", limit.as_str())],
    );
    assert_refused(
        &r,
        "campaign.json",
        &[
            "base.particle_count",
            "1000000000",
            &limit,
            "16.0 GiB",
            "SWEEP_MEMORY_LIMIT_BYTES",
        ],
    );

    // Without the override: this machine's memory (unless it has terabytes).
    let meminfo = std::fs::read_to_string("/proc/meminfo").unwrap_or_default();
    let kb: u64 = meminfo
        .lines()
        .find(|l| l.starts_with("MemTotal:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|n| n.parse().ok())
        .unwrap_or(u64::MAX);
    if kb < 1 << 30 {
        let r = launch(dir.path(), &c, &[]);
        assert_refused(&r, "campaign.json", &["base.particle_count", "MemTotal"]);
    }

    // A small limit refuses a shipped campaign in plan too, naming the swept point it came from.
    let mut c = small_silo();
    c["zip"] = json!({ "particle_count": [300, 3000] });
    c["base"].as_object_mut().unwrap().remove("particle_count");
    let file = write(dir.path(), "zip.json", &c.to_string());
    let r = plan(
        dir.path(),
        &file,
        &[("SWEEP_MEMORY_LIMIT_BYTES", "4000000")],
    );
    assert_refused(&r, "zip.json", &["zip.particle_count[1]", "4000000 bytes"]);
    assert!(!r.stderr.contains("zip.particle_count[0]"), "{}", r.stderr);
    let r = plan(dir.path(), &file, &[("SWEEP_MEMORY_LIMIT_BYTES", "lots")]);
    assert_refused(
        &r,
        "zip.json",
        &["SWEEP_MEMORY_LIMIT_BYTES", "whole number"],
    );
}

// 5. Duplicate keys.

#[test]
fn a_duplicate_key_is_refused_naming_it() {
    let dir = TempDir::new().unwrap();
    // A JSON value cannot hold a key twice: the second is spliced into the text.
    let mut base = crate::common::cli::tiny_silo_base();
    base["orifice_diameter_m"] = json!(0.02);
    let base = serde_json::to_string_pretty(&base).unwrap().replacen(
        '{',
        "{\n  \"orifice_diameter_m\": 0.025,",
        1,
    );
    let text = format!(
        r#"{{
  "name": "dup",
  "scene": "silo",
  "base": {base},
  "sweep": {{ "rotation_frequency_hz": [0.0], "rotation_frequency_hz": [1.0] }}
}}"#
    );
    let file = write(dir.path(), "dup.json", &text);
    let r = launch_file(dir.path(), &file, &[]);
    assert_refused(
        &r,
        "dup.json",
        &[
            "dup.json: base.orifice_diameter_m: duplicate key",
            "dup.json: sweep.rotation_frequency_hz: duplicate key",
        ],
    );
    let r = plan(dir.path(), &file, &[]);
    assert_refused(&r, "dup.json", &["base.orifice_diameter_m: duplicate key"]);
}
