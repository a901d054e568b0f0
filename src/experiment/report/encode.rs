//! The byte-level pieces of the report: HDR pixels as compressed half floats, base64, and text
//! made safe for HTML and for a JSON `<script>` block.

use glam::Vec3;

/// Largest finite half float; larger finite values are stored as this (not as infinity, which
/// the viewer shows as not finite).
const F16_MAX: f32 = 65504.0;

/// Pixels as the viewer decodes them: 3·n half floats, planar (all R, then all G, then all B),
/// split into their high bytes then their low bytes (which deflate compresses better than
/// interleaved bytes), then zlib-compressed (deflate in a zlib wrapper, what the browser's
/// `DecompressionStream("deflate")` reads).
pub fn pixels_f16_deflate(px: &[Vec3]) -> Vec<u8> {
    let n = px.len();
    let mut bytes = vec![0u8; 6 * n];
    for c in 0..3 {
        for (i, p) in px.iter().enumerate() {
            let v = p[c];
            let v = if v.is_finite() {
                v.clamp(-F16_MAX, F16_MAX)
            } else {
                v
            };
            let [lo, hi] = half::f16::from_f32(v).to_bits().to_le_bytes();
            let k = c * n + i;
            bytes[k] = hi;
            bytes[3 * n + k] = lo;
        }
    }
    miniz_oxide::deflate::compress_to_vec_zlib(&bytes, 9)
}

/// Standard base64 (RFC 4648, with padding).
pub fn base64(data: &[u8]) -> String {
    const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(data.len().div_ceil(3) * 4);
    for ch in data.chunks(3) {
        let b = [ch[0], *ch.get(1).unwrap_or(&0), *ch.get(2).unwrap_or(&0)];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for k in 0..4 {
            if k <= ch.len() {
                out.push(T[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// `data:` URL of some bytes.
pub fn data_url(mime: &str, data: &[u8]) -> String {
    format!("data:{mime};base64,{}", base64(data))
}

/// Text escaped for HTML element content and quoted attribute values.
pub fn html(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            _ => out.push(c),
        }
    }
    out
}

/// JSON text that can sit inside a `<script>` element: every `<` (which JSON allows only inside
/// strings) written as `\u003c`, so no `</script>` can end the element early.
pub fn script_json(v: &serde_json::Value) -> String {
    serde_json::to_string(v)
        .expect("JSON values serialise")
        .replace('<', "\\u003c")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc4648_vectors() {
        for (i, o) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(i.as_bytes()), o);
        }
        assert_eq!(base64(&[0xff, 0xfe, 0xfd]), "//79");
    }

    #[test]
    fn pixels_round_trip_through_half_floats() {
        let px = vec![
            Vec3::new(1.0, 0.5, 0.25),
            Vec3::new(1e6, -2.0, f32::NAN),
            Vec3::new(f32::INFINITY, 3e-8, 0.0),
        ];
        let z = pixels_f16_deflate(&px);
        let raw = miniz_oxide::inflate::decompress_to_vec_zlib(&z).unwrap();
        let n = px.len();
        assert_eq!(raw.len(), 6 * n);
        let get = |c: usize, i: usize| {
            let k = c * n + i;
            half::f16::from_bits(u16::from_le_bytes([raw[3 * n + k], raw[k]])).to_f32()
        };
        assert_eq!((get(0, 0), get(1, 0), get(2, 0)), (1.0, 0.5, 0.25));
        assert_eq!((get(0, 1), get(1, 1)), (F16_MAX, -2.0));
        assert!(get(2, 1).is_nan());
        assert_eq!(get(0, 2), f32::INFINITY);
        assert_eq!(get(2, 2), 0.0);
    }

    #[test]
    fn script_json_cannot_close_its_element() {
        let v = serde_json::json!({ "name": "</script><b>" });
        let s = script_json(&v);
        assert!(!s.contains('<'));
        assert_eq!(serde_json::from_str::<serde_json::Value>(&s).unwrap(), v);
    }
}
