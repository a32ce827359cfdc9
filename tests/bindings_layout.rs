//! The committed Embree 4.3 bindings (src/sys/embree-4.3.rs, used with `DOCS_RS` or the feature
//! `bundled-bindings`) lay out every struct as the installed headers do: each size, alignment and
//! field offset that bindgen asserts in the committed file is the one it asserts for the headers
//! this build found (build.rs writes the bindings it compiles to `PHONGRT_BINDINGS_RS`).
#[path = "../src/sys/layout.rs"]
mod layout;
use layout::layout_of;

#[test]
fn bundled_bindings_have_the_layout_of_the_installed_headers() {
    let bundled = include_str!("../src/sys/embree-4.3.rs");
    let built = std::fs::read_to_string(env!("PHONGRT_BINDINGS_RS")).unwrap();
    let (want, have) = (layout_of(bundled), layout_of(&built));
    // RTCBounds, RTCRay, RTCHit, RTCRayHit and their packets, the callback arguments...
    assert!(want.len() > 150, "only {} layout checks in the committed bindings", want.len());
    for key in ["Size of RTCRayHit", "Size of RTCHit", "Size of RTCRay", "Size of RTCBounds"] {
        assert!(want.contains_key(key), "no `{key}` check in the committed bindings");
    }
    let differ: Vec<_> = want.iter().filter(|(k, v)| have.get(*k) != Some(*v)).collect();
    assert!(differ.is_empty(), "the committed bindings differ from the installed headers: {differ:?}");
    // The trap of Embree 4.2 headers (as embree4-sys 0.0.12 bundles): there RTCRayHit is 80 bytes.
    assert_eq!(want["Size of RTCRayHit"], 96);
    assert_eq!(std::mem::size_of::<phongrt::sys::RTCRayHit>(), 96);
}

/// bindgen without rustfmt writes its output as spaced tokens on one line: the layout read from
/// it is the same (a machine without rustfmt must not fail the bundled-bindings check).
#[test]
fn layout_is_read_the_same_from_unformatted_bindings() {
    let bundled = include_str!("../src/sys/embree-4.3.rs");
    // What quote's token printing does to the checks: spaces between tokens outside string
    // literals, no line breaks.
    let spaced =
        |code: &str| code.replace("::", " :: ").replace('<', " < ").replace('>', " > ").replace("][", "] [");
    let unformatted: String = bundled
        .lines()
        .map(|l| {
            let parts: Vec<String> = l
                .trim()
                .split('"')
                .enumerate()
                .map(|(i, p)| if i % 2 == 0 { spaced(p) } else { p.to_string() })
                .collect();
            parts.join("\"")
        })
        .collect::<Vec<_>>()
        .join(" ");
    assert!(!unformatted.contains('\n'));
    let (want, have) = (layout_of(bundled), layout_of(&unformatted));
    assert!(want.len() > 150, "only {} layout checks in the committed bindings", want.len());
    assert_eq!(want, have);
}
