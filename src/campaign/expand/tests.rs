use super::*;

fn parse(s: &str) -> Result<Vec<JobSpec>, CampaignError> {
    let c = CampaignFile::parse_str(s, "t.json")?;
    expand(&c, "t.json").map(|j| j.to_vec())
}

#[test]
fn cartesian_product_and_stable_hashes() {
    let s = r#"{"name":"a","scene":"silo","base":{"particle_count":100},
        "sweep":{"orifice_diameter_m":[0.02,0.03],"rotation_frequency_hz":[0,0.5,1]},"replicas":2}"#;
    let jobs = parse(s).unwrap();
    assert_eq!(jobs.len(), 12);
    let again = parse(s).unwrap();
    assert_eq!(
        jobs.iter().map(|j| j.hash()).collect::<Vec<_>>(),
        again.iter().map(|j| j.hash()).collect::<Vec<_>>()
    );
    let mut hashes: Vec<String> = jobs.iter().map(|j| j.hash()).collect();
    hashes.sort();
    hashes.dedup();
    assert_eq!(hashes.len(), 12, "every job distinct");
    // Fill stage shared across D and f, not across replicas.
    let keys: std::collections::BTreeSet<String> = jobs.iter().map(|j| j.fill_key().0).collect();
    assert_eq!(keys.len(), 2);
}

#[test]
fn errors_name_the_path() {
    let e =
        parse(r#"{"name":"a","scene":"silo","sweep":{"orifice_diameter_m":[0.02,0.03,-0.01]}}"#)
            .unwrap_err()
            .to_string();
    assert!(
        e.contains("sweep.orifice_diameter_m[2]") && e.contains("expected metres > 0"),
        "{e}"
    );
    let e = parse(r#"{"name":"a","scene":"silo","sweep":{"orifice_diameter_m":[]}}"#)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("sweep.orifice_diameter_m") && e.contains("non-empty"),
        "{e}"
    );
    let e = parse(r#"{"name":"a","scene":"silo","base":{"orifice_diameter_m":"big"}}"#)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("base.orifice_diameter_m") && e.contains("invalid type"),
        "{e}"
    );
    let e = parse(r#"{"name":"a","scene":"silo","bogus":1}"#)
        .unwrap_err()
        .to_string();
    assert!(e.contains("unknown field `bogus`"), "{e}");
    let e = parse(r#"{"scene":"silo"}"#).unwrap_err().to_string();
    assert!(e.contains("missing field `name`"), "{e}");
    let e = parse(r#"{"name":"a","scene":"silo","base":{"orifice_diam":0.1}}"#)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("base.orifice_diam") && e.contains("unknown"),
        "{e}"
    );
}

#[test]
fn observer_settings_sweep_keeps_the_seed() {
    let jobs = parse(
        r#"{"name":"a","scene":"chute","zip":{"observers.chute.cg_width_over_length":[0.25,0.5],
            "observers.chute.sample_interval_s":[0.05,0.1]}}"#,
    )
    .unwrap();
    assert_eq!(jobs.len(), 2);
    assert_ne!(
        jobs[0].hash(),
        jobs[1].hash(),
        "observers are part of the identity"
    );
    assert_eq!(jobs[0].seed(), jobs[1].seed(), "but not of the trajectory");
    let ch = jobs[1].observers.chute.as_ref().unwrap();
    assert_eq!((ch.cg_width_over_length, ch.sample_interval_s), (0.5, 0.1));
    assert!(jobs[1]
        .label
        .contains("observers.chute.cg_width_over_length=0.5"));

    let e = parse(
        r#"{"name":"a","scene":"chute","sweep":{"observers.chute.sample_interval_s":[0.05,-1]}}"#,
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("sweep.observers.chute.sample_interval_s[1]"),
        "{e}"
    );
    let e = parse(
        r#"{"name":"a","scene":"silo","sweep":{"observers.chute.sample_interval_s":[0.05]}}"#,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("no observer section \"chute\""), "{e}");
}

#[test]
fn backend_is_a_job_parameter() {
    let jobs = parse(
        r#"{"name":"a","scene":"silo","zip":{"backend":["cpu","gpu"],"precision":["f32","f32"]}}"#,
    )
    .unwrap();
    assert_eq!(jobs[0].backend, Some(JobBackend::Cpu));
    assert_eq!(jobs[1].backend, Some(JobBackend::Gpu));
    let plain = parse(r#"{"name":"a","scene":"silo"}"#).unwrap();
    assert!(
        !plain[0].resolved_json().contains("backend"),
        "old identities unchanged"
    );
    let e = parse(r#"{"name":"a","scene":"silo","sweep":{"backend":["gpu"]}}"#)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("sweep.backend[0]") && e.contains("runs f32"),
        "{e}"
    );
}

#[test]
fn replicas_made_on_demand_differ_from_their_point_only_in_the_index() {
    let c = CampaignFile::parse_str(
        r#"{"name":"a","scene":"silo","base":{"particle_count":100},
            "sweep":{"orifice_diameter_m":[0.02,0.03]},"replicas":3}"#,
        "t.json",
    )
    .unwrap();
    let jobs = expand(&c, "t.json").unwrap();
    assert_eq!(
        (jobs.len(), jobs.points().len(), jobs.replicas()),
        (6, 2, 3)
    );
    let mut seeds = std::collections::BTreeSet::new();
    for p in 0..2 {
        let point = jobs.points()[p].resolved_json();
        for r in 0..3 {
            let made = jobs.get(p * 3 + r);
            assert_eq!(
                made.resolved_json(),
                point.replace("\"replica\":0", &format!("\"replica\":{r}")),
                "point {p}, replica {r}"
            );
            assert!(made.silo().validate().is_empty());
            assert!(
                made.label.ends_with(&format!(",replica={r}")),
                "{}",
                made.label
            );
            seeds.insert(made.seed());
        }
    }
    assert_eq!(seeds.len(), 6, "each replica its own seed");
    assert_eq!(jobs.iter().count(), 6);
    // The index is the file's `replicas`, not a parameter.
    let e = parse(r#"{"name":"a","scene":"silo","base":{"replica":2}}"#)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("base.replica") && e.contains("`replicas`"),
        "{e}"
    );
}

#[test]
fn first_replica_numbers_the_replicas_and_gives_fresh_seeds() {
    let file = |first: &str| {
        CampaignFile::parse_str(
            &format!(
                r#"{{"name":"a","scene":"silo","base":{{"particle_count":100}},
                    "sweep":{{"orifice_diameter_m":[0.02]}},"replicas":2{first}}}"#
            ),
            "t.json",
        )
        .unwrap()
    };
    let jobs = |first: &str| expand(&file(first), "t.json").unwrap().to_vec();
    let (from_0, from_5) = (jobs(""), jobs(r#","first_replica":5"#));
    assert_eq!(jobs(r#","first_replica":0"#).len(), 2);
    let labels: Vec<&str> = from_5.iter().map(|j| j.label.as_str()).collect();
    assert_eq!(
        labels,
        [
            "orifice_diameter_m=0.02,replica=5",
            "orifice_diameter_m=0.02,replica=6"
        ]
    );
    for j in &from_0 {
        assert!(
            from_5
                .iter()
                .all(|k| k.seed() != j.seed() && k.hash() != j.hash()),
            "replicas 5 and 6 share no seed or job with replicas 0 and 1"
        );
    }
    // The default leaves a file's version as it was: the field is not written when 0.
    let written = serde_json::to_string(&file(r#","first_replica":0"#)).unwrap();
    assert!(!written.contains("first_replica"), "{written}");
    let e = CampaignFile::parse_str(
        r#"{"name":"a","scene":"silo","replicas":2,"first_replica":4294967295}"#,
        "t.json",
    )
    .and_then(|c| expand(&c, "t.json").map(|_| ()))
    .unwrap_err()
    .to_string();
    assert!(e.contains("first_replica") && e.contains("32 bits"), "{e}");
}
