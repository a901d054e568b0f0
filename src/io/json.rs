//! JSON documents as untrusted input: what the top level of a file must be, typed reads that
//! keep the JSON path of an error ([`InputError`]), internally tagged objects read without
//! losing it, and keys defined twice.

use super::error::InputError;
use std::path::Path;

/// An error unless `text` starts (after whitespace) with `open`: `{` for a JSON object, `[`
/// for an array. Says what the document is instead, so that a top-level array is not reported
/// as a field of an object.
pub fn json_document(text: &str, open: &str) -> Result<(), String> {
    let want = if open == "{" {
        "one JSON object ({ … })"
    } else {
        "one JSON array ([ … ])"
    };
    let t = text.trim_start_matches([' ', '\t', '\n', '\r']);
    if t.starts_with(open) {
        return Ok(());
    }
    let found = match t.chars().next() {
        None => "is empty",
        Some('{') => "holds a JSON object",
        Some('[') => "holds a JSON array",
        Some('"') => "holds a JSON string",
        Some('t' | 'f') => "holds a JSON boolean",
        Some('n') => "holds JSON null",
        Some(c) if c == '-' || c.is_ascii_digit() => "holds a JSON number",
        Some(_) => "does not hold JSON",
    };
    Err(format!("the file must hold {want}, but it {found}"))
}

/// Deserialize `T` from JSON text with the JSON path of any error. The text must be one JSON
/// object and nothing after it but whitespace ([`json_document`]).
pub fn from_json_str<T: serde::de::DeserializeOwned>(
    file: &Path,
    text: &str,
) -> Result<T, InputError> {
    from_json_document(file, text, "{")
}

/// Deserialize `T` from JSON text that must be one JSON array ([`from_json_str`] otherwise).
pub fn from_json_array_str<T: serde::de::DeserializeOwned>(
    file: &Path,
    text: &str,
) -> Result<T, InputError> {
    from_json_document(file, text, "[")
}

/// `T` from `text`, whose top level opens with `open` (`{` or `[`) and which holds nothing
/// after the document but whitespace.
fn from_json_document<T: serde::de::DeserializeOwned>(
    file: &Path,
    text: &str,
    open: &str,
) -> Result<T, InputError> {
    read_document(text, open).map_err(|(path, m)| InputError::new(file, path, m))
}

/// `T` from `text`, whose top level opens with `open` (`{` or `[`) and which holds nothing
/// after the document but whitespace. An error is the JSON path of the field (empty for the
/// document) and what is wrong.
pub fn read_document<T: serde::de::DeserializeOwned>(
    text: &str,
    open: &str,
) -> Result<T, (String, String)> {
    json_document(text, open).map_err(|m| (String::new(), m))?;
    let mut de = serde_json::Deserializer::from_str(text);
    let v = serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let path = e.path().to_string();
        let path = if path == "." { String::new() } else { path };
        (path, format!("{}", e.into_inner()))
    })?;
    de.end().map_err(|e| {
        (
            String::new(),
            format!("{e}: nothing may follow the JSON document but whitespace"),
        )
    })?;
    Ok(v)
}

/// Deserialize an internally tagged `T` (`{"type": "gaussian", "center": …}`) from the JSON
/// object `v` at `base` within `file`, keeping the JSON path of errors inside it. `T` is written
/// as an externally tagged serde enum (`{"gaussian": {"center": …}}`), into which the object is
/// turned: serde's own internally tagged enums buffer their content and lose the path, so a
/// wrong `quantum_yield` would be blamed on its material. The tag `tag` must be a string.
pub fn from_tagged_value<T: serde::de::DeserializeOwned>(
    file: &Path,
    base: &str,
    tag: &str,
    v: &serde_json::Value,
) -> Result<T, InputError> {
    use serde_json::Value;
    let at = |f: &str| {
        if base.is_empty() {
            f.to_string()
        } else {
            format!("{base}.{f}")
        }
    };
    let Value::Object(map) = v else {
        return Err(InputError::new(
            file,
            base,
            format!("expected an object with a `{tag}`, found {}", json_kind(v)),
        ));
    };
    let kind = match map.get(tag) {
        Some(Value::String(k)) => k.clone(),
        Some(other) => {
            return Err(InputError::new(
                file,
                at(tag),
                format!(
                    "must be a string naming the type, found {}",
                    json_kind(other)
                ),
            ));
        }
        None => return Err(InputError::new(file, at(tag), "missing field")),
    };
    let mut rest = map.clone();
    rest.remove(tag);
    let mut outer = serde_json::Map::new();
    outer.insert(kind, Value::Object(rest));
    serde_path_to_error::deserialize(Value::Object(outer)).map_err(|e| {
        // The path's first segment is the variant (the tag's value): drop it. An error at the
        // top is the tag's (an unknown type), one at the variant is its object's (a missing or
        // unknown field).
        let p = e.path().to_string();
        let inner = e.into_inner().to_string();
        let path = match p.split_once('.') {
            _ if p == "." => at(tag),
            Some((_, rest)) => at(rest),
            None => base.to_string(),
        };
        InputError::new(file, path, inner)
    })
}

/// What a JSON value is, for messages.
fn json_kind(v: &serde_json::Value) -> &'static str {
    use serde_json::Value;
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

/// Deserialize `T` from a JSON value found at `base` within `file`.
pub fn from_json_value<T: serde::de::DeserializeOwned>(
    file: &Path,
    base: &str,
    v: &serde_json::Value,
) -> Result<T, InputError> {
    serde_path_to_error::deserialize(v).map_err(|e| {
        let p = e.path().to_string();
        let inner = e.into_inner();
        let path = if p == "." {
            base.to_string()
        } else {
            format!("{base}.{p}")
        };
        InputError::new(file, path, format!("{inner}"))
    })
}

/// Reject a JSON object that defines the same key twice, anywhere in `text` (serde keeps the
/// last one silently, so a second `materials.white` would replace the first). The error names
/// the JSON path of the repeated key. Malformed JSON passes: the typed parse reports it.
pub fn reject_duplicate_keys(file: &Path, text: &str) -> Result<(), InputError> {
    use serde::de::DeserializeSeed;
    let found = std::cell::RefCell::new(None);
    let mut de = serde_json::Deserializer::from_str(text);
    let walk = duplicates::Walk {
        path: String::new(),
        found: &found,
    };
    let _ = walk.deserialize(&mut de);
    match found.into_inner() {
        Some(path) => Err(InputError::new(
            file,
            path,
            "defined twice in the same object (names and keys must be unique)",
        )),
        None => Ok(()),
    }
}

/// A serde visitor that walks any JSON value, keeping the JSON path, and stops at the first
/// object key seen twice.
mod duplicates {
    use serde::de::{self, DeserializeSeed, MapAccess, SeqAccess, Visitor};
    use std::cell::RefCell;
    use std::collections::HashSet;
    use std::fmt;

    pub struct Walk<'a> {
        pub path: String,
        /// The path of the first repeated key.
        pub found: &'a RefCell<Option<String>>,
    }

    impl<'de> DeserializeSeed<'de> for Walk<'_> {
        type Value = ();
        fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
            d.deserialize_any(self)
        }
    }

    macro_rules! scalars {
        ($($f:ident: $t:ty),*) => {
            $(fn $f<E: de::Error>(self, _: $t) -> Result<(), E> { Ok(()) })*
        };
    }

    impl<'de> Visitor<'de> for Walk<'_> {
        type Value = ();
        fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
            f.write_str("any JSON value")
        }
        scalars!(visit_bool: bool, visit_i64: i64, visit_u64: u64, visit_f64: f64,
                 visit_str: &str, visit_i128: i128, visit_u128: u128);
        fn visit_unit<E: de::Error>(self) -> Result<(), E> {
            Ok(())
        }
        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
            let mut i = 0;
            loop {
                let child = Walk {
                    path: format!("{}[{i}]", self.path),
                    found: self.found,
                };
                if seq.next_element_seed(child)?.is_none() {
                    return Ok(());
                }
                i += 1;
            }
        }
        fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
            let mut seen = HashSet::new();
            while let Some(key) = map.next_key::<String>()? {
                let path = if self.path.is_empty() {
                    key.clone()
                } else {
                    format!("{}.{key}", self.path)
                };
                if !seen.insert(key) {
                    *self.found.borrow_mut() = Some(path);
                    return Err(de::Error::custom("duplicate key"));
                }
                map.next_value_seed(Walk {
                    path,
                    found: self.found,
                })?;
            }
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_top_level_is_named() {
        assert!(json_document(" \n{}", "{").is_ok());
        let e = json_document("[1, 2]", "{").unwrap_err();
        assert!(
            e.contains("must hold one JSON object") && e.contains("JSON array"),
            "{e}"
        );
        assert!(json_document("", "[").unwrap_err().contains("is empty"));
    }
}
