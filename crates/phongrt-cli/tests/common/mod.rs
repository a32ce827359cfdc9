//! The library's test helpers (`tests/common/mod.rs` at the workspace root), shared by path:
//! one copy for every crate's integration tests; and the command line's own.
#![allow(dead_code)]

#[path = "../../../../tests/common/mod.rs"]
mod shared;
pub use shared::*;

/// The `phongrt` binary, run from the workspace root (so `scenes/...` paths name the repository's
/// scenes).
pub fn phongrt() -> assert_cmd::Command {
    let mut c = assert_cmd::Command::cargo_bin("phongrt").unwrap();
    c.current_dir(root());
    c
}

/// A finished command's standard error, as text.
pub fn stderr_of(a: &assert_cmd::assert::Assert) -> String {
    String::from_utf8_lossy(&a.get_output().stderr).into_owned()
}
