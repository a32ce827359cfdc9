//! Link libphongrt.so with a SONAME and an rpath, so C programs need no `LD_LIBRARY_PATH`:
//! - `$ORIGIN`: an install that ships Embree beside it (scripts/install.sh);
//! - the Embree 4 that phongrt's build script found (passed on as `DEP_EMBREE4_LIB` by its
//!   `links = "embree4"`), so the build tree's library runs where it was built.
//!
//! `PHONGRT_INSTALL_RPATH=origin-only` (set by scripts/install.sh) leaves out the second: an
//! installed library must not point into the build machine's Embree (a cache in a home
//! directory); it finds Embree beside itself or in the system's library path.
fn main() {
    println!("cargo:rerun-if-env-changed=DEP_EMBREE4_LIB");
    println!("cargo:rerun-if-env-changed=PHONGRT_INSTALL_RPATH");
    let origin_only = match std::env::var("PHONGRT_INSTALL_RPATH") {
        Err(_) => false,
        Ok(v) if v.is_empty() || v == "build-tree" => false,
        Ok(v) if v == "origin-only" => true,
        Ok(v) => {
            panic!("PHONGRT_INSTALL_RPATH={v:?}: expected \"origin-only\" or \"build-tree\" (the default)")
        }
    };
    let unix = std::env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("windows");
    if std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("linux") {
        let major = std::env::var("CARGO_PKG_VERSION_MAJOR").unwrap_or_else(|_| "0".into());
        println!("cargo:rustc-cdylib-link-arg=-Wl,-soname,libphongrt.so.{major}");
        println!("cargo:rustc-cdylib-link-arg=-Wl,-rpath,$ORIGIN");
    }
    if let Ok(lib) = std::env::var("DEP_EMBREE4_LIB") {
        if unix && !origin_only {
            println!("cargo:rustc-cdylib-link-arg=-Wl,-rpath,{lib}");
        }
    }
    // tests/common's compile_c builds C programs against that same Embree, as the phongrt package's
    // tests do with the variables its build script sets.
    println!("cargo:rerun-if-env-changed=DEP_EMBREE4_INCLUDE");
    let (lib, include) = (std::env::var("DEP_EMBREE4_LIB"), std::env::var("DEP_EMBREE4_INCLUDE"));
    println!("cargo:rustc-env=PHONGRT_EMBREE_LIB_DIR={}", lib.unwrap_or_default());
    println!("cargo:rustc-env=PHONGRT_EMBREE_INCLUDE_DIR={}", include.unwrap_or_default());
}
