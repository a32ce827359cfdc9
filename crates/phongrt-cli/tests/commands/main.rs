//! The `phongrt` command's tests that run the binary or render through the library, as one test
//! target: one build of `assert_cmd`, `predicates` and the shared helpers instead of one per file
//! (each such target took 12–21 s to compile at `opt-level = 3`). Each file is a module.
#[path = "../common/mod.rs"]
mod common;

mod cli;
mod cli_materials;
mod concurrent_outputs;
mod environment;
mod image_diff;
mod render_packets;
mod stitch_integrity;
mod tiles;
