//! Reading the struct layouts out of bindgen's output, shared by `build.rs` (which compares the
//! committed bindings with the installed headers' when it uses the committed ones) and
//! `tests/bindings_layout.rs` (which compares them on every default build). Included by path in
//! both; not a module of the library.

use std::collections::BTreeMap;

/// bindgen's layout checks: `["Size of RTCRay"][size_of::<RTCRay>() - 64usize];` -> ("Size of RTCRay", 64).
/// Read from the tokens, not the lines: without rustfmt (bindgen's formatting is best effort) the
/// output is one long line with spaced tokens (`["Size of RTCRay"] [:: std :: mem :: size_of :: <
/// RTCRay > () - 64usize] ;`), and its layout is the same.
pub fn layout_of(bindings: &str) -> BTreeMap<String, u64> {
    const KINDS: [&str; 3] = ["Size of ", "Alignment of ", "Offset of field: "];
    let mut out = BTreeMap::new();
    let mut rest = bindings;
    while let Some(i) = rest.find("[\"") {
        rest = &rest[i + 2..];
        let Some((what, tail)) = rest.split_once("\"]") else { break };
        if !KINDS.iter().any(|k| what.starts_with(k)) {
            continue;
        }
        // The check's expression ends at its first `usize]`: `... - 64usize]`.
        let Some(end) = tail.find("usize]") else { continue };
        let expr = &tail[..end];
        let digits = expr.len() - expr.trim_end_matches(|c: char| c.is_ascii_digit()).len();
        let before = expr[..expr.len() - digits].trim_end();
        if digits > 0 && before.ends_with('-') {
            if let Ok(n) = expr[expr.len() - digits..].parse() {
                out.insert(what.to_string(), n);
            }
        }
        rest = &tail[end..];
    }
    out
}
