//! Content hashes that stay the same across builds and machines: SHA-256 of bytes (a model's
//! source, the fit cache's key, a scene's or a plan's inputs) and FNV-1a of a list of parts.

use sha2::{Digest, Sha256};

/// SHA-256 of bytes, hex (the `source.sha256` of a model and the fit cache's key).
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// Hash of a text (SHA-256, first 16 bytes in hex): a scene file's, or a plan's inputs.
pub fn text_hash(text: &str) -> String {
    let d = Sha256::digest(text.as_bytes());
    d[..16].iter().map(|b| format!("{b:02x}")).collect()
}

/// FNV-1a over `parts`, each followed by a 0xff byte; stable across builds (the reference
/// cache key).
pub fn fnv1a(parts: &[&[u8]]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for p in parts {
        for b in p.iter().chain(&[0xffu8]) {
            h ^= *b as u64;
            h = h.wrapping_mul(0x100_0000_01b3);
        }
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_hash_depends_on_every_byte() {
        assert_eq!(text_hash("{}").len(), 32);
        assert_ne!(text_hash("{}"), text_hash("{} "));
    }
}
