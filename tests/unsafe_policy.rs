//! The project's rule that `unsafe` lives only in the Embree layer (`src/embree`, `src/sys`):
//! no other source file of the workspace's crates has the keyword outside a comment (run-time
//! CPU dispatch goes through the `multiversion` crate, whose generated code is not ours).
use std::path::{Path, PathBuf};

/// Every `.rs` file under `dir`, recursively.
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// Whether `line`, its `//` comment cut off, has the word `unsafe`.
fn has_unsafe(line: &str) -> bool {
    let code = line.split("//").next().unwrap_or("");
    code.split(|c: char| !(c.is_alphanumeric() || c == '_')).any(|w| w == "unsafe")
}

#[test]
fn no_unsafe_outside_the_embree_layer() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    rust_files(&root.join("src"), &mut files);
    for krate in std::fs::read_dir(root.join("crates")).unwrap() {
        rust_files(&krate.unwrap().path().join("src"), &mut files);
    }
    let layer = [root.join("src/embree"), root.join("src/sys")];
    let checked: Vec<_> = files.iter().filter(|f| !layer.iter().any(|l| f.starts_with(l))).collect();
    let mut found = Vec::new();
    for file in &checked {
        let text = std::fs::read_to_string(file).unwrap();
        for (i, line) in text.lines().enumerate() {
            if has_unsafe(line) {
                found.push(format!("{}:{}: {}", file.display(), i + 1, line.trim()));
            }
        }
    }
    assert!(checked.len() > 50, "only {} files checked", checked.len());
    assert!(found.is_empty(), "`unsafe` outside src/embree and src/sys:\n{}", found.join("\n"));
}

#[test]
fn the_unsafe_scan_sees_code_and_skips_comments() {
    assert!(has_unsafe("    return unsafe { f() };"));
    assert!(has_unsafe("unsafe fn g() {}"));
    assert!(!has_unsafe("// SAFETY: the unsafe call below"));
    assert!(!has_unsafe("    x += 1; // no unsafe here"));
    assert!(!has_unsafe("let unsafe_count = 0;"));
}
