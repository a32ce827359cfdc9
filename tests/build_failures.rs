//! build.rs on a machine without a usable Embree: each case ends with one line on stderr that says
//! what was found and what is needed (exit status 1), and `DOCS_RS` with no Embree builds the
//! committed bindings with nothing linked (exit status 0). The compiled build script of this
//! package is run directly, with a controlled environment: no Cargo rebuild per case.
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

mod common;

/// The newest compiled build script of the phongrt package in this test's target directory.
fn build_script() -> PathBuf {
    let build = common::target_dir().join("build");
    let newest = std::fs::read_dir(&build)
        .unwrap()
        .flatten()
        // phongrt-HASH, not phongrt-capi-HASH or phongrt-cli-HASH (the other packages' scripts).
        .filter(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            name.strip_prefix("phongrt-").is_some_and(|h| h.chars().all(|c| c.is_ascii_hexdigit()))
        })
        .map(|e| e.path().join("build-script-build"))
        .filter(|p| p.is_file())
        .max_by_key(|p| p.metadata().and_then(|m| m.modified()).ok());
    newest.unwrap_or_else(|| panic!("no phongrt build script under {}", build.display()))
}

/// Run the build script with only `vars` (and PATH) set, from the package root, as Cargo does;
/// HOME and the cache point into `tmp`, so no Embree is found unless `vars` names one.
fn run_build_script(tmp: &Path, vars: &[(&str, &str)]) -> Output {
    let out_dir = tmp.join("out");
    std::fs::create_dir_all(&out_dir).unwrap();
    let mut cmd = Command::new(build_script());
    cmd.env_clear()
        .current_dir(common::root())
        .env("PATH", std::env::var_os("PATH").unwrap_or_default())
        .env("OUT_DIR", &out_dir)
        .env("HOME", tmp)
        .env("PHONGRT_CACHE", tmp.join("no-cache"))
        .env("PKG_CONFIG_PATH", tmp.join("no-pkgconfig"))
        .env("PKG_CONFIG_LIBDIR", tmp.join("no-pkgconfig"))
        .env("CARGO_CFG_TARGET_OS", "linux");
    // As under cargo: rustup's own variables reach bindgen's rustfmt (HOME is changed above).
    for k in ["RUSTUP_HOME", "RUSTUP_TOOLCHAIN", "CARGO_HOME", "LIBCLANG_PATH"] {
        if let Some(v) = std::env::var_os(k) {
            cmd.env(k, v);
        }
    }
    if std::env::var_os("RUSTUP_HOME").is_none() {
        if let Some(home) = std::env::var_os("HOME") {
            cmd.env("RUSTUP_HOME", Path::new(&home).join(".rustup"));
        }
    }
    for (k, v) in vars {
        cmd.env(k, v);
    }
    cmd.output().expect("cannot run the build script")
}

/// The one line of a failed run (asserting it failed with exactly one stderr line).
fn one_line_error(out: &Output) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "the build script did not fail: {stderr}");
    assert_eq!(stderr.lines().count(), 1, "not one line:\n{stderr}");
    assert!(stderr.starts_with("error: phongrt: "), "{stderr}");
    stderr
}

/// The system's Embree 4 headers, where this machine has them in a system prefix (then the "not
/// found" cases cannot be staged and are skipped with a message).
fn system_embree4() -> bool {
    ["/usr", "/usr/local", "/opt/homebrew", "/opt/local"]
        .iter()
        .any(|p| Path::new(p).join("include/embree4/rtcore.h").is_file())
}

/// A fake Embree prefix: the installed headers (from this build's Embree) with `edit` applied to
/// `file`, and the installed runtime's directory linked as `lib`.
fn fake_prefix(tmp: &Path, file: &str, edit: impl Fn(String) -> String) -> PathBuf {
    let real_inc = Path::new(env!("PHONGRT_EMBREE_INCLUDE_DIR")).join("embree4");
    let prefix = tmp.join("embree");
    let inc = prefix.join("include/embree4");
    std::fs::create_dir_all(&inc).unwrap();
    for e in std::fs::read_dir(&real_inc).unwrap().flatten() {
        let text = std::fs::read_to_string(e.path()).unwrap();
        let text = if e.file_name() == file { edit(text) } else { text };
        std::fs::write(inc.join(e.file_name()), text).unwrap();
    }
    let lib = env!("PHONGRT_EMBREE_LIB_DIR");
    assert!(!lib.is_empty(), "this build's Embree has no library directory");
    std::os::unix::fs::symlink(lib, prefix.join("lib")).unwrap();
    prefix
}

#[test]
fn no_embree_fails_with_one_line_naming_the_packages_and_embree_dir() {
    if system_embree4() {
        println!("skipped: this machine has Embree 4 in a system prefix, so 'not found' cannot be staged");
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let err = one_line_error(&run_build_script(tmp.path(), &[]));
    for want in [
        "Embree 4.3+ not found",
        "apt install libembree-dev",
        "pacman -S embree",
        "brew install embree",
        "EMBREE_DIR",
    ] {
        assert!(err.contains(want), "no {want:?} in: {err}");
    }
    assert!(!err.contains("setup-embree.sh"), "points at a script a crates.io user does not have: {err}");
}

#[test]
fn docs_rs_without_embree_builds_the_committed_bindings_and_links_nothing() {
    if system_embree4() {
        println!("skipped: this machine has Embree 4 in a system prefix, so 'no Embree' cannot be staged");
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let out = run_build_script(tmp.path(), &[("DOCS_RS", "1")]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    assert!(
        stdout.contains("cargo:warning=phongrt: DOCS_RS is set and no Embree 4.3+ was found"),
        "{stdout}"
    );
    assert!(!stdout.contains("rustc-link-lib"), "DOCS_RS without Embree links: {stdout}");
    let written = std::fs::read_to_string(tmp.path().join("out/embree4.rs")).unwrap();
    let committed = std::fs::read_to_string(common::root().join("src/sys/embree-4.3.rs")).unwrap();
    assert_eq!(written, committed, "DOCS_RS did not build the committed bindings");
}

#[test]
fn embree_dir_without_headers_fails_with_one_line_naming_it() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("empty-prefix");
    std::fs::create_dir_all(&dir).unwrap();
    let err = one_line_error(&run_build_script(tmp.path(), &[("EMBREE_DIR", dir.to_str().unwrap())]));
    assert!(
        err.contains(&format!("EMBREE_DIR={}", dir.display())) && err.contains("include/embree4/rtcore.h"),
        "{err}"
    );
}

#[test]
fn embree_older_than_4_3_fails_with_one_line_naming_the_version_found_and_needed() {
    let tmp = tempfile::tempdir().unwrap();
    let prefix =
        fake_prefix(tmp.path(), "rtcore_config.h", |t| {
            t.lines()
                .map(|l| {
                    if l.starts_with("#define RTC_VERSION_MINOR ") {
                        "#define RTC_VERSION_MINOR 2"
                    } else {
                        l
                    }
                })
                .collect::<Vec<_>>()
                .join("\n")
        });
    let err = one_line_error(&run_build_script(tmp.path(), &[("EMBREE_DIR", prefix.to_str().unwrap())]));
    assert!(err.contains("Embree 4.2.") && err.contains("needs Embree 4.3 or newer"), "{err}");
}

#[test]
fn bundled_bindings_that_differ_from_the_headers_fail_with_one_line_naming_the_field() {
    let tmp = tempfile::tempdir().unwrap();
    // A header whose RTCHit has one more field than the 4.3 layout the bindings were made from.
    let prefix = fake_prefix(tmp.path(), "rtcore_ray.h", |t| {
        t.replacen("struct RTC_ALIGN(16) RTCHit\n{", "struct RTC_ALIGN(16) RTCHit\n{\n  float extra;", 1)
    });
    let edited = std::fs::read_to_string(prefix.join("include/embree4/rtcore_ray.h")).unwrap();
    assert!(edited.contains("float extra;"), "the test's edit of rtcore_ray.h did not apply");
    let err = one_line_error(&run_build_script(
        tmp.path(),
        &[("EMBREE_DIR", prefix.to_str().unwrap()), ("CARGO_FEATURE_BUNDLED_BINDINGS", "1")],
    ));
    assert!(err.contains("do not match the headers") && err.contains("RTCHit"), "{err}");
}

#[test]
fn bundled_bindings_with_matching_headers_pass_without_rustfmt() {
    let tmp = tempfile::tempdir().unwrap();
    let prefix = fake_prefix(tmp.path(), "", |t| t);
    // No rustfmt on PATH (nor rustup's proxies): bindgen's output stays unformatted.
    let out = run_build_script(
        tmp.path(),
        &[
            ("EMBREE_DIR", prefix.to_str().unwrap()),
            ("CARGO_FEATURE_BUNDLED_BINDINGS", "1"),
            ("PATH", "/usr/bin:/bin"),
        ],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "the bundled bindings were refused without rustfmt: {stderr}");
    let written = std::fs::read_to_string(tmp.path().join("out/embree4.rs")).unwrap();
    assert_eq!(written, std::fs::read_to_string(common::root().join("src/sys/embree-4.3.rs")).unwrap());
}
