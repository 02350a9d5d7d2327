//! The four tests on hand-made results (supported, contradicted, undecided, on the bound), bad
//! claims refused by field, and the repeated-looks rule on synthetic campaigns.

use std::collections::BTreeMap;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use super::*;

const D: &str = "orifice_diameter_m";
const F: &str = "rotation_frequency_hz";

fn point(d: f64, f: f64, q: f64, se: f64) -> PointData {
    PointData {
        label: format!("{D}={d},{F}={f}"),
        params: BTreeMap::from([(D.to_string(), d), (F.to_string(), f)]),
        results: BTreeMap::from([(
            "q".to_string(),
            Estimate {
                mean: q,
                se,
                dof: 20.0,
            },
        )]),
        missing: None,
        clogged: false,
        replicas_short: 0,
        particle_steps: 1e6,
    }
}

fn claim(json: serde_json::Value) -> Claim {
    serde_json::from_value(json).expect("claim parses")
}

fn verdict(c: &Claim, points: &[PointData]) -> Verdict {
    let s = Statistic::resolve(c, "claims[0]", points, SILO_RESULTS, None).expect("resolves");
    decide(&s, points, look_level(1), 7)
}

fn compare_ratio_below_one() -> Claim {
    claim(serde_json::json!({
        "id": "dip", "statement": "Q(0.3 Hz) / Q(0) < 1",
        "compare": { "result": "q", "at": { D: 0.032, F: 0.3 }, "against": { D: 0.032, F: 0.0 }, "below": 1.0 }
    }))
}

#[test]
fn compare_is_supported_contradicted_undecided_and_undecided_on_the_bound() {
    let c = compare_ratio_below_one();
    let with = |q03: f64, se: f64| vec![point(0.032, 0.0, 1.0, se), point(0.032, 0.3, q03, se)];
    let v = verdict(&c, &with(0.95, 0.005));
    assert_eq!(v.decision, Decision::Supported, "{v:?}");
    assert!((v.value - 0.95).abs() < 1e-12 && v.hi < 1.0 && v.lo < 0.95);
    assert_eq!(
        verdict(&c, &with(1.05, 0.005)).decision,
        Decision::Contradicted
    );
    assert_eq!(verdict(&c, &with(0.98, 0.03)).decision, Decision::Undecided);
    // Exactly on the bound, however precise: the interval holds 1, nothing is decided.
    let v = verdict(&c, &with(1.0, 1e-6));
    assert_eq!(v.decision, Decision::Undecided, "{v:?}");
    assert!(v.lo < 1.0 && v.hi > 1.0);
}

#[test]
fn compare_against_a_value_as_a_difference() {
    let c = claim(serde_json::json!({
        "id": "q0", "statement": "Q(0) above 0.5 kg/s",
        "compare": { "result": "q", "at": { D: 0.032, F: 0.0 }, "value": 0.5, "as": "difference", "above": 0.0 }
    }));
    let v = verdict(&c, &[point(0.032, 0.0, 0.6, 0.01)]);
    assert_eq!(v.decision, Decision::Supported);
    assert!((v.value - 0.1).abs() < 1e-12);
}

fn rising() -> Claim {
    claim(serde_json::json!({
        "id": "rise", "statement": "Q rises with f for small D",
        "trend": { "result": "q", "along": F, "at": { D: 0.015 }, "direction": "rising" }
    }))
}

#[test]
fn trend_is_decided_by_its_slope_and_refuted_by_a_reversed_step() {
    let c = rising();
    let series = |qs: [f64; 3], se: f64| -> Vec<PointData> {
        [0.0, 0.5, 1.0]
            .iter()
            .zip(qs)
            .map(|(f, q)| point(0.015, *f, q, se))
            .collect()
    };
    assert_eq!(
        verdict(&c, &series([1.0, 1.2, 1.4], 0.02)).decision,
        Decision::Supported
    );
    assert_eq!(
        verdict(&c, &series([1.4, 1.2, 1.0], 0.02)).decision,
        Decision::Contradicted
    );
    assert_eq!(
        verdict(&c, &series([1.0, 1.02, 1.01], 0.05)).decision,
        Decision::Undecided
    );
    // Rising overall, but the second step falls beyond its error: not monotonic.
    let v = verdict(&c, &series([1.0, 1.6, 1.4], 0.01));
    assert_eq!(v.decision, Decision::Contradicted, "{v:?}");
    assert!(v.note.contains("2→3"), "{}", v.note);
    // A point whose runs all clogged for good is left out, as the figures leave it out.
    let mut with_clog = series([1.0, 1.2, 1.4], 0.02);
    with_clog.insert(0, point(0.015, -0.5, f64::NAN, f64::NAN));
    with_clog[0].results.clear();
    with_clog[0].clogged = true;
    let v = verdict(&c, &with_clog);
    assert_eq!(v.decision, Decision::Supported, "{v:?}");
    assert_eq!(v.points, vec![1, 2, 3]);
    // On the bound: flat, however precise.
    let v = verdict(&c, &series([1.0, 1.0, 1.0], 1e-6));
    assert_eq!(v.decision, Decision::Undecided, "{v:?}");
}

fn dip() -> Claim {
    claim(serde_json::json!({
        "id": "min", "statement": "Q(f) has a minimum near 0.3 Hz",
        "minimum_inside": { "result": "q", "along": F, "at": { D: 0.032 }, "inside": [0.1, 0.6] }
    }))
}

#[test]
fn minimum_inside_needs_an_interior_point_below_both_ends() {
    let c = dip();
    let series = |qs: [f64; 4], se: f64| -> Vec<PointData> {
        [0.0, 0.3, 0.6, 1.0]
            .iter()
            .zip(qs)
            .map(|(f, q)| point(0.032, *f, q, se))
            .collect()
    };
    let v = verdict(&c, &series([1.0, 0.95, 0.97, 1.02], 0.005));
    assert_eq!(v.decision, Decision::Supported, "{v:?}");
    assert!((v.value - (0.95 / 1.0 - 1.0)).abs() < 1e-12, "{}", v.value);
    // Monotonic: every interior point is above the lower end.
    assert_eq!(
        verdict(&c, &series([1.0, 1.1, 1.2, 1.3], 0.005)).decision,
        Decision::Contradicted
    );
    assert_eq!(
        verdict(&c, &series([1.0, 0.98, 0.99, 1.0], 0.05)).decision,
        Decision::Undecided
    );
    // The dip is at 0.8 Hz, outside `inside`: it does not count.
    let outside = vec![
        point(0.032, 0.0, 1.0, 0.005),
        point(0.032, 0.3, 1.05, 0.005),
        point(0.032, 0.8, 0.9, 0.005),
        point(0.032, 1.0, 1.0, 0.005),
    ];
    assert_eq!(verdict(&c, &outside).decision, Decision::Contradicted);
}

fn janda(d: f64) -> f64 {
    // C = 1000, α1 = 2, α2 = 6 mm: D_min = α2 ln α1 ≈ 4.16 mm.
    1000.0 * (1.0 - 2.0 * (-d / 0.006).exp()) * d.powf(2.5)
}

#[test]
fn fit_recovers_janda_d_min_and_decides_against_a_range() {
    let ds = [0.012, 0.016, 0.02, 0.025, 0.032, 0.04];
    let pts: Vec<PointData> = ds
        .iter()
        .map(|&d| point(d, 0.0, janda(d), 0.001 * janda(d)))
        .collect();
    let inside = claim(serde_json::json!({
        "id": "dmin", "statement": "D_min", "fit": { "model": "janda", "parameter": "d_min_m", "at": { F: 0.0 }, "within": [0.002, 0.007] }
    }));
    let v = verdict(&inside, &pts);
    assert!((v.value - 0.006 * 2f64.ln()).abs() < 2e-4, "{v:?}");
    assert_eq!(v.decision, Decision::Supported, "{v:?}");
    let off = claim(serde_json::json!({
        "id": "dmin", "statement": "D_min", "fit": { "model": "janda", "parameter": "d_min_m", "at": { F: 0.0 }, "within": [0.008, 0.01] }
    }));
    assert_eq!(verdict(&off, &pts).decision, Decision::Contradicted);
    // On the bound: the fitted D_min is the range's end.
    let exact: Vec<PointData> = ds
        .iter()
        .map(|&d| point(d, 0.0, janda(d), 1e-7 * janda(d)))
        .collect();
    let d_min = verdict(&inside, &exact).value;
    let edge = claim(serde_json::json!({
        "id": "dmin", "statement": "D_min", "fit": { "model": "janda", "parameter": "d_min_m", "at": { F: 0.0 }, "within": [d_min, 0.01] }
    }));
    assert_eq!(verdict(&edge, &exact).decision, Decision::Undecided);
}

#[test]
fn fit_line_through_results() {
    let mut pts = Vec::new();
    for (k, xi) in [1.0, 1.5, 2.0, 3.0].iter().enumerate() {
        let x = 0.01 * (k as f64 + 1.0);
        let y = 2.0 * x;
        pts.push(PointData {
            label: format!("aspect_ratio={xi}"),
            params: BTreeMap::from([("aspect_ratio".to_string(), *xi)]),
            results: BTreeMap::from([
                (
                    "shear_rate_d_perp2".to_string(),
                    Estimate {
                        mean: x,
                        se: 1e-4,
                        dof: 4.0,
                    },
                ),
                (
                    "D".to_string(),
                    Estimate {
                        mean: y,
                        se: 2e-4,
                        dof: 4.0,
                    },
                ),
            ]),
            missing: None,
            clogged: false,
            replicas_short: 0,
            particle_steps: 1.0,
        });
    }
    let r = claim(serde_json::json!({
        "id": "r", "statement": "D ∝ γ̇ d⊥², R ≥ 0.9",
        "fit": { "model": "proportional", "parameter": "r", "x": "shear_rate_d_perp2", "y": "D", "above": 0.9 }
    }));
    let s = Statistic::resolve(&r, "claims[0]", &pts, CHUTE_RESULTS, None).unwrap();
    let v = decide(&s, &pts, look_level(1), 1);
    assert_eq!(v.decision, Decision::Supported, "{v:?}");
}

#[test]
fn bad_claims_are_refused_by_field() {
    let pts = vec![point(0.032, 0.0, 1.0, 0.01), point(0.032, 0.3, 1.0, 0.01)];
    let problem = |json: serde_json::Value| {
        Statistic::resolve(&claim(json), "claims[0]", &pts, SILO_RESULTS, None)
            .err()
            .expect("refused")
    };
    let e = problem(serde_json::json!({ "id": "a", "statement": "s",
        "compare": { "result": "D", "at": { D: 0.032, F: 0.0 }, "value": 1.0, "below": 1.0 } }));
    assert_eq!(e.field, "claims[0].compare.result");
    assert!(e.message.contains("expected one of q"), "{}", e.message);
    let e = problem(serde_json::json!({ "id": "a", "statement": "s",
        "compare": { "result": "q", "at": { D: 0.05, F: 0.0 }, "value": 1.0, "below": 1.0 } }));
    assert_eq!(e.field, "claims[0].compare.at");
    assert!(e.message.contains("no point"), "{}", e.message);
    let e = problem(serde_json::json!({ "id": "a", "statement": "s",
        "compare": { "result": "q", "at": { D: 0.032 }, "value": 1.0, "below": 1.0 } }));
    assert!(e.message.contains("2 points"), "{}", e.message);
    let e = problem(serde_json::json!({ "id": "a", "statement": "s",
        "compare": { "result": "q", "at": { D: 0.032, F: 0.0 }, "value": 1.0 } }));
    assert!(
        e.message.contains("exactly one of below, above, within"),
        "{}",
        e.message
    );
    let e = problem(serde_json::json!({ "id": "a", "statement": "s" }));
    assert!(e.message.contains("got none"), "{}", e.message);
    let e = problem(serde_json::json!({ "id": "a", "statement": "s",
        "fit": { "model": "janda", "parameter": "beta", "below": 1.0 } }));
    assert_eq!(e.field, "claims[0].fit.parameter");
    let e = problem(serde_json::json!({ "id": "a", "statement": "s",
        "trend": { "result": "q", "along": "gravity", "at": {}, "direction": "rising" } }));
    assert_eq!(e.field, "claims[0].trend.along");
    assert!(serde_json::from_value::<Claim>(
        serde_json::json!({ "id": "a", "statement": "s", "colour": 1 })
    )
    .is_err());
}

/// Synthetic campaigns with no effect: two points with the same true Q, blocks added round
/// after round, the compare claim looked at after every round.
fn false_verdicts(campaigns: u64, looks: u32, level: f64) -> usize {
    let c = compare_ratio_below_one();
    let noise = Normal::new(1.0, 0.1).unwrap();
    let mut false_count = 0;
    for k in 0..campaigns {
        let mut rng = ChaCha8Rng::seed_from_u64(1000 + k);
        let mut blocks: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
        for look in 0..looks {
            let n = 4usize << look.min(4);
            for b in &mut blocks {
                while b.len() < n {
                    b.push(noise.sample(&mut rng));
                }
            }
            let est = |b: &[f64]| {
                let m = b.iter().sum::<f64>() / b.len() as f64;
                let var = b.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (b.len() - 1) as f64;
                (m, (var / b.len() as f64).sqrt(), (b.len() - 1) as f64)
            };
            let (m0, s0, d0) = est(&blocks[0]);
            let (m1, s1, d1) = est(&blocks[1]);
            let mut p0 = point(0.032, 0.0, m0, s0);
            let mut p1 = point(0.032, 0.3, m1, s1);
            p0.results.get_mut("q").unwrap().dof = d0;
            p1.results.get_mut("q").unwrap().dof = d1;
            let pts = vec![p0, p1];
            let s = Statistic::resolve(&c, "claims[0]", &pts, SILO_RESULTS, None).unwrap();
            if decide(&s, &pts, level, seed_of("synthetic", "dip", look)).decision
                != Decision::Undecided
            {
                false_count += 1;
                break;
            }
        }
    }
    false_count
}

#[test]
fn repeated_looks_keep_false_verdicts_at_five_percent() {
    let looks = 9;
    let split = false_verdicts(200, looks, look_level(looks));
    assert!(
        split <= 10,
        "{split} of 200 campaigns reached a false verdict (≤ 10 expected)"
    );
    // The rule matters: 95 % at every look decides far more often on no effect.
    let naive = false_verdicts(200, looks, 0.95);
    println!(
        "false verdicts in 200 campaigns of {looks} looks: α split {split}, 95 % per look {naive}"
    );
    assert!(naive > split && naive > 10, "naive {naive}, split {split}");
}

/// The α that looks at `levels` spend together.
fn alpha_of(levels: &[f64]) -> f64 {
    levels.iter().map(|l| 1.0 - l).sum()
}

#[test]
fn a_campaign_whose_looks_never_changed_looks_at_the_even_split() {
    let even = look_level(9);
    for look in 0..9 {
        let before = vec![even; look as usize];
        assert_eq!(spending_level(9, look, 0.0, &before), Some(even));
    }
}

#[test]
fn raising_the_looks_mid_campaign_spends_no_more_than_alpha() {
    // Five looks at 9 planned, then max_rounds raised to 16 (17 looks): the rest share what
    // the first five left, where 17 looks at the new even split would spend 6.3 %.
    let mut levels = vec![look_level(9); 5];
    for look in 5..17 {
        let l = spending_level(17, look, 0.0, &levels).expect("α left");
        assert!(l < 1.0 && l > look_level(9), "look {look}: {l}");
        levels.push(l);
    }
    let spent = alpha_of(&levels);
    assert!((spent - ALPHA).abs() < 1e-12, "spent {spent}");
    assert!(alpha_of(&[look_level(9); 5]) + 12.0 * (1.0 - look_level(17)) > ALPHA);
}

#[test]
fn a_new_version_spends_only_what_its_earlier_ones_left() {
    // Version 1 took 5 of 9 looks; version 2 plans 4 more rounds (5 looks) of its own.
    let carried = alpha_of(&[look_level(9); 5]);
    let mut levels = Vec::new();
    for look in 5..10 {
        levels.push(spending_level(10, look, carried, &levels).expect("α left"));
    }
    assert!((carried + alpha_of(&levels) - ALPHA).abs() < 1e-12);
    // Once α is spent, no look can decide anything.
    assert_eq!(spending_level(12, 10, ALPHA, &[]), None);
    assert_eq!(spending_level(12, 11, carried, &levels), None);
}
