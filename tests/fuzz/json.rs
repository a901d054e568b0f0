//! A small JSON tree for the mutator. Unlike `serde_json::Value` it keeps the order of object
//! members, allows the same key twice, and keeps each number's text as written, so a mutant can
//! hold `-0`, `1e308`, `5e-324` or `4294967296` exactly as a user could type them.

use std::fmt::Write;

#[derive(Clone, Debug, PartialEq)]
pub enum Json {
    Null,
    Bool(bool),
    /// A number, as its source text.
    Num(String),
    Str(String),
    Arr(Vec<Json>),
    Obj(Vec<(String, Json)>),
}

/// One step of a path from the root to a node: an object member (by position, since keys may
/// repeat) or an array element.
#[derive(Clone, Debug, PartialEq)]
pub enum Step {
    Member(usize),
    Index(usize),
}

impl Json {
    pub fn parse(text: &str) -> Result<Json, String> {
        let mut p = Parser {
            s: text.as_bytes(),
            i: 0,
        };
        p.ws();
        let v = p.value(0)?;
        p.ws();
        if p.i != p.s.len() {
            return Err(format!("trailing characters at byte {}", p.i));
        }
        Ok(v)
    }

    pub fn num(v: f64) -> Json {
        Json::Num(format!("{v}"))
    }

    pub fn as_f64(&self) -> Option<f64> {
        match self {
            Json::Num(t) => t.parse().ok(),
            _ => None,
        }
    }

    pub fn get(&self, key: &str) -> Option<&Json> {
        match self {
            Json::Obj(m) => m.iter().find(|(k, _)| k == key).map(|(_, v)| v),
            _ => None,
        }
    }

    pub fn get_mut(&mut self, key: &str) -> Option<&mut Json> {
        match self {
            Json::Obj(m) => m.iter_mut().find(|(k, _)| k == key).map(|(_, v)| v),
            _ => None,
        }
    }

    /// Set `key` of an object (replacing the first member of that name, else appending).
    pub fn set(&mut self, key: &str, v: Json) {
        if let Json::Obj(m) = self {
            match m.iter_mut().find(|(k, _)| k == key) {
                Some((_, old)) => *old = v,
                None => m.push((key.to_string(), v)),
            }
        }
    }

    /// Paths of every node below the root (the root itself excluded), depth first.
    pub fn paths(&self) -> Vec<Vec<Step>> {
        let mut out = Vec::new();
        let mut cur = Vec::new();
        self.collect(&mut cur, &mut out);
        out
    }

    fn collect(&self, cur: &mut Vec<Step>, out: &mut Vec<Vec<Step>>) {
        match self {
            Json::Arr(a) => {
                for (i, v) in a.iter().enumerate() {
                    cur.push(Step::Index(i));
                    out.push(cur.clone());
                    v.collect(cur, out);
                    cur.pop();
                }
            }
            Json::Obj(m) => {
                for (i, (_, v)) in m.iter().enumerate() {
                    cur.push(Step::Member(i));
                    out.push(cur.clone());
                    v.collect(cur, out);
                    cur.pop();
                }
            }
            _ => {}
        }
    }

    pub fn at(&self, path: &[Step]) -> &Json {
        let mut v = self;
        for s in path {
            v = match (v, s) {
                (Json::Arr(a), Step::Index(i)) => &a[*i],
                (Json::Obj(m), Step::Member(i)) => &m[*i].1,
                _ => panic!("bad path"),
            };
        }
        v
    }

    pub fn at_mut(&mut self, path: &[Step]) -> &mut Json {
        let mut v = self;
        for s in path {
            v = match (v, s) {
                (Json::Arr(a), Step::Index(i)) => &mut a[*i],
                (Json::Obj(m), Step::Member(i)) => &mut m[*i].1,
                _ => panic!("bad path"),
            };
        }
        v
    }

    /// The dotted name of a path (`camera.width`, `shapes[3].radius`) for reports.
    pub fn path_name(&self, path: &[Step]) -> String {
        let mut out = String::new();
        let mut v = self;
        for s in path {
            match (v, s) {
                (Json::Arr(a), Step::Index(i)) => {
                    let _ = write!(out, "[{i}]");
                    v = &a[*i];
                }
                (Json::Obj(m), Step::Member(i)) => {
                    if !out.is_empty() {
                        out.push('.');
                    }
                    out.push_str(&m[*i].0);
                    v = &m[*i].1;
                }
                _ => panic!("bad path"),
            }
        }
        if out.is_empty() { "<root>".into() } else { out }
    }

    /// Pretty text with two-space indents (numbers and duplicate keys exactly as held).
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        self.write(&mut s, 0);
        s.push('\n');
        s
    }

    fn write(&self, s: &mut String, indent: usize) {
        match self {
            Json::Null => s.push_str("null"),
            Json::Bool(b) => s.push_str(if *b { "true" } else { "false" }),
            Json::Num(t) => s.push_str(t),
            Json::Str(t) => write_str(s, t),
            Json::Arr(a) => {
                // Short arrays of scalars on one line, like the shipped files.
                if a.iter().all(|v| !matches!(v, Json::Arr(_) | Json::Obj(_))) {
                    s.push('[');
                    for (i, v) in a.iter().enumerate() {
                        if i > 0 {
                            s.push_str(", ");
                        }
                        v.write(s, indent);
                    }
                    s.push(']');
                    return;
                }
                s.push_str("[\n");
                for (i, v) in a.iter().enumerate() {
                    pad(s, indent + 1);
                    v.write(s, indent + 1);
                    s.push_str(if i + 1 < a.len() { ",\n" } else { "\n" });
                }
                pad(s, indent);
                s.push(']');
            }
            Json::Obj(m) => {
                if m.is_empty() {
                    s.push_str("{}");
                    return;
                }
                s.push_str("{\n");
                for (i, (k, v)) in m.iter().enumerate() {
                    pad(s, indent + 1);
                    write_str(s, k);
                    s.push_str(": ");
                    v.write(s, indent + 1);
                    s.push_str(if i + 1 < m.len() { ",\n" } else { "\n" });
                }
                pad(s, indent);
                s.push('}');
            }
        }
    }
}

fn pad(s: &mut String, indent: usize) {
    for _ in 0..indent {
        s.push_str("  ");
    }
}

fn write_str(s: &mut String, t: &str) {
    s.push('"');
    for c in t.chars() {
        match c {
            '"' => s.push_str("\\\""),
            '\\' => s.push_str("\\\\"),
            '\n' => s.push_str("\\n"),
            '\r' => s.push_str("\\r"),
            '\t' => s.push_str("\\t"),
            c if (c as u32) < 0x20 => {
                let _ = write!(s, "\\u{:04x}", c as u32);
            }
            c => s.push(c),
        }
    }
    s.push('"');
}

struct Parser<'a> {
    s: &'a [u8],
    i: usize,
}

impl Parser<'_> {
    fn ws(&mut self) {
        while self.i < self.s.len() && matches!(self.s[self.i], b' ' | b'\t' | b'\n' | b'\r') {
            self.i += 1;
        }
    }

    fn err<T>(&self, what: &str) -> Result<T, String> {
        Err(format!("{what} at byte {}", self.i))
    }

    fn value(&mut self, depth: usize) -> Result<Json, String> {
        if depth > 200 {
            return self.err("nesting too deep");
        }
        match self.s.get(self.i) {
            None => self.err("unexpected end"),
            Some(b'{') => {
                self.i += 1;
                let mut m = Vec::new();
                self.ws();
                if self.s.get(self.i) == Some(&b'}') {
                    self.i += 1;
                    return Ok(Json::Obj(m));
                }
                loop {
                    self.ws();
                    let k = self.string()?;
                    self.ws();
                    if self.s.get(self.i) != Some(&b':') {
                        return self.err("expected ':'");
                    }
                    self.i += 1;
                    self.ws();
                    let v = self.value(depth + 1)?;
                    m.push((k, v));
                    self.ws();
                    match self.s.get(self.i) {
                        Some(b',') => self.i += 1,
                        Some(b'}') => {
                            self.i += 1;
                            return Ok(Json::Obj(m));
                        }
                        _ => return self.err("expected ',' or '}'"),
                    }
                }
            }
            Some(b'[') => {
                self.i += 1;
                let mut a = Vec::new();
                self.ws();
                if self.s.get(self.i) == Some(&b']') {
                    self.i += 1;
                    return Ok(Json::Arr(a));
                }
                loop {
                    self.ws();
                    a.push(self.value(depth + 1)?);
                    self.ws();
                    match self.s.get(self.i) {
                        Some(b',') => self.i += 1,
                        Some(b']') => {
                            self.i += 1;
                            return Ok(Json::Arr(a));
                        }
                        _ => return self.err("expected ',' or ']'"),
                    }
                }
            }
            Some(b'"') => Ok(Json::Str(self.string()?)),
            Some(b't') if self.s[self.i..].starts_with(b"true") => {
                self.i += 4;
                Ok(Json::Bool(true))
            }
            Some(b'f') if self.s[self.i..].starts_with(b"false") => {
                self.i += 5;
                Ok(Json::Bool(false))
            }
            Some(b'n') if self.s[self.i..].starts_with(b"null") => {
                self.i += 4;
                Ok(Json::Null)
            }
            Some(c) if *c == b'-' || c.is_ascii_digit() => {
                let start = self.i;
                while self.i < self.s.len()
                    && matches!(
                        self.s[self.i],
                        b'-' | b'+' | b'.' | b'e' | b'E' | b'0'..=b'9'
                    )
                {
                    self.i += 1;
                }
                let t = std::str::from_utf8(&self.s[start..self.i]).unwrap();
                if t.parse::<f64>().is_err() {
                    return self.err("bad number");
                }
                Ok(Json::Num(t.to_string()))
            }
            Some(_) => self.err("unexpected character"),
        }
    }

    fn string(&mut self) -> Result<String, String> {
        if self.s.get(self.i) != Some(&b'"') {
            return self.err("expected string");
        }
        self.i += 1;
        let mut buf: Vec<u8> = Vec::new();
        loop {
            match self.s.get(self.i) {
                None => return self.err("unterminated string"),
                Some(b'"') => {
                    self.i += 1;
                    return String::from_utf8(buf).or_else(|_| self.err("invalid UTF-8"));
                }
                Some(b'\\') => {
                    let e = *self.s.get(self.i + 1).ok_or("unterminated escape")?;
                    self.i += 2;
                    let c = match e {
                        b'"' => '"',
                        b'\\' => '\\',
                        b'/' => '/',
                        b'b' => '\u{8}',
                        b'f' => '\u{c}',
                        b'n' => '\n',
                        b'r' => '\r',
                        b't' => '\t',
                        b'u' => {
                            let hex = self.s.get(self.i..self.i + 4).ok_or("short \\u")?;
                            let code = u32::from_str_radix(std::str::from_utf8(hex).unwrap(), 16)
                                .map_err(|e| e.to_string())?;
                            self.i += 4;
                            char::from_u32(code).unwrap_or('\u{fffd}')
                        }
                        _ => return self.err("bad escape"),
                    };
                    let mut b = [0u8; 4];
                    buf.extend_from_slice(c.encode_utf8(&mut b).as_bytes());
                }
                Some(&c) => {
                    buf.push(c);
                    self.i += 1;
                }
            }
        }
    }
}
