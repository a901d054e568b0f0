//! JSON documents as untrusted input: what the top level of a file must be.

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
