//! Helpers shared by the integration tests (each test file that needs them says `mod common;`).
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// The workspace root (two levels above this package's directory, `crates/NAME`).
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).ancestors().nth(2).unwrap().to_path_buf()
}

/// The corpus without the message: `None` when absent.
pub fn corpus_quiet() -> Option<PathBuf> {
    std::env::var_os("PHONGRT_CORPUS")
        .map(PathBuf::from)
        .into_iter()
        .chain([root().join("../shared/corpus"), root().join("../../shared/corpus")])
        .find(|c| c.is_dir())
}

/// The corpus, for the tests marked `#[ignore = "needs ../shared/corpus"]`: they run with
/// `cargo test -- --ignored` (CI does) and fail here, loudly, when it is absent.
pub fn corpus_required() -> PathBuf {
    corpus_quiet().unwrap_or_else(|| {
        panic!("../shared/corpus is absent: this test needs it (put the corpus beside the checkout or set PHONGRT_CORPUS)")
    })
}
