//! Helpers shared by the integration tests (each test file that needs them says `mod common;`),
//! of this package and of the workspace's other crates, whose `tests/common/mod.rs` include this
//! file by path.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

/// The workspace root: the package's directory for the library, two levels above it for a
/// crate in `crates/NAME`.
pub fn root() -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    match dir.parent() {
        Some(crates) if crates.file_name() == Some("crates".as_ref()) => {
            crates.parent().unwrap().to_path_buf()
        }
        _ => dir.to_path_buf(),
    }
}

/// `target/<profile>`, where cargo puts the workspace's libraries and binaries.
pub fn target_dir() -> PathBuf {
    // target/<profile>/deps/TEST-HASH -> target/<profile>
    let exe = std::env::current_exe().unwrap();
    exe.parent().and_then(|p| p.parent()).unwrap().to_path_buf()
}

/// Compile the C program `source` against include/phongrt.h and the workspace's libphongrt.so
/// (built by `cargo build --release -p phongrt-capi`; scripts/test.sh does) with the system C
/// compiler, into a temporary directory that also holds the SONAME link `libphongrt.so.0` (as an
/// install makes it). Returns the directory (keep it alive) and the program.
pub fn compile_c(source: &Path, name: &str) -> (tempfile::TempDir, PathBuf) {
    let lib_dir = target_dir();
    let so = lib_dir.join("libphongrt.so");
    assert!(
        so.exists(),
        "{} is missing: build it with `cargo build --release -p phongrt-capi` (scripts/test.sh does)",
        so.display()
    );
    let out = tempfile::tempdir().unwrap();
    let exe = out.path().join(name);
    std::os::unix::fs::symlink(&so, out.path().join("libphongrt.so.0")).unwrap();
    // Set by the build scripts of the crates whose tests compile C (not phongrt-render's).
    let (Some(emb_lib), Some(emb_include)) =
        (option_env!("PHONGRT_EMBREE_LIB_DIR"), option_env!("PHONGRT_EMBREE_INCLUDE_DIR"))
    else {
        panic!("this crate's build script does not set PHONGRT_EMBREE_LIB_DIR and PHONGRT_EMBREE_INCLUDE_DIR")
    };
    let mut c = Command::new(std::env::var("CC").unwrap_or_else(|_| "cc".into()));
    c.args(["-std=c99", "-O1", "-g", "-Wall", "-Wextra", "-Werror", "-o"])
        .arg(&exe)
        .arg(source)
        .arg(format!("-I{}", root().join("include").display()))
        .arg(format!("-I{emb_include}"))
        .arg(format!("-L{}", lib_dir.display()))
        .arg(format!("-Wl,-rpath,{}", out.path().display()))
        .arg("-lphongrt");
    if !emb_lib.is_empty() {
        c.arg(format!("-L{emb_lib}")).arg(format!("-Wl,-rpath,{emb_lib}"));
    }
    c.args(["-lembree4", "-lm"]);
    let st = c.output().expect("cannot run the C compiler");
    assert!(
        st.status.success(),
        "C compile of {} failed:\n{}",
        source.display(),
        String::from_utf8_lossy(&st.stderr)
    );
    (out, exe)
}

/// Run the C program `exe`, which must exit 0 and print a line starting with "ok"; then again
/// under valgrind (memcheck, definite leaks are errors) when valgrind is installed.
pub fn run_c(exe: &Path) {
    let run = Command::new(exe).output().unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "C program failed:\n{stdout}\n{}", String::from_utf8_lossy(&run.stderr));
    assert!(stdout.starts_with("ok "), "{stdout}");
    let Some(mut vg) = valgrind(exe) else { return };
    let vg = vg.output().unwrap();
    assert!(vg.status.success(), "valgrind reports errors:\n{}", String::from_utf8_lossy(&vg.stderr));
    assert!(String::from_utf8_lossy(&vg.stdout).starts_with("ok "));
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

/// `valgrind` (memcheck; definite leaks are errors, exit code 9) set up to run `exe`, or `None`
/// with a message when valgrind is not installed.
pub fn valgrind(exe: &Path) -> Option<Command> {
    if Command::new("valgrind").arg("--version").output().is_err() {
        println!("skipped valgrind: not installed");
        return None;
    }
    let mut vg = Command::new("valgrind");
    vg.args(["--leak-check=full", "--errors-for-leak-kinds=definite", "--error-exitcode=9", "--quiet"])
        .arg(exe);
    Some(vg)
}

/// The message of a panic payload (`&str` or `String`; empty otherwise).
pub fn panic_message(payload: Box<dyn std::any::Any + Send>) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_default()
}
