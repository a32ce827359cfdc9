//! The library's test helpers (`tests/common/mod.rs` at the workspace root), shared by path:
//! one copy for every crate's integration tests.
#[path = "../../../../tests/common/mod.rs"]
mod shared;
pub use shared::*;
