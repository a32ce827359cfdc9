//! C packaging: scripts/install.sh into a temporary PREFIX, then C programs built against it the
//! ways a C or C++ user would (pkg-config; CMake's find_package) run with no LD_LIBRARY_PATH, and
//! under valgrind when it is installed. Also: the header's version macros agree with Cargo.toml.
//!
//! The install relinks the release build of phongrt-capi (scripts/test.sh has built it) and runs
//! once for the whole file. cmake and pkg-config come from scripts/test.sh (apt-get) when missing;
//! a test that needs one prints that it is skipped when it still cannot be found.
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

mod common;

/// The install PREFIX shared by the tests of this file (made once; kept for the process).
fn prefix() -> &'static Path {
    static PREFIX: OnceLock<(tempfile::TempDir, PathBuf)> = OnceLock::new();
    let (_dir, prefix) = PREFIX.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let prefix = dir.path().join("prefix");
        // The same target directory as this test's build, whatever CARGO_TARGET_DIR says.
        let target = common::target_dir().parent().unwrap().to_path_buf();
        let out = Command::new(common::root().join("scripts/install.sh"))
            .arg(&prefix)
            .env("CARGO_TARGET_DIR", &target)
            .output()
            .expect("cannot run scripts/install.sh");
        assert!(
            out.status.success(),
            "scripts/install.sh failed:\n{}\n{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        (dir, prefix)
    });
    prefix
}

fn tool_present(tool: &str) -> bool {
    let ok = Command::new(tool).arg("--version").output().is_ok_and(|o| o.status.success());
    if !ok {
        println!("skipped: {tool} not found (scripts/test.sh installs it with apt-get where it can)");
    }
    ok
}

fn check(what: &str, out: &Output) {
    assert!(
        out.status.success(),
        "{what} failed ({}):\n{}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

fn readelf_dynamic(file: &Path) -> String {
    let out = Command::new("readelf").arg("-d").arg(file).output().expect("cannot run readelf");
    check("readelf -d", &out);
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Runs an installed program as a user would: no LD_LIBRARY_PATH, and under valgrind too.
fn run_installed(exe: &Path) {
    let run = Command::new(exe).env_remove("LD_LIBRARY_PATH").output().unwrap();
    check(&format!("{}", exe.display()), &run);
    let stdout = String::from_utf8_lossy(&run.stdout);
    let version = format!("phongrt {}\n", env!("CARGO_PKG_VERSION"));
    assert!(stdout.starts_with(&version), "the installed header's version is not {version}: {stdout}");
    assert!(stdout.lines().nth(1).is_some_and(|l| l.starts_with("ok ")), "{stdout}");

    let Some(mut vg) = common::valgrind(exe) else { return };
    let vg = vg.env_remove("LD_LIBRARY_PATH").output().unwrap();
    check("the installed program under valgrind", &vg);
}

/// The `#define NAME VALUE` of include/phongrt.h.
fn header_define(header: &str, name: &str) -> String {
    let prefix = format!("#define {name} ");
    header
        .lines()
        .find_map(|l| l.strip_prefix(&prefix))
        .unwrap_or_else(|| panic!("include/phongrt.h has no #define {name}"))
        .trim()
        .to_string()
}

#[test]
fn header_version_macros_match_cargo_toml() {
    let header = std::fs::read_to_string(common::root().join("include/phongrt.h")).unwrap();
    assert_eq!(header_define(&header, "PHONGRT_VERSION_MAJOR"), env!("CARGO_PKG_VERSION_MAJOR"));
    assert_eq!(header_define(&header, "PHONGRT_VERSION_MINOR"), env!("CARGO_PKG_VERSION_MINOR"));
    assert_eq!(header_define(&header, "PHONGRT_VERSION_PATCH"), env!("CARGO_PKG_VERSION_PATCH"));
    assert_eq!(header_define(&header, "PHONGRT_VERSION"), format!("\"{}\"", env!("CARGO_PKG_VERSION")));
}

#[test]
fn install_lays_out_header_libraries_pc_cmake_and_embree() {
    let p = prefix();
    let version = env!("CARGO_PKG_VERSION");
    let major = env!("CARGO_PKG_VERSION_MAJOR");
    for f in [
        "include/phongrt.h".to_string(),
        format!("lib/libphongrt.so.{version}"),
        "lib/libphongrt.a".into(),
        "lib/pkgconfig/phongrt.pc".into(),
        "lib/cmake/phongrt/phongrtConfig.cmake".into(),
        "lib/cmake/phongrt/phongrtConfigVersion.cmake".into(),
        "share/doc/phongrt/LICENSE-MIT".into(),
    ] {
        assert!(p.join(&f).is_file(), "{f} is not installed");
    }
    // The SONAME link and the development link.
    let so_major = format!("libphongrt.so.{major}");
    assert_eq!(
        std::fs::read_link(p.join("lib").join(&so_major)).unwrap(),
        Path::new(&format!("libphongrt.so.{version}"))
    );
    assert_eq!(std::fs::read_link(p.join("lib/libphongrt.so")).unwrap(), Path::new(&so_major));
    // The installed library names itself by its SONAME and looks for Embree beside itself (or in
    // the system's path) only: no rpath into the build machine's Embree.
    let dynamic = readelf_dynamic(&p.join(format!("lib/libphongrt.so.{version}")));
    assert!(dynamic.contains(&format!("Library soname: [{so_major}]")), "{dynamic}");
    let rpaths: Vec<&str> =
        dynamic.lines().filter(|l| l.contains("RUNPATH") || l.contains("RPATH")).collect();
    assert_eq!(rpaths.len(), 1, "{dynamic}");
    assert!(
        rpaths[0].ends_with("[$ORIGIN]"),
        "the installed library's rpath is not $ORIGIN alone: {}",
        rpaths[0]
    );
    // The header's version macros are the workspace's.
    let header = std::fs::read_to_string(p.join("include/phongrt.h")).unwrap();
    assert_eq!(header_define(&header, "PHONGRT_VERSION"), format!("\"{version}\""));
    // Embree: shipped beside libphongrt unless the build's Embree is a system library.
    let emb_lib = env!("PHONGRT_EMBREE_LIB_DIR");
    let system = ["/usr/lib", "/lib"].iter().any(|d| emb_lib.starts_with(d));
    let needed = dynamic
        .lines()
        .find_map(|l| l.split("Shared library: [").nth(1).filter(|s| s.starts_with("libembree4")))
        .map(|s| s.trim_end_matches(']').to_string())
        .expect("libphongrt.so does not need libembree4");
    if !system {
        assert!(p.join("lib").join(&needed).exists(), "{needed} is not shipped into PREFIX/lib");
        assert!(p.join("include/embree4/rtcore.h").is_file(), "the Embree headers are not shipped");
        // Only the loader's files: libembree4 under the name libphongrt needs, the development
        // link, and the libraries libembree4 needs (TBB); no other libembree4/libtbb file.
        let shipped: Vec<String> = std::fs::read_dir(p.join("lib"))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with("libembree4") || n.starts_with("libtbb"))
            .collect();
        let emb_needs = readelf_dynamic(&p.join("lib").join(&needed));
        for name in &shipped {
            let wanted = *name == needed
                || name == "libembree4.so"
                || emb_needs.contains(&format!("Shared library: [{name}]"));
            assert!(wanted, "{name} is shipped but nothing loads it (shipped: {shipped:?})");
        }
    }
}

/// The installed libraries carry no debug information (install.sh strips them; `--keep-debug`
/// keeps it in a separate file).
#[test]
fn installed_libraries_are_stripped() {
    let p = prefix();
    let version = env!("CARGO_PKG_VERSION");
    for lib in [format!("lib/libphongrt.so.{version}"), "lib/libphongrt.a".into()] {
        let out = Command::new("readelf").arg("-S").arg(p.join(&lib)).output().expect("cannot run readelf");
        check("readelf -S", &out);
        let sections = String::from_utf8_lossy(&out.stdout);
        assert!(!sections.contains(".debug_info"), "{lib} still has debug information");
    }
}

/// `cc prog.c $(PKG_CONFIG_PATH=PREFIX/lib/pkgconfig pkg-config --cflags --libs phongrt)`, run
/// with no LD_LIBRARY_PATH.
#[test]
fn pkg_config_built_program_runs_without_ld_library_path() {
    if !tool_present("pkg-config") {
        return;
    }
    let p = prefix();
    let pc = Command::new("pkg-config")
        .args(["--cflags", "--libs", "phongrt"])
        .env("PKG_CONFIG_PATH", p.join("lib/pkgconfig"))
        .output()
        .unwrap();
    check("pkg-config --cflags --libs phongrt", &pc);
    let flags = String::from_utf8(pc.stdout).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let exe = dir.path().join("installed");
    // The flags split as the shell splits `$(pkg-config ...)`.
    let out = Command::new("sh")
        .arg("-c")
        .arg(format!("${{CC:-cc}} -std=c99 -Wall -Wextra -Werror -o \"$1\" \"$2\" {} -lm", flags.trim()))
        .arg("sh")
        .arg(&exe)
        .arg(common::root().join("tests/c/installed.c"))
        .output()
        .unwrap();
    check(&format!("cc installed.c {}", flags.trim()), &out);
    run_installed(&exe);
}

/// A CMake project with find_package(phongrt REQUIRED) and target_link_libraries(prog
/// phongrt::phongrt), configured with CMAKE_PREFIX_PATH=PREFIX, run with no LD_LIBRARY_PATH.
#[test]
fn cmake_find_package_program_runs_without_ld_library_path() {
    if !tool_present("cmake") {
        return;
    }
    let p = prefix();
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src");
    std::fs::create_dir(&src).unwrap();
    std::fs::copy(common::root().join("tests/c/installed.c"), src.join("prog.c")).unwrap();
    std::fs::write(
        src.join("CMakeLists.txt"),
        format!(
            "cmake_minimum_required(VERSION 3.13)\n\
             project(installed C)\n\
             find_package(phongrt {} REQUIRED)\n\
             add_executable(prog prog.c)\n\
             target_link_libraries(prog phongrt::phongrt m)\n",
            env!("CARGO_PKG_VERSION")
        ),
    )
    .unwrap();
    let build = dir.path().join("build");
    let configure = Command::new("cmake")
        .arg("-S")
        .arg(&src)
        .arg("-B")
        .arg(&build)
        .arg(format!("-DCMAKE_PREFIX_PATH={}", p.display()))
        .output()
        .unwrap();
    check("cmake configure", &configure);
    let make = Command::new("cmake").arg("--build").arg(&build).output().unwrap();
    check("cmake --build", &make);
    run_installed(&build.join("prog"));
}

/// The static library: `pkg-config --static --libs phongrt` with `-lphongrt` taken as
/// `-l:libphongrt.a` links (its Libs.private are what the Rust staticlib needs), and the program
/// runs with no libphongrt.so loaded.
#[test]
fn static_library_links_with_pkg_config_static_flags() {
    if !tool_present("pkg-config") {
        return;
    }
    let p = prefix();
    let pc = Command::new("pkg-config")
        .args(["--cflags", "--libs", "--static", "phongrt"])
        .env("PKG_CONFIG_PATH", p.join("lib/pkgconfig"))
        .output()
        .unwrap();
    check("pkg-config --cflags --libs --static phongrt", &pc);
    let flags = String::from_utf8(pc.stdout).unwrap();
    let flags: Vec<&str> =
        flags.split_whitespace().map(|f| if f == "-lphongrt" { "-l:libphongrt.a" } else { f }).collect();
    assert!(flags.contains(&"-l:libphongrt.a"), "{flags:?}");
    let dir = tempfile::tempdir().unwrap();
    let exe = dir.path().join("installed_static");
    let out = Command::new(std::env::var("CC").unwrap_or_else(|_| "cc".into()))
        .args(["-std=c99", "-Wall", "-Wextra", "-Werror", "-o"])
        .arg(&exe)
        .arg(common::root().join("tests/c/installed.c"))
        .args(&flags)
        .arg("-lm")
        .output()
        .unwrap();
    check(&format!("cc installed.c {}", flags.join(" ")), &out);
    let dynamic = readelf_dynamic(&exe);
    assert!(!dynamic.contains("libphongrt.so"), "the static build still needs libphongrt.so:\n{dynamic}");
    run_installed(&exe);
}
