//! The JSON Schema of campaign files (`sweep schema`, for editors and validators). Both scenes:
//! `base` is the silo's parameters when `scene` is "silo" and the chute's when "chute" (each
//! with `precision`, `backend` and the `observers.<section>.<setting>` keys a campaign may set
//! there), `sweep` and `zip` the same keys with non-empty lists of those types. Without `scene`
//! the per-scene rules do not apply; `base` then lists every parameter of either scene, for
//! completion.

use schemars::SchemaGenerator;
use serde_json::{json, Map, Value};

use super::file::{CampaignFile, JobBackend, Precision};
use crate::scene::{ChuteParams, SiloParams};

/// The schema, draft 2020-12, as JSON.
pub fn campaign_schema() -> Value {
    let mut g = SchemaGenerator::default();
    g.subschema_for::<SiloParams>();
    g.subschema_for::<ChuteParams>();
    g.subschema_for::<Precision>();
    g.subschema_for::<JobBackend>();
    let root = g.into_root_schema_for::<CampaignFile>();
    let mut schema: Value = root.into();
    let defs = schema["$defs"].as_object().cloned().unwrap_or_default();
    let observer_keys = observer_setting_keys(&defs);
    let mut scene_keys = Map::new();
    for (scene, def) in [("silo", "SiloParams"), ("chute", "ChuteParams")] {
        let mut params = defs.get(def).cloned().unwrap_or_else(|| json!({}));
        let props = params["properties"].as_object_mut().expect("struct schema");
        props.insert(
            "precision".into(),
            json!({ "$ref": "#/$defs/Precision", "description": "This job's precision (overrides run.precision)." }),
        );
        props.insert(
            "backend".into(),
            json!({
                "anyOf": [{ "$ref": "#/$defs/JobBackend" }, { "type": "null" }],
                "description": "The engine this job must run on (null: wherever `sweep launch --backend` puts it)."
            }),
        );
        for (k, v) in &observer_keys {
            props.insert(k.clone(), v.clone());
        }
        let base = json!({
            "type": "object",
            "description": format!("Parameters shared by every {scene} job (unset ones take the paper's value)."),
            "properties": props.clone(),
            "additionalProperties": false
        });
        let lists: Map<String, Value> = props
            .iter()
            .map(|(k, v)| {
                let mut item = v.clone();
                if let Some(o) = item.as_object_mut() {
                    o.remove("default");
                    o.remove("description");
                }
                (
                    k.clone(),
                    json!({ "type": "array", "minItems": 1, "items": item }),
                )
            })
            .collect();
        let lists = json!({
            "type": "object",
            "description": format!("Lists of {scene} parameter values."),
            "properties": lists,
            "additionalProperties": false
        });
        let cap = if scene == "silo" { "Silo" } else { "Chute" };
        scene_keys.insert(format!("{cap}Base"), base);
        scene_keys.insert(format!("{cap}Lists"), lists);
    }
    // `base` without a scene: every key of either scene (a key both have: either type).
    let mut union = Map::new();
    for name in ["SiloBase", "ChuteBase"] {
        for (k, v) in scene_keys[name]["properties"].as_object().expect("props") {
            match union.get(k) {
                None => {
                    union.insert(k.clone(), v.clone());
                }
                Some(old) if old == v => {}
                Some(old) => {
                    let both = json!({ "anyOf": [old.clone(), v.clone()] });
                    union.insert(k.clone(), both);
                }
            }
        }
    }
    let defs_out = schema["$defs"].as_object_mut().expect("defs");
    for (k, v) in scene_keys {
        defs_out.insert(k, v);
    }
    let props = schema["properties"].as_object_mut().expect("properties");
    props.insert(
        "base".into(),
        json!({
            "type": "object",
            "description": "Parameters shared by every job: the silo's (SiloParams) when scene is \"silo\", the chute's (ChuteParams) when \"chute\"; also `precision`, `backend` and observer settings by path (`observers.chute.sample_interval_s`).",
            "properties": union
        }),
    );
    for key in ["sweep", "zip"] {
        if let Some(o) = props.get_mut(key).and_then(Value::as_object_mut) {
            o.insert(
                "additionalProperties".into(),
                json!({ "type": "array", "minItems": 1 }),
            );
        }
    }
    let when = |scene: &str, cap: &str| {
        json!({
            "if": { "properties": { "scene": { "const": scene } }, "required": ["scene"] },
            "then": { "properties": {
                "base": { "$ref": format!("#/$defs/{cap}Base") },
                "sweep": { "$ref": format!("#/$defs/{cap}Lists") },
                "zip": { "$ref": format!("#/$defs/{cap}Lists") }
            } }
        })
    };
    schema["allOf"] = json!([when("silo", "Silo"), when("chute", "Chute")]);
    schema
}

/// `observers.<section>.<setting>` for every setting of every observer section, with its type.
fn observer_setting_keys(defs: &Map<String, Value>) -> Vec<(String, Value)> {
    let mut out = Vec::new();
    let Some(sections) = defs
        .get("Observers")
        .and_then(|o| o["properties"].as_object())
    else {
        return out;
    };
    for (section, s) in sections {
        let Some(def) = first_ref(s).and_then(|r| defs.get(r)) else {
            continue;
        };
        let Some(settings) = def["properties"].as_object() else {
            continue;
        };
        for (name, v) in settings {
            out.push((format!("observers.{section}.{name}"), v.clone()));
        }
    }
    out
}

/// The definition name of the first `$ref` in a schema (`{"$ref": …}` or inside `anyOf`).
fn first_ref(s: &Value) -> Option<&str> {
    if let Some(r) = s.get("$ref").and_then(Value::as_str) {
        return r.strip_prefix("#/$defs/");
    }
    s.get("anyOf")?.as_array()?.iter().find_map(first_ref)
}
