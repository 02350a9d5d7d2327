//! A job's point of a campaign: every resolved parameter except the replica index. Replicas are
//! the jobs of one point; reports combine exactly those (never jobs that differ in N, say).

use serde_json::Value;

/// The canonical JSON of a job's stored parameters (`jobs.params_json`) without its replica
/// index; text that is not JSON is its own point.
pub fn point_key(params_json: &str) -> String {
    let Ok(mut v) = serde_json::from_str::<Value>(params_json) else {
        return params_json.to_string();
    };
    for scene in ["silo", "chute"] {
        if let Some(Value::Object(p)) = v.get_mut(scene) {
            p.remove("replica");
        }
    }
    v.to_string()
}

/// A job label without its `replica=K` part: "a=1,b=2,replica=3" → "a=1,b=2".
pub fn label_without_replica(label: &str) -> String {
    label
        .split(',')
        .filter(|part| !part.trim_start().starts_with("replica="))
        .collect::<Vec<_>>()
        .join(",")
}

/// The numeric scene parameters of a job's stored parameters (`jobs.params_json`), by name,
/// without the replica index: what a claim's `at` picks points by.
pub fn point_params(params_json: &str) -> std::collections::BTreeMap<String, f64> {
    let mut out = std::collections::BTreeMap::new();
    let Ok(v) = serde_json::from_str::<Value>(params_json) else {
        return out;
    };
    for scene in ["silo", "chute"] {
        if let Some(Value::Object(p)) = v.get(scene) {
            for (k, x) in p {
                if let (false, Some(x)) = (k == "replica", x.as_f64()) {
                    out.insert(k.clone(), x);
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replicas_share_a_point_and_another_parameter_does_not() {
        let a = r#"{"scene":"silo","silo":{"particle_count":300,"replica":0}}"#;
        let b = r#"{"scene":"silo","silo":{"particle_count":300,"replica":1}}"#;
        let c = r#"{"scene":"silo","silo":{"particle_count":400,"replica":0}}"#;
        assert_eq!(point_key(a), point_key(b));
        assert_ne!(point_key(a), point_key(c));
    }
}
