//! Claims on a chute point's height profile (Figs. 3–5 and 7 of the chute paper): a trend up
//! the blocks of one point, a block against another block, a value held outside a range, and
//! the bed-part results refused in a block.

use std::collections::BTreeMap;

use super::*;

const XI: &str = "aspect_ratio";

fn estimate(mean: f64, se: f64) -> Estimate {
    Estimate { mean, se, dof: 4.0 }
}

/// One chute point (ξ = 2.5) with `result@k` = values[k] ± se.
fn profile(result: &str, values: &[f64], se: f64) -> Vec<PointData> {
    let results = values
        .iter()
        .enumerate()
        .map(|(k, v)| (result_key(result, Some(k as i64)), estimate(*v, se)))
        .collect();
    vec![PointData {
        label: format!("{XI}=2.5"),
        params: BTreeMap::from([(XI.to_string(), 2.5)]),
        results,
        missing: None,
        clogged: false,
        replicas_short: 0,
        particle_steps: 1.0,
    }]
}

fn claim(json: serde_json::Value) -> Claim {
    serde_json::from_value(json).expect("claim parses")
}

fn verdict(c: &Claim, points: &[PointData]) -> Verdict {
    let s = Statistic::resolve(c, "claims[0]", points, CHUTE_RESULTS, None).expect("resolves");
    decide(&s, points, look_level(1), 3)
}

fn grows_up(range: [f64; 2]) -> Claim {
    claim(
        serde_json::json!({ "id": "fig7", "statement": "l grows towards the surface",
        "trend": { "result": "correlation_length", "along": "block", "at": { XI: 2.5 },
                   "range": range, "direction": "rising" } }),
    )
}

#[test]
fn a_trend_runs_up_the_blocks_of_one_point() {
    let c = grows_up([1.0, 4.0]);
    let rising = profile("correlation_length", &[9.0, 1.0, 1.5, 2.0, 2.5, 0.1], 0.05);
    let v = verdict(&c, &rising);
    // Blocks 0 and 5 lie outside the range and are not read.
    assert_eq!(v.decision, Decision::Supported, "{v:?}");
    let falling = profile("correlation_length", &[0.0, 2.5, 2.0, 1.5, 1.0], 0.05);
    assert_eq!(verdict(&c, &falling).decision, Decision::Contradicted);
    let noisy = profile("correlation_length", &[0.0, 1.0, 1.1, 0.95, 1.05], 0.3);
    assert_eq!(verdict(&c, &noisy).decision, Decision::Undecided);
    // A block the point has no value in (no steady replica measured it) leaves it undecided.
    let v = verdict(&grows_up([1.0, 7.0]), &rising);
    assert_eq!(v.decision, Decision::Undecided);
    assert!(v.note.contains("correlation_length@6"), "{}", v.note);
}

#[test]
fn a_block_is_compared_with_another_block_of_the_same_point() {
    let c = claim(
        serde_json::json!({ "id": "base", "statement": "l at the base is shorter",
        "compare": { "result": "correlation_length", "at": { XI: 2.5 }, "block": 1,
                     "against_block": 4, "below": 1.0 } }),
    );
    let v = verdict(
        &c,
        &profile("correlation_length", &[0.0, 1.0, 1.5, 2.0, 2.5], 0.05),
    );
    assert_eq!(v.decision, Decision::Supported, "{v:?}");
    assert!((v.value - 0.4).abs() < 1e-12);
}

#[test]
fn a_result_is_compared_with_another_result_of_the_same_point() {
    let mut pts = profile("D", &[1.0], 0.1);
    pts[0]
        .results
        .insert("profile_gap_rms_base".into(), estimate(0.3, 0.02));
    pts[0]
        .results
        .insert("profile_gap_rms".into(), estimate(0.05, 0.01));
    let c = claim(
        serde_json::json!({ "id": "fig3", "statement": "the profiles part at the base",
        "compare": { "result": "profile_gap_rms_base", "at": { XI: 2.5 },
                     "against_result": "profile_gap_rms", "above": 1.0 } }),
    );
    let v = verdict(&c, &pts);
    assert_eq!(v.decision, Decision::Supported, "{v:?}");
    assert!((v.value - 6.0).abs() < 1e-12);
}

#[test]
fn outside_holds_a_value_away_from_a_range() {
    let skewed = |s: f64, se: f64| {
        let c = claim(
            serde_json::json!({ "id": "fig5", "statement": "skewed at the base",
            "compare": { "result": "vz_skewness", "at": { XI: 2.5 }, "block": 0, "value": 0.0,
                         "as": "difference", "outside": [-0.2, 0.2] } }),
        );
        verdict(&c, &profile("vz_skewness", &[s], se))
    };
    assert_eq!(skewed(0.6, 0.05).decision, Decision::Supported);
    assert_eq!(skewed(-0.6, 0.05).decision, Decision::Supported);
    assert_eq!(skewed(0.0, 0.02).decision, Decision::Contradicted);
    assert_eq!(skewed(0.2, 0.05).decision, Decision::Undecided);
    let v = skewed(0.6, 0.05);
    assert_eq!(v.side.text(), "outside [-0.2, 0.2]");
    assert!((v.gap() - 0.4).abs() < 1e-12);
}

#[test]
fn profile_claims_are_refused_by_field() {
    let pts = profile("D", &[1.0, 2.0], 0.1);
    let problem = |json: serde_json::Value| {
        Statistic::resolve(&claim(json), "claims[0]", &pts, CHUTE_RESULTS, None)
            .err()
            .expect("refused")
    };
    let e = problem(serde_json::json!({ "id": "a", "statement": "s",
        "trend": { "result": "D", "along": "block", "at": { XI: 2.5 }, "direction": "rising" } }));
    assert_eq!(e.field, "claims[0].trend.range");
    let e = problem(serde_json::json!({ "id": "a", "statement": "s",
        "trend": { "result": "D", "along": "block", "at": { XI: 2.5 }, "range": [3.0, 3.0],
                   "direction": "rising" } }));
    assert!(e.message.contains("first < last"), "{}", e.message);
    let e = problem(serde_json::json!({ "id": "a", "statement": "s",
        "compare": { "result": "profile_gap_rms", "at": { XI: 2.5 }, "block": 2, "value": 0.0,
                     "as": "difference", "below": 0.2 } }));
    assert_eq!(e.field, "claims[0].compare.block");
    let e = problem(serde_json::json!({ "id": "a", "statement": "s",
        "compare": { "result": "D", "at": { XI: 2.5 }, "block": 2, "against_block": 2,
                     "below": 1.0 } }));
    assert_eq!(e.field, "claims[0].compare.against_block");
    let e = problem(serde_json::json!({ "id": "a", "statement": "s",
        "compare": { "result": "D", "at": { XI: 2.5 }, "against_block": 1, "value": 1.0,
                     "below": 1.0 } }));
    assert!(
        e.message.contains("exactly one of 'against'"),
        "{}",
        e.message
    );
    let e = problem(serde_json::json!({ "id": "a", "statement": "s",
        "compare": { "result": "D", "at": { XI: 2.5 }, "against_result": "D", "above": 1.0 } }));
    assert_eq!(e.field, "claims[0].compare.against_result");
    let e = problem(serde_json::json!({ "id": "a", "statement": "s",
        "compare": { "result": "profile_gap_rms_base", "at": { XI: 2.5 }, "block": 1,
                     "against_result": "profile_gap_rms", "above": 1.0 } }));
    assert_eq!(e.field, "claims[0].compare.block");
    let e = problem(serde_json::json!({ "id": "a", "statement": "s",
        "compare": { "result": "D", "at": { XI: 2.5 }, "value": 1.0,
                     "within": [0.0, 1.0], "outside": [0.0, 1.0] } }));
    assert!(e.message.contains("within, outside"), "{}", e.message);
}
