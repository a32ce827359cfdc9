//! Link libphongrt.so with a SONAME and an rpath: `$ORIGIN` (an install that ships Embree beside
//! it, see scripts/install.sh) and the Embree 4 that phongrt's build script found (passed on as
//! `DEP_EMBREE4_LIB` by its `links = "embree4"`), so C programs need no `LD_LIBRARY_PATH`.
fn main() {
    println!("cargo:rerun-if-env-changed=DEP_EMBREE4_LIB");
    if std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("linux") {
        let major = std::env::var("CARGO_PKG_VERSION_MAJOR").unwrap_or_else(|_| "0".into());
        println!("cargo:rustc-cdylib-link-arg=-Wl,-soname,libphongrt.so.{major}");
        println!("cargo:rustc-cdylib-link-arg=-Wl,-rpath,$ORIGIN");
    }
    if let Ok(lib) = std::env::var("DEP_EMBREE4_LIB") {
        if std::env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("windows") {
            println!("cargo:rustc-cdylib-link-arg=-Wl,-rpath,{lib}");
        }
    }
}
