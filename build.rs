//! Find Embree 4, generate its bindings with bindgen (or take the committed ones), link it with an
//! rpath.
//!
//! Search order (the first that has `include/embree4/rtcore.h` wins):
//! 1. `EMBREE_DIR` (a prefix with `include/embree4` and `lib` or `lib64`);
//! 2. pkg-config `embree4`;
//! 3. the default system prefixes (`/usr`, `/usr/local`, `/opt/homebrew`, `/opt/local`);
//! 4. the cache filled by the repository's `scripts/setup-embree.sh`
//!    (`$PHONGRT_CACHE` or `$XDG_CACHE_HOME/phongrt` or `$HOME/.cache/phongrt`, then `embree-4.4.0`).
//!
//! Bindings: bindgen runs on the Embree found, except when `DOCS_RS` is set or the feature
//! `bundled-bindings` is on. Then the committed `src/sys/embree-4.3.rs` (bindgen's output for the
//! Embree 4.3.3 headers, 64-bit Linux) is used, and where headers are installed their struct layout
//! must equal the committed one. With `DOCS_RS` and no Embree at all nothing is linked: `cargo doc`
//! and `cargo check` work (also for a crate depending on phongrt on docs.rs), a link does not.
//!
//! Every failure is one line on stderr and exit status 1: what was found, and what is needed.

#[path = "src/sys/layout.rs"]
mod layout;
use layout::layout_of;
use std::env;
use std::path::{Path, PathBuf};

/// The oldest Embree the library supports (its API and the committed bindings' headers).
const MIN_VERSION: (u32, u32) = (4, 3);
/// The committed bindings, relative to the package root.
const BUNDLED: &str = "src/sys/embree-4.3.rs";

struct Embree {
    include_dir: PathBuf,
    lib_dir: Option<PathBuf>,
    how: String,
    /// Found in the cache of scripts/setup-embree.sh (the only case worth a cargo:warning).
    from_cache: bool,
}

/// Print `msg` as the build's one-line error and stop the build.
fn fail(msg: &str) -> ! {
    eprintln!("error: phongrt: {msg}");
    std::process::exit(1);
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
    Some(Embree {
        include_dir,
        lib_dir: lib_dir_of(prefix),
        how: format!("{how} ({})", prefix.display()),
        from_cache: false,
    })
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

/// The Embree 4 install, `Ok(None)` when there is none, `Err` when `EMBREE_DIR` is wrong.
fn find_embree() -> Result<Option<Embree>, String> {
    // 1. EMBREE_DIR: an explicit choice must be right, or we say so.
    if let Some(dir) = env::var_os("EMBREE_DIR") {
        let dir = PathBuf::from(dir);
        return match from_prefix(&dir, "EMBREE_DIR") {
            Some(e) => Ok(Some(e)),
            None => Err(format!(
                "EMBREE_DIR={} has no include/embree4/rtcore.h; point it at an Embree 4.3+ install prefix",
                dir.display()
            )),
        };
    }
    // 2. pkg-config.
    if let Ok(lib) = pkg_config::Config::new().atleast_version("4.0").cargo_metadata(false).probe("embree4") {
        if let Some(inc) = lib.include_paths.iter().find(|p| has_headers(p)) {
            return Ok(Some(Embree {
                include_dir: inc.clone(),
                lib_dir: lib.link_paths.first().cloned(),
                how: format!("pkg-config embree4 {}", lib.version),
                from_cache: false,
            }));
        }
    }
    // 3. System prefixes.
    for prefix in ["/usr", "/usr/local", "/opt/homebrew", "/opt/local"] {
        if let Some(e) = from_prefix(Path::new(prefix), "system") {
            return Ok(Some(e));
        }
    }
    // 4. The cache of scripts/setup-embree.sh (a clone of the repository fills it).
    let cached = cache_dir().and_then(|c| from_prefix(&c.join("embree-4.4.0"), "the setup-embree.sh cache"));
    Ok(cached.map(|e| Embree { from_cache: true, ..e }))
}

/// The one line for a machine without Embree 4: where we looked and how to get it.
const NOT_FOUND: &str = "Embree 4.3+ not found (looked at EMBREE_DIR, pkg-config embree4, /usr, /usr/local, \
     /opt/homebrew, /opt/local); install it (Debian 13 / Ubuntu 24.04: apt install libembree-dev; \
     Arch: pacman -S embree; macOS: brew install embree) or set EMBREE_DIR to an Embree 4.3+ prefix \
     with include/embree4 and lib";

/// `RTC_VERSION_MAJOR`, `_MINOR` and `_PATCH` of the headers in `include_dir`.
fn header_version(include_dir: &Path) -> Result<(u32, u32, u32), String> {
    let config = include_dir.join("embree4").join("rtcore_config.h");
    let text =
        std::fs::read_to_string(&config).map_err(|e| format!("cannot read {}: {e}", config.display()))?;
    let define = |name: &str| -> Result<u32, String> {
        text.lines()
            .find_map(|l| l.trim().strip_prefix("#define ")?.trim().strip_prefix(name)?.trim().parse().ok())
            .ok_or_else(|| format!("{} has no `#define {name} N`", config.display()))
    };
    Ok((define("RTC_VERSION_MAJOR")?, define("RTC_VERSION_MINOR")?, define("RTC_VERSION_PATCH")?))
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

fn out_dir() -> PathBuf {
    PathBuf::from(env::var_os("OUT_DIR").unwrap_or_else(|| fail("cargo did not set OUT_DIR")))
}

/// Link (or copy) Embree's runtime files from `lib_dir` into `OUT_DIR/lib`: `libembree4*` and the
/// TBB it was built with (`libtbb*`), shared objects only. Returns that directory.
fn runtime_into_out_dir(lib_dir: &Path) -> std::io::Result<PathBuf> {
    let out = out_dir().join("lib");
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

/// Link Embree, with an rpath so target/*/phongrt and the test binaries run without LD_LIBRARY_PATH.
fn link(embree: &Embree) {
    if let Some(lib_dir) = &embree.lib_dir {
        // For dependents: the rpath applies to this package's own targets only, but Cargo puts
        // every link-search path that lies inside OUT_DIR on the dynamic-library path of `cargo
        // run` and `cargo test` (the Cargo book, build scripts, `rustc-link-search`), so an Embree
        // the system loader cannot find is linked into OUT_DIR/lib (symlinks, or copies where
        // links fail) and searched there first.
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
}

/// bindgen on the installed `rtcore.h`: only the rtc API, enums as newtypes (no UB on unknown
/// values), flags as bitfields, with layout checks. `Err` when libclang cannot be loaded or parses
/// nothing.
fn generate(include_dir: &Path) -> Result<String, String> {
    let rtcore = include_dir.join("embree4").join("rtcore.h");
    let builder = bindgen::Builder::default()
        .header(rtcore.to_string_lossy())
        .clang_arg(format!("-I{}", include_dir.display()))
        .allowlist_function("rtc.*")
        .allowlist_type("RTC.*")
        .allowlist_var("RTC.*")
        .default_enum_style(bindgen::EnumVariation::NewType { is_bitfield: false, is_global: false })
        .bitfield_enum("RTC.*Flags")
        .derive_default(true)
        .derive_debug(true)
        .layout_tests(true)
        .generate_comments(false)
        .parse_callbacks(Box::new(bindgen::CargoCallbacks::new()));
    // bindgen panics when it cannot load libclang: that is an Err here, not a backtrace.
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(move || builder.generate())) {
        Ok(Ok(b)) => Ok(b.to_string()),
        Ok(Err(e)) => Err(format!("bindgen failed on {}: {e}", rtcore.display())),
        Err(_) => Err("bindgen could not load libclang (set LIBCLANG_PATH)".to_string()),
    }
}

/// `Err` naming the first layout that differs between the committed bindings and `installed`.
fn check_layout(bundled: &str, installed: &str, headers: &Path) -> Result<(), String> {
    let (want, have) = (layout_of(bundled), layout_of(installed));
    let differs = want.iter().find(|(k, v)| have.get(*k) != Some(*v));
    match differs {
        None => Ok(()),
        Some((what, n)) => Err(format!(
            "the bundled Embree 4.3 bindings ({BUNDLED}) do not match the headers in {}: {what} is {} there, \
             {n} bundled; build without feature bundled-bindings (and without DOCS_RS) to generate them",
            headers.display(),
            have.get(what).map_or("absent".to_string(), |v| v.to_string()),
        )),
    }
}

/// The bindings to compile: the installed headers' (bindgen), or the committed ones, checked
/// against the installed headers where there are any.
fn bindings(embree: Option<&Embree>, bundled: bool) -> String {
    let committed = || {
        let path = Path::new(BUNDLED);
        println!("cargo:rerun-if-changed={BUNDLED}");
        std::fs::read_to_string(path).unwrap_or_else(|e| fail(&format!("cannot read {BUNDLED}: {e}")))
    };
    match (embree, bundled) {
        (None, _) => committed(),
        (Some(e), false) => generate(&e.include_dir).unwrap_or_else(|msg| fail(&msg)),
        (Some(e), true) => {
            let text = committed();
            // No libclang (an offline machine with the feature on): the committed layout checks
            // still hold the bindings to the target; there is nothing installed to compare with.
            if let Ok(installed) = generate(&e.include_dir) {
                check_layout(&text, &installed, &e.include_dir).unwrap_or_else(|msg| fail(&msg));
            }
            text
        }
    }
}

fn main() {
    for var in [
        "EMBREE_DIR",
        "PKG_CONFIG_PATH",
        "PHONGRT_CACHE",
        "XDG_CACHE_HOME",
        "HOME",
        "LIBCLANG_PATH",
        "DOCS_RS",
    ] {
        println!("cargo:rerun-if-env-changed={var}");
    }
    println!("cargo:rerun-if-changed=build.rs");
    let docs_rs = env::var_os("DOCS_RS").is_some();
    let bundled = docs_rs || env::var_os("CARGO_FEATURE_BUNDLED_BINDINGS").is_some();

    let embree = find_embree().unwrap_or_else(|msg| fail(&msg));
    match &embree {
        // docs.rs: the committed bindings and nothing linked. The rlib serves `cargo doc` and
        // `cargo check`, also of a crate that depends on phongrt there; a program that links it
        // fails at link time, for want of Embree's symbols.
        None if docs_rs => println!(
            "cargo:warning=phongrt: DOCS_RS is set and no Embree 4.3+ was found: committed \
             bindings, nothing linked (documentation and checks only)"
        ),
        None => fail(NOT_FOUND),
        Some(e) => {
            let (major, minor, patch) = header_version(&e.include_dir).unwrap_or_else(|msg| fail(&msg));
            if (major, minor) < MIN_VERSION {
                fail(&format!(
                    "Embree {major}.{minor}.{patch} found at {}, phongrt needs Embree 4.3 or newer \
                     (set EMBREE_DIR to a 4.3+ prefix)",
                    e.how
                ));
            }
            for h in ["rtcore.h", "rtcore_config.h"] {
                println!("cargo:rerun-if-changed={}", e.include_dir.join("embree4").join(h).display());
            }
            if e.from_cache {
                println!(
                    "cargo:warning=phongrt: using Embree (headers {major}.{minor}.{patch}) from {}",
                    e.how
                );
            }
            link(e);
        }
    }
    let text = bindings(embree.as_ref(), bundled);
    let out = out_dir().join("embree4.rs");
    std::fs::write(&out, text).unwrap_or_else(|e| fail(&format!("cannot write {}: {e}", out.display())));
    println!("cargo:rustc-env=PHONGRT_BINDINGS_RS={}", out.display());
}
