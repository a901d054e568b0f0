//! The seeded mutators: JSON-aware (on a [`Json`] tree), line-aware text (CSV, BFC, any file
//! read as text) and binary (`.vol` grids, EXR images). Each returns a short description of what
//! it did, for the failure table.

use super::json::{Json, Step};
use rand::Rng;
use rand::seq::IndexedRandom;
use rand_pcg::Pcg64;

/// Numbers a user (or a broken tool) can write where a number is expected: zeros, the f32 and
/// f64 limits and beyond, subnormals, integers just past u32/i32 and u64, negatives.
pub const EXTREME_NUMBERS: &[&str] = &[
    "0",
    "-0",
    "1e-38",
    "-1e-38",
    "1e38",
    "-1e38",
    "3.5e38",
    "1e39",
    "1e308",
    "-1e308",
    "5e-324",
    "1e-45",
    "4294967296",
    "4294967295",
    "2147483648",
    "1e19",
    "18446744073709551616",
    "-1",
    "0.5",
    "1e-7",
    "1e9",
];

/// Non-finite values as JSON strings (JSON has no literal for them).
pub const NONFINITE_STRINGS: &[&str] = &["NaN", "nan", "inf", "-inf", "Infinity", "-Infinity"];

/// Replacement text for a number in a CSV or BFC line.
const TEXT_NUMBERS: &[&str] = &[
    "nan",
    "NaN",
    "inf",
    "-inf",
    "1e30",
    "1e309",
    "-1e30",
    "-1",
    "0",
    "-0",
    "",
    "abc",
    "1e-45",
    "4294967296",
    "1,5",
    "0x10",
    "3.4e38",
];

/// Integers for binary header fields.
const EXTREME_INTS: &[i64] = &[
    0,
    1,
    -1,
    2,
    3,
    1000,
    65536,
    1 << 20,
    1 << 30,
    i32::MAX as i64,
    i32::MIN as i64,
    u32::MAX as i64,
];

const EXTREME_FLOATS: &[f32] = &[
    f32::NAN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    0.0,
    -0.0,
    1e38,
    -1e38,
    1e-45,
    -1.0,
    f32::MAX,
];

/// Apply `n` JSON mutations to `doc`. `strings` are extra strings worth trying where a string
/// is (other data files, names from elsewhere, bad paths).
pub fn json(rng: &mut Pcg64, doc: &mut Json, n: usize, strings: &[String]) -> Vec<String> {
    let mut out = Vec::new();
    for _ in 0..n {
        if let Some(d) = json_once(rng, doc, strings) {
            out.push(d);
        }
    }
    out
}

/// Paths grouped by field: the name of the nearest object member on the way (`radius`,
/// `corners`, `value`, `domain`), so that a field with one number is as likely to be hit as one
/// with hundreds (the corners of every quad).
fn by_field<'a>(
    doc: &Json,
    paths: &'a [Vec<Step>],
    keep: impl Fn(&Json) -> bool,
) -> Vec<Vec<&'a Vec<Step>>> {
    let mut groups: Vec<(String, Vec<&'a Vec<Step>>)> = Vec::new();
    for p in paths {
        if !keep(doc.at(p)) {
            continue;
        }
        let mut field = String::new();
        let mut v = doc;
        for st in p {
            match (v, st) {
                (Json::Obj(m), Step::Member(i)) => {
                    field = m[*i].0.clone();
                    v = &m[*i].1;
                }
                (Json::Arr(a), Step::Index(i)) => v = &a[*i],
                _ => unreachable!(),
            }
        }
        match groups.iter_mut().find(|(f, _)| *f == field) {
            Some((_, g)) => g.push(p),
            None => groups.push((field, vec![p])),
        }
    }
    groups.into_iter().map(|(_, g)| g).collect()
}

/// A path of a field chosen uniformly among the fields, then uniformly within it.
fn pick(rng: &mut Pcg64, groups: &[Vec<&Vec<Step>>]) -> Vec<Step> {
    (*groups.choose(rng).unwrap().choose(rng).unwrap()).clone()
}

fn extreme(rng: &mut Pcg64) -> Json {
    if rng.random_bool(0.8) {
        Json::Num(EXTREME_NUMBERS.choose(rng).unwrap().to_string())
    } else {
        Json::Str(NONFINITE_STRINGS.choose(rng).unwrap().to_string())
    }
}

/// A change applied to each number of a field (a replacement or a factor).
type NumberMap = Box<dyn Fn(&Json) -> Json>;

const FACTORS: &[f64] = &[
    -1.0, 0.0, 2.0, 10.0, 1e3, 1e6, 1e-3, 1e-6, 1e20, 0.999, 1.001,
];

fn json_once(rng: &mut Pcg64, doc: &mut Json, strings: &[String]) -> Option<String> {
    let paths = doc.paths();
    if paths.is_empty() {
        *doc = Json::Arr(vec![]);
        return Some("root -> []".into());
    }
    let numbers = by_field(doc, &paths, |v| matches!(v, Json::Num(_)));
    let strs = by_field(doc, &paths, |v| matches!(v, Json::Str(_)));
    let fields = by_field(doc, &paths, |_| true);
    let op = rng.random_range(0..100);
    // Numbers get most of the attention: they are where the crashes were, and an extreme value
    // of the right type gets past the parser to the checks and the renderer.
    if op < 42 && !numbers.is_empty() {
        let p = pick(rng, &numbers);
        let name = doc.path_name(&p);
        let new = extreme(rng);
        let d = format!("{name} = {}", short(&new));
        *doc.at_mut(&p) = new;
        return Some(d);
    }
    if op < 54 && !numbers.is_empty() {
        let p = pick(rng, &numbers);
        let name = doc.path_name(&p);
        let v = doc.at(&p).as_f64().unwrap_or(1.0);
        let f = *FACTORS.choose(rng).unwrap();
        let new = Json::num(v * f);
        let d = format!("{name} ×{f} = {}", short(&new));
        *doc.at_mut(&p) = new;
        return Some(d);
    }
    if op < 60 && !numbers.is_empty() {
        // Every number of one field at once (every `scale`, every `value`).
        let g = numbers.choose(rng).unwrap();
        let first = doc.path_name(g[0]);
        let (what, new): (String, NumberMap) = if rng.random_bool(0.5) {
            let e = extreme(rng);
            (format!("= {}", short(&e)), Box::new(move |_| e.clone()))
        } else {
            let f = *FACTORS.choose(rng).unwrap();
            (
                format!("×{f}"),
                Box::new(move |v: &Json| Json::num(v.as_f64().unwrap_or(1.0) * f)),
            )
        };
        for p in g {
            let v = new(doc.at(p));
            *doc.at_mut(p) = v;
        }
        return Some(format!("all {} like {first} {what}", g.len()));
    }
    if op < 68 && !strs.is_empty() {
        let p = pick(rng, &strs);
        let name = doc.path_name(&p);
        let mut pool: Vec<String> = vec![
            String::new(),
            " ".into(),
            "does-not-exist.json".into(),
            "/nonexistent/x.csv".into(),
            ".".into(),
            "x".repeat(5000),
            "λ σ̂ \u{202e}".into(),
        ];
        pool.extend(strings.iter().cloned());
        // Another string of the same document: a name where a path is, a path where a name is.
        pool.extend(strs.iter().flatten().map(|q| match doc.at(q) {
            Json::Str(s) => s.clone(),
            _ => unreachable!(),
        }));
        let s = pool.choose(rng).unwrap().clone();
        let new = Json::Str(s);
        let d = format!("{name} = {}", short(&new));
        *doc.at_mut(&p) = new;
        return Some(d);
    }
    let p = pick(rng, &fields);
    let name = doc.path_name(&p);
    let (parent, last) = p.split_at(p.len() - 1);
    match rng.random_range(0..40) {
        0..=9 => {
            // Delete the member or element.
            match (doc.at_mut(parent), &last[0]) {
                (Json::Obj(m), Step::Member(i)) => {
                    m.remove(*i);
                }
                (Json::Arr(a), Step::Index(i)) => {
                    a.remove(*i);
                }
                _ => unreachable!(),
            }
            Some(format!("delete {name}"))
        }
        10..=19 => {
            // Duplicate it: the same key twice, or the element twice.
            let mutate_copy = rng.random_bool(0.5);
            let copy = doc.at(&p).clone();
            let copy = if mutate_copy {
                swap_type(rng, &copy)
            } else {
                copy
            };
            let what = if mutate_copy {
                format!(" as {}", short(&copy))
            } else {
                String::new()
            };
            match (doc.at_mut(parent), &last[0]) {
                (Json::Obj(m), Step::Member(i)) => {
                    let k = m[*i].0.clone();
                    m.insert(*i + 1, (k, copy));
                }
                (Json::Arr(a), Step::Index(i)) => a.insert(*i + 1, copy),
                _ => unreachable!(),
            }
            Some(format!("duplicate {name}{what}"))
        }
        20..=25 => {
            let new = swap_type(rng, doc.at(&p));
            let d = format!("{name} = {}", short(&new));
            *doc.at_mut(&p) = new;
            Some(d)
        }
        26..=29 => {
            let new = match doc.at(&p) {
                Json::Arr(_) => Json::Arr(vec![]),
                Json::Obj(_) => Json::Obj(vec![]),
                _ => Json::Str(String::new()),
            };
            let d = format!("{name} = {}", short(&new));
            *doc.at_mut(&p) = new;
            Some(d)
        }
        30..=37 => {
            // Rename a member: to an unknown key, or to a sibling's key (a duplicate).
            if let (Json::Obj(m), Step::Member(i)) = (doc.at_mut(parent), &last[0]) {
                let new = if m.len() > 1 && rng.random_bool(0.5) {
                    m[rng.random_range(0..m.len())].0.clone()
                } else {
                    format!("{}_", m[*i].0)
                };
                let d = format!("rename {name} -> {new}");
                m[*i].0 = new;
                Some(d)
            } else {
                // Arrays: grow, shrink or reverse.
                let a = match doc.at_mut(parent) {
                    Json::Arr(a) => a,
                    _ => unreachable!(),
                };
                match rng.random_range(0..3) {
                    0 => {
                        a.truncate(1);
                        Some(format!("{} truncated to 1", doc.path_name(parent)))
                    }
                    1 => {
                        let v = a[rng.random_range(0..a.len())].clone();
                        for _ in 0..rng.random_range(1..4) {
                            a.push(v.clone());
                        }
                        Some(format!("{} grown", doc.path_name(parent)))
                    }
                    _ => {
                        a.reverse();
                        Some(format!("{} reversed", doc.path_name(parent)))
                    }
                }
            }
        }
        38 if matches!(doc.at(parent), Json::Arr(_)) => {
            // Many copies of one element (70,000 shapes is more than a 16-bit id can count).
            let k = *[100usize, 1000, 70_000].choose(rng).unwrap();
            let v = doc.at(&p).clone();
            if let Json::Arr(a) = doc.at_mut(parent) {
                a.extend(std::iter::repeat_n(v, k));
            }
            Some(format!("{name} repeated {k} more times"))
        }
        _ => {
            // Deep nesting.
            let mut v = Json::Num("1".into());
            let depth = *[20usize, 130, 300].choose(rng).unwrap();
            for _ in 0..depth {
                v = Json::Arr(vec![v]);
            }
            *doc.at_mut(&p) = v;
            Some(format!("{name} = {depth} nested arrays"))
        }
    }
}

/// A value of another type than `v`, built from it where it can be.
fn swap_type(rng: &mut Pcg64, v: &Json) -> Json {
    let choices: Vec<Json> = vec![
        Json::Null,
        Json::Bool(true),
        Json::Str("x".into()),
        Json::Num("1".into()),
        Json::Arr(vec![]),
        Json::Obj(vec![]),
        Json::Arr(vec![v.clone()]),
        Json::Obj(vec![("value".into(), v.clone())]),
        match v {
            Json::Num(t) => Json::Str(t.clone()),
            Json::Str(s) => Json::Num(if s.parse::<f64>().is_ok() {
                s.clone()
            } else {
                "0".into()
            }),
            _ => Json::Str("0.5".into()),
        },
    ];
    loop {
        let c = choices.choose(rng).unwrap().clone();
        if std::mem::discriminant(&c) != std::mem::discriminant(v) || c != *v {
            return c;
        }
    }
}

/// A value for a report: short, on one line.
pub fn short(v: &Json) -> String {
    let t = match v {
        Json::Arr(a) if a.len() > 3 => format!("[{} items]", a.len()),
        Json::Obj(m) if m.len() > 3 => format!("{{{} keys}}", m.len()),
        _ => v.to_text().split_whitespace().collect::<Vec<_>>().join(" "),
    };
    clip(&t, 40)
}

pub fn clip(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_string()
    } else {
        format!("{}…", s.chars().take(n).collect::<String>())
    }
}

/// Apply `n` line-aware text mutations. `header_lines`: how many leading lines are a header
/// (BFC files), which get extra attention.
pub fn text(rng: &mut Pcg64, data: &mut Vec<u8>, n: usize, header_lines: usize) -> Vec<String> {
    (0..n).map(|_| text_once(rng, data, header_lines)).collect()
}

fn text_once(rng: &mut Pcg64, data: &mut Vec<u8>, header_lines: usize) -> String {
    let mut lines = split_lines(data);
    let nl = lines.len().max(1);
    let pick_line = |rng: &mut Pcg64| -> usize {
        if header_lines > 0 && rng.random_bool(0.4) {
            rng.random_range(0..header_lines.min(nl))
        } else {
            rng.random_range(0..nl)
        }
    };
    let d = match rng.random_range(0..100) {
        0..=34 => {
            // Replace a number in a line.
            let li = pick_line(rng);
            let Some(line) = lines.get_mut(li) else {
                return "no lines".into();
            };
            let spans = number_spans(line);
            if spans.is_empty() {
                return text_once(rng, data, header_lines);
            }
            let (a, b) = *spans.choose(rng).unwrap();
            let new = TEXT_NUMBERS.choose(rng).unwrap();
            let old = String::from_utf8_lossy(&line[a..b]).to_string();
            line.splice(a..b, new.bytes());
            format!("line {}: {old} -> '{new}'", li + 1)
        }
        35..=44 => {
            let at = rng.random_range(0..=data.len());
            data.truncate(at);
            return format!("truncate at byte {at}");
        }
        45..=52 => {
            let li = pick_line(rng);
            if li < lines.len() {
                let l = lines[li].clone();
                lines.insert(li, l);
            }
            format!("duplicate line {}", li + 1)
        }
        53..=60 => {
            let li = pick_line(rng);
            if li < lines.len() {
                lines.remove(li);
            }
            format!("delete line {}", li + 1)
        }
        61..=66 => {
            data.splice(0..0, [0xEF, 0xBB, 0xBF]);
            return "insert UTF-8 BOM".into();
        }
        67..=70 => {
            let (a, b) = (rng.random_range(0..nl), rng.random_range(0..nl));
            if a < lines.len() && b < lines.len() {
                lines.swap(a, b);
            }
            format!("swap lines {} and {}", a + 1, b + 1)
        }
        71..=74 => {
            let junk = *[
                "#comment", "", "a,b", "1,2,3", ",,", "500", "500,", "\t", "λ,σ", "1e400,1",
            ]
            .choose(rng)
            .unwrap();
            let li = rng.random_range(0..=lines.len());
            let mut l = junk.as_bytes().to_vec();
            l.push(b'\n');
            lines.insert(li, l);
            format!("insert line {} '{junk}'", li + 1)
        }
        75..=78 => {
            let at = rng.random_range(0..=data.len());
            let b = *[0xFFu8, 0x00, 0xC3, 0x80].choose(rng).unwrap();
            data.insert(at, b);
            return format!("insert byte {b:#04x} at {at}");
        }
        79..=81 => {
            // Line endings: LF <-> CRLF, or none at all.
            let crlf = data.contains(&b'\r');
            if crlf {
                data.retain(|&c| c != b'\r');
                return "CRLF -> LF".into();
            } else if rng.random_bool(0.5) {
                let mut o = Vec::with_capacity(data.len() * 2);
                for &c in data.iter() {
                    if c == b'\n' {
                        o.push(b'\r');
                    }
                    o.push(c);
                }
                *data = o;
                return "LF -> CRLF".into();
            } else {
                for c in data.iter_mut() {
                    if *c == b'\n' {
                        *c = b'\r';
                    }
                }
                return "LF -> CR".into();
            }
        }
        82..=84 => {
            data.clear();
            return "empty file".into();
        }
        85..=88 => {
            // Separators.
            let li = pick_line(rng);
            if let Some(line) = lines.get_mut(li) {
                for c in line.iter_mut() {
                    match *c {
                        b',' => *c = b';',
                        b'\t' => *c = b' ',
                        _ => {}
                    }
                }
            }
            format!("line {}: separators changed", li + 1)
        }
        89..=92 => {
            let skip = header_lines.min(lines.len());
            lines[skip..].reverse();
            "data lines reversed".into()
        }
        _ => {
            // Flip a few bytes.
            let k = rng.random_range(1..4);
            for _ in 0..k {
                if data.is_empty() {
                    break;
                }
                let i = rng.random_range(0..data.len());
                data[i] = rng.random();
            }
            return format!("{k} random bytes");
        }
    };
    *data = lines.concat();
    d
}

/// Lines with their terminators (so joining them gives the file back).
fn split_lines(data: &[u8]) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    let mut cur = Vec::new();
    for &c in data {
        cur.push(c);
        if c == b'\n' {
            out.push(std::mem::take(&mut cur));
        }
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

/// Byte ranges of the numbers in a line.
fn number_spans(line: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < line.len() {
        let c = line[i];
        let starts = c.is_ascii_digit()
            || ((c == b'-' || c == b'.')
                && line
                    .get(i + 1)
                    .is_some_and(|d| d.is_ascii_digit() || *d == b'.'));
        if starts && (i == 0 || !line[i - 1].is_ascii_alphanumeric()) {
            let a = i;
            i += 1;
            while i < line.len()
                && (line[i].is_ascii_digit()
                    || matches!(line[i], b'.' | b'e' | b'E')
                    || (matches!(line[i], b'-' | b'+') && matches!(line[i - 1], b'e' | b'E')))
            {
                i += 1;
            }
            out.push((a, i));
        } else {
            i += 1;
        }
    }
    out
}

/// Binary mutations for a Mitsuba `.vol` grid: header integers, bounding box, voxel values,
/// truncation, byte flips.
pub fn vol(rng: &mut Pcg64, data: &mut Vec<u8>, n: usize) -> Vec<String> {
    (0..n)
        .map(|_| match rng.random_range(0..6) {
            0 | 1 => {
                let fields = [
                    (3usize, "version"),
                    (4, "encoding"),
                    (8, "xres"),
                    (12, "yres"),
                    (16, "zres"),
                    (20, "channels"),
                ];
                let (off, name) = *fields.choose(rng).unwrap();
                let v = *EXTREME_INTS.choose(rng).unwrap();
                if off == 3 {
                    if data.len() > 3 {
                        data[3] = v as u8;
                    }
                } else {
                    put_i32(data, off, v);
                }
                format!("header {name} = {v}")
            }
            2 => {
                let k = rng.random_range(0..6);
                let v = *EXTREME_FLOATS.choose(rng).unwrap();
                put_f32(data, 24 + 4 * k, v);
                format!("bbox[{k}] = {v}")
            }
            3 => {
                let voxels = data.len().saturating_sub(48) / 4;
                if voxels == 0 {
                    return "no voxels".into();
                }
                let k = rng.random_range(0..voxels);
                let v = *EXTREME_FLOATS.choose(rng).unwrap();
                put_f32(data, 48 + 4 * k, v);
                format!("voxel {k} = {v}")
            }
            4 => truncate(rng, data, 48),
            _ => flip(rng, data),
        })
        .collect()
}

/// Binary mutations for an OpenEXR file: integers inside header attributes (data window,
/// channel list, compression, tile description), the offset table, truncation, byte flips.
pub fn exr(rng: &mut Pcg64, data: &mut Vec<u8>, n: usize) -> Vec<String> {
    (0..n)
        .map(|_| {
            let (attrs, header_end) = exr_attributes(data);
            match rng.random_range(0..6) {
                0 | 1 if !attrs.is_empty() => {
                    let (name, off, size) = attrs.choose(rng).unwrap().clone();
                    if size < 1 {
                        return flip(rng, data);
                    }
                    if size >= 4 {
                        let k = rng.random_range(0..size / 4);
                        let v = *EXTREME_INTS.choose(rng).unwrap();
                        put_i32(data, off + 4 * k, v);
                        format!("{name}[{k}] = {v}")
                    } else {
                        let v: u8 = rng.random();
                        data[off] = v;
                        format!("{name} = {v}")
                    }
                }
                2 if header_end + 8 <= data.len() => {
                    // An offset-table entry.
                    let entries = (data.len() - header_end) / 8;
                    let k = rng.random_range(0..entries.min(64));
                    let v = *[0u64, 1, u64::MAX, data.len() as u64, 1 << 40]
                        .choose(rng)
                        .unwrap();
                    data[header_end + 8 * k..header_end + 8 * k + 8]
                        .copy_from_slice(&v.to_le_bytes());
                    format!("offset[{k}] = {v}")
                }
                3 => truncate(rng, data, header_end.max(8)),
                _ => flip(rng, data),
            }
        })
        .collect()
}

/// (name, value offset, value size) of each attribute of a single-part EXR header, and where
/// the header ends.
fn exr_attributes(d: &[u8]) -> (Vec<(String, usize, usize)>, usize) {
    let mut out = Vec::new();
    let mut i = 8;
    let cstr = |i: &mut usize| -> Option<String> {
        let start = *i;
        while *i < d.len() && d[*i] != 0 {
            *i += 1;
        }
        if *i >= d.len() {
            return None;
        }
        *i += 1;
        Some(String::from_utf8_lossy(&d[start..*i - 1]).to_string())
    };
    while let Some(name) = cstr(&mut i) {
        if name.is_empty() {
            break;
        }
        let Some(_ty) = cstr(&mut i) else { break };
        if i + 4 > d.len() {
            break;
        }
        let size = i32::from_le_bytes(d[i..i + 4].try_into().unwrap()).max(0) as usize;
        i += 4;
        if i + size > d.len() {
            break;
        }
        out.push((name, i, size));
        i += size;
    }
    (out, i)
}

fn truncate(rng: &mut Pcg64, data: &mut Vec<u8>, header: usize) -> String {
    let at = if rng.random_bool(0.5) {
        rng.random_range(0..=header.min(data.len()))
    } else {
        rng.random_range(0..=data.len())
    };
    data.truncate(at);
    format!("truncate at byte {at}")
}

fn flip(rng: &mut Pcg64, data: &mut [u8]) -> String {
    if data.is_empty() {
        return "nothing to flip".into();
    }
    let k = rng.random_range(1..9);
    for _ in 0..k {
        let i = rng.random_range(0..data.len());
        if rng.random_bool(0.5) {
            data[i] ^= 1 << rng.random_range(0..8);
        } else {
            data[i] = rng.random();
        }
    }
    format!("flip {k} bytes")
}

fn put_i32(data: &mut [u8], off: usize, v: i64) {
    if off + 4 <= data.len() {
        data[off..off + 4].copy_from_slice(&(v as u32).to_le_bytes());
    }
}

fn put_f32(data: &mut [u8], off: usize, v: f32) {
    if off + 4 <= data.len() {
        data[off..off + 4].copy_from_slice(&v.to_le_bytes());
    }
}
