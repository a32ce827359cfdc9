//! phongrt's C API as a shared and a static library (`libphongrt.so`, `libphongrt.a`) for
//! `include/phongrt.h`. The functions are the `phongrt` crate's `capi` feature
//! (`phongrt::embree::capi`): they live beside the Embree layer whose internals they use, and
//! this crate only links them into C libraries.
pub use phongrt_rs::embree::capi::*;
