//! The work forecast on hand-made results: at many degrees of freedom it is the width's
//! (half-width / gap)², where an interval rests on few replicas it is far less, and a value on
//! its bound gets none.

use std::collections::BTreeMap;

use super::*;

const D: &str = "orifice_diameter_m";
const F: &str = "rotation_frequency_hz";

fn point(f: f64, q: f64, se: f64, dof: f64) -> PointData {
    PointData {
        label: format!("{D}=0.032,{F}={f}"),
        params: BTreeMap::from([(D.to_string(), 0.032), (F.to_string(), f)]),
        results: BTreeMap::from([("q".to_string(), Estimate { mean: q, se, dof })]),
        missing: None,
        clogged: false,
        replicas_short: 0,
        particle_steps: 1e6,
    }
}

/// Q(0.3 Hz) / Q(0) < 1, at Q(0) = 1 and the given Q(0.3 Hz), each with `se` on `dof`.
fn dip(q: f64, se: f64, dof: f64) -> (Statistic, Vec<PointData>) {
    let c: Claim = serde_json::from_value(serde_json::json!({
        "id": "dip", "statement": "Q(0.3 Hz) / Q(0) < 1",
        "compare": { "result": "q", "at": { D: 0.032, F: 0.3 }, "against": { D: 0.032, F: 0.0 }, "below": 1.0 }
    }))
    .expect("claim parses");
    let points = vec![point(0.0, 1.0, se, dof), point(0.3, q, se, dof)];
    let s = Statistic::resolve(&c, "claims[0]", &points, SILO_RESULTS, None).expect("resolves");
    (s, points)
}

const LEVEL: f64 = 0.995;

#[test]
fn at_many_degrees_of_freedom_the_forecast_is_the_widths() {
    // Normal draws on the same seed shrink as 1/√k about the value: the upper end, the one
    // against the bound, reaches it at k = ((hi − value) / gap)².
    let (s, p) = dip(0.998, 0.002, 1e9);
    let v = decide(&s, &p, LEVEL, 7);
    assert_eq!(v.decision, Decision::Undecided, "{v:?}");
    let by_width = ((v.hi - v.value) / v.gap()).powi(2);
    let k = work_to_decide(&s, &p, LEVEL, 7).expect("decidable");
    assert!((k / by_width - 1.0).abs() < 0.1, "{k} against {by_width}");
}

#[test]
fn on_few_replicas_the_tails_not_the_error_set_the_work() {
    // The same errors on 2 degrees of freedom (three replicas' spread): a far wider interval,
    // which a third of the work with its replicas narrows far more than 1/√work says.
    let (s, p) = dip(0.998, 0.002, 2.0);
    let v = decide(&s, &p, LEVEL, 7);
    assert_eq!(v.decision, Decision::Undecided, "{v:?}");
    let by_width = (v.half_width() / v.gap()).powi(2);
    let k = work_to_decide(&s, &p, LEVEL, 7).expect("decidable");
    assert!(k < by_width / 3.0, "{k} against the width's {by_width}");
    // By then the replicas are many and the tails nearly normal: about the work at many
    // degrees of freedom (other draws, so not the same bits).
    let (s_inf, p_inf) = dip(0.998, 0.002, 1e9);
    let k_inf = work_to_decide(&s_inf, &p_inf, LEVEL, 7).expect("decidable");
    assert!((k / k_inf - 1.0).abs() < 0.2, "{k} against {k_inf}");
    // And at that work the claim is decided, a little short of it not.
    let scaled = |k: f64| -> Vec<PointData> {
        p.iter()
            .map(|x| {
                let mut x = x.clone();
                let e = x.results["q"];
                x.results.insert(
                    "q".into(),
                    Estimate {
                        mean: e.mean,
                        se: e.se / k.sqrt(),
                        dof: (e.dof + 1.0) * k - 1.0,
                    },
                );
                x
            })
            .collect()
    };
    assert_ne!(
        decide(&s, &scaled(k), LEVEL, 7).decision,
        Decision::Undecided
    );
    assert_eq!(
        decide(&s, &scaled(0.95 * k), LEVEL, 7).decision,
        Decision::Undecided
    );
}

#[test]
fn a_value_on_its_bound_gets_no_forecast() {
    let (s, p) = dip(1.0, 0.01, 20.0);
    assert_eq!(work_to_decide(&s, &p, LEVEL, 7), None);
}
