//! Duplicate keys in a campaign file. serde's derived structs refuse a repeated field, but
//! `base`, `sweep` and `zip` are maps, and a JSON map silently keeps the last of two equal keys:
//! `"orifice_diameter_m": 0.02, …, "orifice_diameter_m": 0.03` would run 0.03 without a word.
//! This pre-pass walks the raw text once (a `serde::de::Visitor` over every object and array)
//! and returns the JSON path of each key that appears a second time in the same object.

use std::collections::HashSet;
use std::fmt;

use serde::de::{DeserializeSeed, Deserializer, MapAccess, SeqAccess, Visitor};

/// JSON paths of the keys that repeat a key earlier in the same object, in document order
/// (`base.orifice_diameter_m`, `sweep.precision`, `observers.discharge.block_s`). Empty when
/// there are none, and for text that is not JSON (the parser then says what is wrong).
pub fn duplicate_keys(text: &str) -> Vec<String> {
    let mut found = Vec::new();
    let mut de = serde_json::Deserializer::from_str(text);
    let walk = Walk {
        path: String::new(),
        found: &mut found,
    };
    if walk.deserialize(&mut de).is_err() || de.end().is_err() {
        return Vec::new();
    }
    found
}

/// Visits one value at `path`, recording repeated keys of the objects inside it.
struct Walk<'a> {
    path: String,
    found: &'a mut Vec<String>,
}

impl Walk<'_> {
    fn key_path(&self, key: &str) -> String {
        if self.path.is_empty() {
            key.to_string()
        } else {
            format!("{}.{key}", self.path)
        }
    }
}

impl<'de> DeserializeSeed<'de> for Walk<'_> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_any(self)
    }
}

impl<'de> Visitor<'de> for Walk<'_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("any JSON value")
    }

    fn visit_bool<E>(self, _: bool) -> Result<(), E> {
        Ok(())
    }

    fn visit_i64<E>(self, _: i64) -> Result<(), E> {
        Ok(())
    }

    fn visit_u64<E>(self, _: u64) -> Result<(), E> {
        Ok(())
    }

    fn visit_f64<E>(self, _: f64) -> Result<(), E> {
        Ok(())
    }

    fn visit_str<E>(self, _: &str) -> Result<(), E> {
        Ok(())
    }

    fn visit_unit<E>(self) -> Result<(), E> {
        Ok(())
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        let mut i = 0usize;
        loop {
            let element = Walk {
                path: format!("{}[{i}]", self.path),
                found: &mut *self.found,
            };
            if seq.next_element_seed(element)?.is_none() {
                return Ok(());
            }
            i += 1;
        }
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        let mut seen = HashSet::new();
        while let Some(key) = map.next_key::<String>()? {
            let path = self.key_path(&key);
            if !seen.insert(key) {
                self.found.push(path.clone());
            }
            map.next_value_seed(Walk {
                path,
                found: &mut *self.found,
            })?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::duplicate_keys;

    #[test]
    fn repeated_keys_are_found_with_their_paths() {
        let text = r#"{"name": "a", "base": {"d": 1, "e": [{"x": 1, "x": 2}], "d": 2},
            "sweep": {"f": [1, 2]}, "base": {}}"#;
        assert_eq!(duplicate_keys(text), vec!["base.e[0].x", "base.d", "base"]);
        assert!(duplicate_keys(r#"{"a": {"b": 1}, "c": {"b": 1}}"#).is_empty());
        assert!(duplicate_keys("{not json").is_empty());
    }
}
