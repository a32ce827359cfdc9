//! Find Embree 4, generate its bindings with bindgen, link it with an rpath.
//!
//! Search order (the first that has `include/embree4/rtcore.h` wins):
//! 1. `EMBREE_DIR` (a prefix with `include/embree4` and `lib` or `lib64`);
//! 2. pkg-config `embree4`;
//! 3. the default system prefixes (`/usr`, `/usr/local`, `/opt/homebrew`, `/opt/local`);
//! 4. the cache filled by `scripts/setup-embree.sh`
//!    (`$PHONGRT_CACHE` or `$XDG_CACHE_HOME/phongrt` or `$HOME/.cache/phongrt`, then `embree-4.4.0`).

use std::env;
use std::path::{Path, PathBuf};

struct Embree {
    include_dir: PathBuf,
    lib_dir: Option<PathBuf>,
    how: String,
}

fn has_headers(include_dir: &Path) -> bool {
    include_dir.join("embree4").join("rtcore.h").is_file()
}

fn lib_dir_of(prefix: &Path) -> Option<PathBuf> {
    ["lib", "lib64", "lib/x86_64-linux-gnu", "lib/aarch64-linux-gnu"]
        .iter()
        .map(|d| prefix.join(d))
        .find(|d| ["libembree4.so", "libembree4.dylib", "embree4.lib"].iter().any(|f| d.join(f).exists()))
}

fn from_prefix(prefix: &Path, how: &str) -> Option<Embree> {
    let include_dir = prefix.join("include");
    if !has_headers(&include_dir) {
        return None;
    }
    Some(Embree { include_dir, lib_dir: lib_dir_of(prefix), how: format!("{how} ({})", prefix.display()) })
}

fn cache_dir() -> Option<PathBuf> {
    if let Some(c) = env::var_os("PHONGRT_CACHE") {
        return Some(PathBuf::from(c));
    }
    if let Some(x) = env::var_os("XDG_CACHE_HOME") {
        return Some(PathBuf::from(x).join("phongrt"));
    }
    env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache").join("phongrt"))
}

fn find_embree() -> Result<Embree, String> {
    // 1. EMBREE_DIR: an explicit choice must be right, or we say so.
    if let Some(dir) = env::var_os("EMBREE_DIR") {
        let dir = PathBuf::from(dir);
        return from_prefix(&dir, "EMBREE_DIR").ok_or_else(|| {
            format!(
                "EMBREE_DIR={} has no include/embree4/rtcore.h; point it at an Embree 4 install prefix",
                dir.display()
            )
        });
    }
    // 2. pkg-config.
    if let Ok(lib) = pkg_config::Config::new().atleast_version("4.0").cargo_metadata(false).probe("embree4") {
        if let Some(inc) = lib.include_paths.iter().find(|p| has_headers(p)) {
            return Ok(Embree {
                include_dir: inc.clone(),
                lib_dir: lib.link_paths.first().cloned(),
                how: format!("pkg-config embree4 {}", lib.version),
            });
        }
    }
    // 3. System prefixes.
    for prefix in ["/usr", "/usr/local", "/opt/homebrew", "/opt/local"] {
        if let Some(e) = from_prefix(Path::new(prefix), "system") {
            return Ok(e);
        }
    }
    // 4. The cache of scripts/setup-embree.sh.
    if let Some(cache) = cache_dir() {
        if let Some(e) = from_prefix(&cache.join("embree-4.4.0"), "setup-embree.sh cache") {
            return Ok(e);
        }
    }
    Err("Embree 4 was not found.\n\
         Looked at: EMBREE_DIR, pkg-config `embree4`, /usr, /usr/local, /opt/homebrew, /opt/local and the\n\
         cache of scripts/setup-embree.sh. To get it:\n\
         - Debian 12 / Ubuntu 22.04 (no Embree 4 package): run `scripts/setup-embree.sh` (fetches the\n\
           Debian 13 headers and the PyPI embreex runtime into ~/.cache/phongrt; no system changes\n\
           beyond `apt-get install libclang-dev`), or just use `scripts/test.sh` / `scripts/demo.sh`;\n\
         - Debian 13 / Ubuntu 24.04: `apt-get install libembree-dev`; Arch: `pacman -S embree`;\n\
           macOS: `brew install embree`;\n\
         - or set EMBREE_DIR to an Embree 4 prefix (with include/embree4 and lib)."
        .to_string())
}

/// Whether the dynamic loader finds libraries in `dir` without help (no rpath, no
/// LD_LIBRARY_PATH): the default directories of glibc's loader and of Debian's multiarch layout.
fn is_system_lib_dir(dir: &Path) -> bool {
    let dir = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
    [
        "/lib",
        "/lib64",
        "/usr/lib",
        "/usr/lib64",
        "/usr/lib/x86_64-linux-gnu",
        "/lib/x86_64-linux-gnu",
        "/usr/lib/aarch64-linux-gnu",
        "/lib/aarch64-linux-gnu",
    ]
    .iter()
    .any(|d| dir == Path::new(d))
}

/// Link (or copy) Embree's runtime files from `lib_dir` into `OUT_DIR/lib`: `libembree4*` and the
/// TBB it was built with (`libtbb*`), shared objects only. Returns that directory.
fn runtime_into_out_dir(lib_dir: &Path) -> std::io::Result<PathBuf> {
    let out = PathBuf::from(env::var("OUT_DIR").expect("cargo sets OUT_DIR")).join("lib");
    std::fs::create_dir_all(&out)?;
    for entry in std::fs::read_dir(lib_dir)? {
        let entry = entry?;
        let name = entry.file_name();
        let n = name.to_string_lossy();
        let shared = n.contains(".so") || n.ends_with(".dylib");
        if !(shared && (n.starts_with("libembree4") || n.starts_with("libtbb"))) {
            continue;
        }
        let dest = out.join(&name);
        let _ = std::fs::remove_file(&dest);
        let src = entry.path().canonicalize()?;
        #[cfg(unix)]
        let linked = std::os::unix::fs::symlink(&src, &dest);
        #[cfg(not(unix))]
        let linked: std::io::Result<()> = Err(std::io::ErrorKind::Unsupported.into());
        if linked.is_err() {
            std::fs::copy(&src, &dest)?;
        }
    }
    Ok(out)
}

fn main() {
    for var in ["EMBREE_DIR", "PKG_CONFIG_PATH", "PHONGRT_CACHE", "XDG_CACHE_HOME", "HOME", "LIBCLANG_PATH"] {
        println!("cargo:rerun-if-env-changed={var}");
    }
    println!("cargo:rerun-if-changed=build.rs");

    let embree = match find_embree() {
        Ok(e) => e,
        Err(msg) => {
            eprintln!("\nerror: {msg}\n");
            panic!("phongrt build: Embree 4 not found (see the message above)");
        }
    };
    let rtcore = embree.include_dir.join("embree4").join("rtcore.h");
    println!("cargo:rerun-if-changed={}", rtcore.display());
    println!(
        "cargo:rerun-if-changed={}",
        embree.include_dir.join("embree4").join("rtcore_config.h").display()
    );
    println!("cargo:warning=phongrt: using Embree 4 from {}", embree.how);

    // Link, with an rpath so target/*/phongrt and the test binaries run without LD_LIBRARY_PATH.
    if let Some(lib_dir) = &embree.lib_dir {
        // For dependents: the rpath above applies to this package's own targets only, but Cargo
        // puts every link-search path that lies inside OUT_DIR on the dynamic-library path of
        // `cargo run` and `cargo test` (the Cargo book, build scripts, `rustc-link-search`), so
        // an Embree the system loader cannot find is linked into OUT_DIR/lib (symlinks, or copies
        // where links fail) and searched there first.
        if !is_system_lib_dir(lib_dir) {
            match runtime_into_out_dir(lib_dir) {
                Ok(dir) => println!("cargo:rustc-link-search=native={}", dir.display()),
                Err(e) => println!(
                    "cargo:warning=phongrt: cannot link the Embree runtime into OUT_DIR ({e}); dependents \
                     need LD_LIBRARY_PATH={} for `cargo run`",
                    lib_dir.display()
                ),
            }
        }
        println!("cargo:rustc-link-search=native={}", lib_dir.display());
        if env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("windows") {
            println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib_dir.display());
        }
        println!("cargo:rustc-env=PHONGRT_EMBREE_LIB_DIR={}", lib_dir.display());
        println!("cargo:lib={}", lib_dir.display());
    } else {
        println!("cargo:rustc-env=PHONGRT_EMBREE_LIB_DIR=");
    }
    println!("cargo:rustc-link-lib=dylib=embree4");
    println!("cargo:rustc-env=PHONGRT_EMBREE_INCLUDE_DIR={}", embree.include_dir.display());
    println!("cargo:include={}", embree.include_dir.display());

    // Bindings: only the rtc API, enums as newtypes (no UB on unknown values), flags as bitfields.
    let bindings = bindgen::Builder::default()
        .header(rtcore.to_string_lossy())
        .clang_arg(format!("-I{}", embree.include_dir.display()))
        .allowlist_function("rtc.*")
        .allowlist_type("RTC.*")
        .allowlist_var("RTC.*")
        .default_enum_style(bindgen::EnumVariation::NewType { is_bitfield: false, is_global: false })
        .bitfield_enum("RTC.*Flags")
        .derive_default(true)
        .derive_debug(true)
        .layout_tests(true)
        .generate_comments(false)
        .parse_callbacks(Box::new(bindgen::CargoCallbacks::new()))
        .generate()
        .unwrap_or_else(|e| panic!("bindgen failed on {}: {e}", rtcore.display()));
    let out = PathBuf::from(env::var("OUT_DIR").expect("cargo sets OUT_DIR")).join("embree4.rs");
    bindings.write_to_file(&out).unwrap_or_else(|e| panic!("cannot write {}: {e}", out.display()));
}
