//! Reading the struct layouts out of bindgen's output, shared by `build.rs` (which compares the
//! committed bindings with the installed headers' when it uses the committed ones) and
//! `tests/bindings_layout.rs` (which compares them on every default build). Included by path in
//! both; not a module of the library.

use std::collections::BTreeMap;

/// bindgen's layout checks: `["Size of RTCRay"][size_of::<RTCRay>() - 64usize];` -> ("Size of RTCRay", 64).
pub fn layout_of(bindings: &str) -> BTreeMap<String, u64> {
    bindings
        .lines()
        .filter_map(|l| {
            let l = l.trim().strip_prefix("[\"")?;
            let (what, rest) = l.split_once("\"]")?;
            let n = rest.rsplit_once(" - ")?.1.strip_suffix("usize];")?;
            Some((what.to_string(), n.parse().ok()?))
        })
        .collect()
}
