//! Link the `phongrt` binary, examples and benches with an rpath to the Embree 4 that phongrt's
//! build script found (passed on as `DEP_EMBREE4_LIB` by its `links = "embree4"`), so they run
//! without `LD_LIBRARY_PATH`.
fn main() {
    println!("cargo:rerun-if-env-changed=DEP_EMBREE4_LIB");
    if let Ok(lib) = std::env::var("DEP_EMBREE4_LIB") {
        if std::env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("windows") {
            println!("cargo:rustc-link-arg=-Wl,-rpath,{lib}");
        }
    }
    // tests/common's compile_c builds C programs against that same Embree, as the phongrt package's
    // tests do with the variables its build script sets.
    println!("cargo:rerun-if-env-changed=DEP_EMBREE4_INCLUDE");
    let (lib, include) = (std::env::var("DEP_EMBREE4_LIB"), std::env::var("DEP_EMBREE4_INCLUDE"));
    println!("cargo:rustc-env=PHONGRT_EMBREE_LIB_DIR={}", lib.unwrap_or_default());
    println!("cargo:rustc-env=PHONGRT_EMBREE_INCLUDE_DIR={}", include.unwrap_or_default());
}
