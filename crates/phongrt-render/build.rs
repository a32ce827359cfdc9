//! Link this crate's tests with an rpath to the Embree 4 that phongrt's
//! build script found (passed on as `DEP_EMBREE4_LIB` by its `links = "embree4"`), so they run
//! without `LD_LIBRARY_PATH`.
fn main() {
    println!("cargo:rerun-if-env-changed=DEP_EMBREE4_LIB");
    if let Ok(lib) = std::env::var("DEP_EMBREE4_LIB") {
        if std::env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("windows") {
            println!("cargo:rustc-link-arg=-Wl,-rpath,{lib}");
        }
    }
}
