//! The C API: tests/c/mixed_scene.c, compiled with the system C compiler against
//! include/phongrt.h and libphongrt.so, builds a scene mixing native triangles, a Phong mesh and
//! an instance of it, traces rays and checks the results; then runs again under valgrind
//! (memcheck, leak check) when valgrind is installed.
//!
//! The shared library must be built first (`cargo build --release -p phongrt-capi`; scripts/test.sh does).
use std::process::Command;

mod common;

#[test]
fn c_program_mixes_triangles_phong_and_instances() {
    let (_dir, exe) = common::compile_c(&common::root().join("tests/c/mixed_scene.c"), "mixed_scene");
    common::run_c(&exe);
}

/// benches/c/user_floor.c (the user-geometry floor in plain C, run by scripts/c-floor.sh) still
/// builds against the installed Embree and its user geometry finds exactly the native triangles'
/// hits (the program exits non-zero when the counts differ).
#[test]
fn c_user_floor_matches_native_triangles() {
    let root = common::root();
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    let out = tempfile::tempdir().unwrap();
    let exe = out.path().join("user_floor");
    let emb_lib = env!("PHONGRT_EMBREE_LIB_DIR");
    let mut c = Command::new(&cc);
    c.args(["-std=c99", "-O1", "-Wall", "-Wextra", "-Werror", "-o"])
        .arg(&exe)
        .arg(root.join("benches/c/user_floor.c"))
        .arg(format!("-I{}", env!("PHONGRT_EMBREE_INCLUDE_DIR")));
    if !emb_lib.is_empty() {
        c.arg(format!("-L{emb_lib}")).arg(format!("-Wl,-rpath,{emb_lib}"));
    }
    c.args(["-lembree4", "-lm"]);
    let st = c.output().expect("cannot run the C compiler");
    assert!(st.status.success(), "C compile failed:\n{}", String::from_utf8_lossy(&st.stderr));
    let run = Command::new(&exe).args(["8", "4", "24"]).output().unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "user_floor failed:\n{stdout}\n{}", String::from_utf8_lossy(&run.stderr));
    // A sphere filling most of the view: some rays hit, and the callback ran.
    let line = stdout.lines().find(|l| l.starts_with("native ")).expect("no timing line");
    let hits: u32 = line
        .split('(')
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.parse().ok())
        .expect("no hit count");
    assert!(hits > 0 && hits < 24 * 24, "{line}");
    assert!(!line.contains("0.00 callback calls"), "{line}");
}

/// tests/c/pending_error.c: phongrt_attach_mesh on a device with an error left pending by the
/// caller succeeds (the mesh is attached and traced, under valgrind when installed, so a mesh
/// freed under its geometry would show), and leaves that error for the caller.
#[test]
fn c_attach_with_callers_pending_device_error_succeeds() {
    let (_dir, exe) = common::compile_c(&common::root().join("tests/c/pending_error.c"), "pending_error");
    common::run_c(&exe);
}
