//! Scene overrides: set values at dot paths (`media.fluid.sigma_a`) in a scene's JSON and load
//! the text back. The parameter grid and the sweep both render scenes changed this way.

use serde_json::Value;
use std::path::Path;

/// What to do when the last key of a path is missing from its object.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Missing {
    /// Insert it (a field left to its default, e.g. a material's `concentration`).
    Insert,
    /// Fail: the path must name a field the scene file has.
    Fail,
}

/// Set the value at the dot path `path` (object keys only) in `v` to `x`. Every object on the
/// way must exist; the last key must too unless `missing` is [`Missing::Insert`]. The error
/// says which key is missing or which value is not an object.
pub fn set(v: &mut Value, path: &str, x: Value, missing: Missing) -> Result<(), String> {
    let keys: Vec<&str> = path.split('.').collect();
    if keys.iter().any(|k| k.is_empty()) {
        return Err(format!("{path:?} is not a dot path of object keys"));
    }
    let (last, parents) = keys.split_last().unwrap();
    let mut cur = v;
    for (i, k) in parents.iter().enumerate() {
        let at = keys[..i].join(".");
        cur = object(cur, &at)?
            .get_mut(*k)
            .ok_or_else(|| no_key(k, &at))?;
    }
    let at = parents.join(".");
    let obj = object(cur, &at)?;
    if missing == Missing::Fail && !obj.contains_key(*last) {
        return Err(no_key(last, &at));
    }
    obj.insert((*last).to_string(), x);
    Ok(())
}

fn object<'a>(
    v: &'a mut Value,
    at: &str,
) -> Result<&'a mut serde_json::Map<String, Value>, String> {
    v.as_object_mut().ok_or_else(|| {
        if at.is_empty() {
            "the scene is not a JSON object".to_string()
        } else {
            format!("`{at}` is not an object")
        }
    })
}

fn no_key(k: &str, at: &str) -> String {
    if at.is_empty() {
        format!("the scene has no key {k:?}")
    } else {
        format!("`{at}` has no key {k:?}")
    }
}

/// The scene text `text` (of the file `path`) with every `(dot path, value)` of `overrides`
/// set. The error message names the missing key; the caller names the config field.
pub fn apply(
    text: &str,
    path: &Path,
    overrides: &[(String, Value)],
    missing: Missing,
) -> Result<String, String> {
    let mut v: Value =
        serde_json::from_str(text).map_err(|e| format!("{}: {e}", path.display()))?;
    for (p, x) in overrides {
        set(&mut v, p, x.clone(), missing)?;
    }
    Ok(v.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn sets_nested_values_of_any_kind() {
        let mut v =
            json!({"media": {"fluid": {"sigma_a": 0, "fluorescence": {"emission": {"fwhm": 40}}}}});
        set(&mut v, "media.fluid.sigma_a", json!(0.5), Missing::Fail).unwrap();
        set(
            &mut v,
            "media.fluid.fluorescence.emission",
            json!({"type": "box", "lo": 500, "hi": 600, "value": 1}),
            Missing::Fail,
        )
        .unwrap();
        assert_eq!(v["media"]["fluid"]["sigma_a"], json!(0.5));
        assert_eq!(
            v["media"]["fluid"]["fluorescence"]["emission"]["lo"],
            json!(500)
        );
    }

    #[test]
    fn missing_keys_are_errors_naming_them() {
        let mut v = json!({"media": {"fluid": {"sigma_a": 0}}, "shapes": [1]});
        let e = set(&mut v, "media.fog.sigma_a", json!(1), Missing::Fail).unwrap_err();
        assert!(e.contains("`media` has no key \"fog\""), "{e}");
        let e = set(&mut v, "media.fluid.sigma_s", json!(1), Missing::Fail).unwrap_err();
        assert!(e.contains("\"sigma_s\""), "{e}");
        let e = set(&mut v, "shapes.0", json!(1), Missing::Fail).unwrap_err();
        assert!(e.contains("`shapes` is not an object"), "{e}");
        assert!(set(&mut v, "media..x", json!(1), Missing::Fail).is_err());
        // Insert adds a missing last key, never a missing parent.
        set(&mut v, "media.fluid.sigma_s", json!(1), Missing::Insert).unwrap();
        assert_eq!(v["media"]["fluid"]["sigma_s"], json!(1));
        assert!(set(&mut v, "media.fog.sigma_s", json!(1), Missing::Insert).is_err());
    }
}
