//! Raw bindings to Embree 4 (`rtcore.h`): every `rtc*` function, `RTC*` type and constant, as
//! Embree declares them.
//!
//! By default `build.rs` generates them with bindgen from the installed headers. With `DOCS_RS` set
//! or the feature `bundled-bindings`, it uses the committed `src/sys/embree-4.3.rs` instead
//! (bindgen's output for the Embree 4.3.3 headers on 64-bit Linux, the oldest Embree supported),
//! after checking that every struct's size, alignment and field offsets equal those of the
//! installed headers, where there are any. So `RTC_VERSION*` here name the headers the bindings came
//! from, not necessarily the runtime: ask the device (`rtcGetDeviceProperty`) for that.
//!
//! For code that drives its own `RTCScene` beside phongrt's safe layer, and for
//! [`crate::embree::attach_phong_raw`]. Calling them is `unsafe`; Embree's documentation is the
//! contract. Enums are newtypes (an unknown value from a newer Embree is not undefined
//! behaviour) and flag enums are bitfields.
// Generated code: bindgen writes its own unsafe blocks (bitfield accessors), without SAFETY comments.
#![allow(non_upper_case_globals, non_camel_case_types, non_snake_case, dead_code, clippy::all)]
#![allow(clippy::undocumented_unsafe_blocks, unsafe_op_in_unsafe_fn)]
// Generated code: the items are documented by Embree's headers and manual, not here.
#![allow(missing_docs)]

include!(concat!(env!("OUT_DIR"), "/embree4.rs"));

/// `RTC_INVALID_GEOMETRY_ID` (a cast macro that bindgen cannot translate).
pub const RTC_INVALID_GEOMETRY_ID: u32 = u32::MAX;
