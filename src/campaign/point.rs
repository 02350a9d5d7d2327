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
