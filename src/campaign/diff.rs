//! The fields in which two campaign files differ, for refusing an edited campaign with the list.

use serde_json::Value;

/// "path: old -> new" for every leaf that differs between `old` and `new` (objects compared key
/// by key, lists as whole values), in path order; "(absent)" where one side lacks the field.
pub fn diff_fields(old: &Value, new: &Value) -> Vec<String> {
    let mut out = Vec::new();
    walk("", Some(old), Some(new), &mut out);
    out
}

fn walk(path: &str, old: Option<&Value>, new: Option<&Value>, out: &mut Vec<String>) {
    if let (Some(Value::Object(a)), Some(Value::Object(b))) = (old, new) {
        let mut keys: Vec<&String> = a.keys().chain(b.keys()).collect();
        keys.sort();
        keys.dedup();
        for k in keys {
            let p = if path.is_empty() {
                k.clone()
            } else {
                format!("{path}.{k}")
            };
            walk(&p, a.get(k), b.get(k), out);
        }
        return;
    }
    if old != new {
        let show = |v: Option<&Value>| v.map_or_else(|| "(absent)".to_string(), |v| v.to_string());
        out.push(format!("{path}: {} -> {}", show(old), show(new)));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn names_changed_added_and_removed_fields_by_path() {
        let a = json!({"base": {"particle_count": 300, "x": 1}, "sweep": {"d": [1, 2]}});
        let b = json!({"base": {"particle_count": 400}, "sweep": {"d": [1, 3]}, "replicas": 2});
        assert_eq!(
            diff_fields(&a, &b),
            vec![
                "base.particle_count: 300 -> 400",
                "base.x: 1 -> (absent)",
                "replicas: (absent) -> 2",
                "sweep.d: [1,2] -> [1,3]",
            ]
        );
        assert!(diff_fields(&a, &a).is_empty());
    }
}
