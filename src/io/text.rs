//! Untrusted strings made safe where they go: a terminal (control bytes escaped, very long paths
//! shortened) and OpenEXR text attributes, which hold Latin-1 only (non-ASCII escaped as JSON
//! `\uXXXX`, so that any path round-trips).

use std::path::Path;

/// Longest path shown whole in a message; longer ones keep their start and their end.
const MAX_SHOWN_PATH: usize = 240;

/// `path` for a message: control characters escaped, and a path longer than 240 bytes shortened
/// to its first 120 and last 80 bytes around "…".
pub fn show_path(path: &Path) -> String {
    let s = path.to_string_lossy();
    let s = if s.len() > MAX_SHOWN_PATH {
        let mut a = 120;
        while !s.is_char_boundary(a) {
            a -= 1;
        }
        let mut b = s.len() - 80;
        while !s.is_char_boundary(b) {
            b += 1;
        }
        format!("{}…{}", &s[..a], &s[b..])
    } else {
        s.into_owned()
    };
    escape_control(&s, false)
}

/// `s` with its control characters (C0, DEL and C1; newlines too unless `keep_newlines`)
/// written as `\x1b`, `\u{9b}`, …, so that text from a file cannot drive the terminal.
pub fn escape_control(s: &str, keep_newlines: bool) -> String {
    if !s
        .chars()
        .any(|c| c.is_control() && !(keep_newlines && c == '\n'))
    {
        return s.to_string();
    }
    let mut out = String::with_capacity(s.len() + 8);
    for c in s.chars() {
        match c {
            '\n' if keep_newlines => out.push('\n'),
            '\t' => out.push_str("\\t"),
            '\r' => out.push_str("\\r"),
            '\n' => out.push_str("\\n"),
            c if (c as u32) < 0x80 && c.is_control() => {
                out.push_str(&format!("\\x{:02x}", c as u32))
            }
            c if c.is_control() => out.push_str(&format!("\\u{{{:x}}}", c as u32)),
            c => out.push(c),
        }
    }
    out
}

/// JSON text with every non-ASCII character written as `\uXXXX` (a surrogate pair above
/// U+FFFF): the same JSON value, in ASCII, which an OpenEXR text attribute can hold. Only
/// strings can hold non-ASCII characters in JSON, and there the escape is exact.
pub fn json_ascii(json: &str) -> String {
    let mut out = String::with_capacity(json.len());
    for c in json.chars() {
        if c.is_ascii() {
            out.push(c);
        } else {
            let mut units = [0u16; 2];
            for u in c.encode_utf16(&mut units) {
                out.push_str(&format!("\\u{u:04x}"));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_bytes_are_escaped() {
        assert_eq!(escape_control("plain", false), "plain");
        assert_eq!(escape_control("a\x1b[31mb", false), "a\\x1b[31mb");
        assert_eq!(escape_control("a\nb\u{9b}", true), "a\nb\\u{9b}");
        assert_eq!(escape_control("a\nb", false), "a\\nb");
    }

    #[test]
    fn ascii_json_round_trips_any_string() {
        let v = serde_json::json!({"scene": "/tmp/☃/场景 𝄞.json", "n": 1});
        let a = json_ascii(&v.to_string());
        assert!(a.is_ascii(), "{a}");
        let back: serde_json::Value = serde_json::from_str(&a).unwrap();
        assert_eq!(back, v);
    }

    #[test]
    fn long_paths_are_shortened() {
        let p = format!("/tmp/{}.exr", "x".repeat(5000));
        let s = show_path(Path::new(&p));
        assert!(
            s.len() < 260 && s.starts_with("/tmp/x") && s.ends_with("x.exr"),
            "{s}"
        );
    }
}
