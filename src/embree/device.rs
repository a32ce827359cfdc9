//! The Embree device: creation from a config string, errors as Rust values, properties.

use std::ffi::{c_char, c_void, CStr, CString};
use std::sync::atomic::{AtomicI64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::ThreadId;

use crate::sys;

/// An Embree error code (`RTCError`), as a matchable value.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ErrorCode {
    /// `RTC_ERROR_UNKNOWN`.
    Unknown,
    /// `RTC_ERROR_INVALID_ARGUMENT`.
    InvalidArgument,
    /// `RTC_ERROR_INVALID_OPERATION`.
    InvalidOperation,
    /// `RTC_ERROR_OUT_OF_MEMORY`.
    OutOfMemory,
    /// `RTC_ERROR_UNSUPPORTED_CPU`.
    UnsupportedCpu,
    /// `RTC_ERROR_CANCELLED` (a memory monitor or progress callback said stop).
    Cancelled,
    /// `RTC_ERROR_LEVEL_ZERO_RAYTRACING_SUPPORT_MISSING`.
    LevelZeroRaytracingSupportMissing,
    /// A code these bindings do not know (a newer Embree), with its value.
    Other(u32),
}

impl ErrorCode {
    /// The code of an `RTCError`; `None` for `RTC_ERROR_NONE`.
    pub fn from_raw(code: sys::RTCError) -> Option<Self> {
        use sys::RTCError as E;
        Some(match code {
            E::RTC_ERROR_NONE => return None,
            E::RTC_ERROR_UNKNOWN => ErrorCode::Unknown,
            E::RTC_ERROR_INVALID_ARGUMENT => ErrorCode::InvalidArgument,
            E::RTC_ERROR_INVALID_OPERATION => ErrorCode::InvalidOperation,
            E::RTC_ERROR_OUT_OF_MEMORY => ErrorCode::OutOfMemory,
            E::RTC_ERROR_UNSUPPORTED_CPU => ErrorCode::UnsupportedCpu,
            E::RTC_ERROR_CANCELLED => ErrorCode::Cancelled,
            E::RTC_ERROR_LEVEL_ZERO_RAYTRACING_SUPPORT_MISSING => {
                ErrorCode::LevelZeroRaytracingSupportMissing
            }
            other => ErrorCode::Other(other.0),
        })
    }
}

impl std::fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ErrorCode::Unknown => f.write_str("unknown error"),
            ErrorCode::InvalidArgument => f.write_str("invalid argument"),
            ErrorCode::InvalidOperation => f.write_str("invalid operation"),
            ErrorCode::OutOfMemory => f.write_str("out of memory"),
            ErrorCode::UnsupportedCpu => f.write_str("unsupported CPU"),
            ErrorCode::Cancelled => f.write_str("cancelled"),
            ErrorCode::LevelZeroRaytracingSupportMissing => {
                f.write_str("Level Zero ray tracing support missing")
            }
            ErrorCode::Other(c) => write!(f, "error code {c}"),
        }
    }
}

/// An error reported by Embree (through the device's error callback), or a refusal by this
/// wrapper of something Embree would silently misuse. One type for the whole Embree layer.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EmbreeError {
    /// Embree reported an error code, with its message (empty if Embree gave none).
    #[error("Embree: {code}{}{message}", if message.is_empty() { "" } else { ": " })]
    Device {
        /// The `RTCError` code.
        code: ErrorCode,
        /// Embree's message, or what we were doing.
        message: String,
    },
    /// The device config string contains a NUL byte.
    #[error("Embree device config {0:?} contains a NUL byte")]
    Config(String),
    /// A null handle came back without an error code.
    #[error("Embree returned no {0} and reported no error")]
    Null(&'static str),
    /// A vertex index of a mesh is not below the vertex count.
    #[error("{what} index {index} out of range for {vertices} vertices")]
    IndexOutOfRange {
        /// The kind of mesh ("triangle", "subdivision").
        what: &'static str,
        /// The offending index.
        index: u32,
        /// The number of vertices.
        vertices: usize,
    },
    /// A subdivision tessellation rate that is not a finite number >= 1.
    #[error("tessellation rate {0} is not >= 1")]
    TessellationRate(f32),
    /// A user-geometry callback panicked where no Rust caller could resume the panic: the
    /// bounds callback on one of Embree's build threads (reported by the commit that ran it,
    /// which leaves the scene uncommitted), or a query callback under the caller's own
    /// `rtcIntersect*` (reported by the next commit).
    #[error("user geometry {geom_id}: the {callback} callback panicked: {message}")]
    CallbackPanicked {
        /// The geomID of the geometry whose callback panicked.
        geom_id: u32,
        /// Which callback: "bounds", "intersect" or "occluded".
        callback: &'static str,
        /// The panic message (if it was a string).
        message: String,
    },
}

impl EmbreeError {
    /// The Embree error code, if this error came from Embree.
    pub fn code(&self) -> Option<ErrorCode> {
        match self {
            EmbreeError::Device { code, .. } => Some(*code),
            _ => None,
        }
    }

    /// An error from a raw Embree code (`Unknown` for `RTC_ERROR_NONE`, which callers only pass
    /// when a call failed anyway).
    pub(crate) fn from_code(code: sys::RTCError, message: String) -> Self {
        EmbreeError::Device { code: ErrorCode::from_raw(code).unwrap_or(ErrorCode::Unknown), message }
    }
}

/// An error code and Embree's message for it.
type Pending = (sys::RTCError, String);

/// What the error and memory-monitor callbacks write into; owned by the device handle, so
/// it outlives every callback Embree can make on that device.
#[derive(Default)]
struct DeviceState {
    /// Per thread, the first error message since that thread's last [`Device::check`]: Embree
    /// keeps its error codes per thread too ("Each thread has its own error code per device",
    /// rtcGetDeviceError docs), and calls the error function on the thread whose call failed.
    last_error: Mutex<Vec<(ThreadId, Pending)>>,
    /// Bytes Embree reports as allocated (memory monitor callback).
    bytes: AtomicI64,
    peak: AtomicI64,
}

struct DeviceHandle {
    raw: sys::RTCDevice,
    state: Box<DeviceState>,
    /// Held for every call that accesses the device object (see the `Sync` impl).
    calls: Mutex<()>,
}

// SAFETY: Embree's docs (Introduction): "In general, API calls that access the same object are
// not thread-safe, unless specified otherwise. However, attaching geometries to the same scene
// and performing ray queries in a scene is thread-safe." So every call this crate makes on the
// device object (rtcNewScene, rtcNewGeometry, rtcNewBuffer, rtcGetDeviceProperty,
// rtcGetDeviceError) holds `calls` ([`Device::lock`]): two threads never access the device at
// once. Creation and release (rtcSetDevice*Function, rtcReleaseDevice) happen while one handle
// owns it. Scene-level calls access their scene, which `&mut Scene` makes exclusive, and ray
// queries run on committed scenes, the case Embree allows. The state is Sync itself.
unsafe impl Send for DeviceHandle {}
// SAFETY: see Send.
unsafe impl Sync for DeviceHandle {}

impl Drop for DeviceHandle {
    fn drop(&mut self) {
        // SAFETY: `raw` came from rtcNewDevice and this is the only release of our reference;
        // scenes hold their own `Device` clone, so no scene outlives this call's device use.
        unsafe { sys::rtcReleaseDevice(self.raw) };
    }
}

/// An Embree device. Cheap to clone (shared handle), `Send` and `Sync`: every call that
/// accesses the device object takes the device's lock, as Embree requires ("API calls that
/// access the same object are not thread-safe, unless specified otherwise").
#[derive(Clone)]
pub struct Device {
    inner: Arc<DeviceHandle>,
}

unsafe extern "C" fn error_callback(user: *mut c_void, code: sys::RTCError, msg: *const c_char) {
    // No panic may unwind into Embree.
    let _ = std::panic::catch_unwind(|| {
        let message = if msg.is_null() {
            String::new()
        } else {
            // SAFETY: Embree passes a NUL-terminated message valid for the duration of the call
            // (rtcSetDeviceErrorFunction docs).
            unsafe { CStr::from_ptr(msg) }.to_string_lossy().into_owned()
        };
        // SAFETY: `user` is the `DeviceState` we registered; it lives in a Box owned by the
        // device handle, which outlives the device's callbacks (released in Drop after use).
        let state = unsafe { &*(user as *const DeviceState) };
        // Embree calls this on the thread whose call failed: keep that thread's first error.
        let id = std::thread::current().id();
        let mut slot = state.last_error.lock().unwrap_or_else(|e| e.into_inner());
        if !slot.iter().any(|(t, _)| *t == id) {
            slot.push((id, (code, message)));
        }
    });
}

unsafe extern "C" fn memory_callback(user: *mut c_void, bytes: isize, _post: bool) -> bool {
    let _ = std::panic::catch_unwind(|| {
        // SAFETY: as in `error_callback`, `user` is our Box<DeviceState>, alive while the device is.
        let state = unsafe { &*(user as *const DeviceState) };
        let now = state.bytes.fetch_add(bytes as i64, Ordering::Relaxed) + bytes as i64;
        state.peak.fetch_max(now, Ordering::Relaxed);
    });
    true
}

impl Device {
    /// A device with Embree's default configuration.
    pub fn new() -> Result<Self, EmbreeError> {
        Self::with_config("")
    }

    /// A device from an Embree config string (e.g. `"threads=1,verbose=0"`).
    pub fn with_config(config: &str) -> Result<Self, EmbreeError> {
        let c = CString::new(config).map_err(|_| EmbreeError::Config(config.to_string()))?;
        // SAFETY: `c` is a valid NUL-terminated string for the duration of the call; rtcNewDevice
        // copies what it needs (rtcNewDevice docs).
        let raw = unsafe { sys::rtcNewDevice(c.as_ptr()) };
        if raw.is_null() {
            // SAFETY: rtcGetDeviceError accepts NULL and then returns the thread-local error of
            // the failed device creation (rtcGetDeviceError docs).
            let code = unsafe { sys::rtcGetDeviceError(std::ptr::null_mut()) };
            return Err(EmbreeError::from_code(code, format!("cannot create device with config {config:?}")));
        }
        let state = Box::<DeviceState>::default();
        let user = &*state as *const DeviceState as *mut c_void;
        // SAFETY: `raw` is a live device; `user` points into a Box that lives in the handle as
        // long as the device (dropped after rtcReleaseDevice); the callbacks catch all panics.
        unsafe {
            sys::rtcSetDeviceErrorFunction(raw, Some(error_callback), user);
            sys::rtcSetDeviceMemoryMonitorFunction(raw, Some(memory_callback), user);
        }
        Ok(Device { inner: Arc::new(DeviceHandle { raw, state, calls: Mutex::new(()) }) })
    }

    pub(crate) fn raw(&self) -> sys::RTCDevice {
        self.inner.raw
    }

    /// The lock every call that accesses the device object holds (Embree: "API calls that
    /// access the same object are not thread-safe, unless specified otherwise").
    pub(crate) fn lock(&self) -> MutexGuard<'_, ()> {
        self.inner.calls.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// This thread's pending error (Embree's code and the message its error function gave),
    /// clearing it; other threads' errors stay theirs.
    fn take_error(&self) -> Option<Pending> {
        let code = {
            let _device = self.lock();
            // SAFETY: the device is live for as long as `self` is; the lock serialises the
            // access; the code read is this thread's (rtcGetDeviceError docs).
            unsafe { sys::rtcGetDeviceError(self.raw()) }
        };
        let id = std::thread::current().id();
        let mut slot = self.inner.state.last_error.lock().unwrap_or_else(|e| e.into_inner());
        let stored = slot.iter().position(|(t, _)| *t == id).map(|k| slot.swap_remove(k).1);
        match (code, stored) {
            (sys::RTCError::RTC_ERROR_NONE, None) => None,
            (code, None) => Some((code, String::new())),
            (_, Some(stored)) => Some(stored),
        }
    }

    /// Turn an Embree error pending on this thread (if any) into `Err`. Errors of calls made
    /// on other threads are theirs: they are not reported here. An error the caller's own raw
    /// calls left pending when a phongrt call ran on this device is kept for this method (Embree's
    /// own `rtcGetDeviceError` no longer returns it then).
    pub fn check(&self) -> Result<(), EmbreeError> {
        match self.take_error() {
            None => Ok(()),
            Some((code, message)) => Err(EmbreeError::from_code(code, message)),
        }
    }

    /// Run `f`, Embree calls whose return values cannot say they failed (functions returning
    /// `void`), and blame on it exactly the error they recorded on this thread: an error left
    /// pending before by the caller's own raw calls is not reported, and stays pending for
    /// the caller's own [`Device::check`].
    pub(crate) fn call<R>(&self, f: impl FnOnce() -> R) -> Result<R, EmbreeError> {
        let earlier = self.take_error();
        let r = f();
        let error = self.take_error();
        if let Some(earlier) = earlier {
            let id = std::thread::current().id();
            self.inner.state.last_error.lock().unwrap_or_else(|e| e.into_inner()).push((id, earlier));
        }
        match error {
            None => Ok(r),
            Some((code, message)) => Err(EmbreeError::from_code(code, message)),
        }
    }

    fn property(&self, p: sys::RTCDeviceProperty) -> isize {
        let _device = self.lock();
        // SAFETY: the device is live; the lock serialises the access; reading a property has
        // no other precondition (rtcGetDeviceProperty docs).
        unsafe { sys::rtcGetDeviceProperty(self.raw(), p) }
    }

    /// The runtime's version as (major, minor, patch).
    pub fn version(&self) -> (u32, u32, u32) {
        use sys::RTCDeviceProperty as P;
        (
            self.property(P::RTC_DEVICE_PROPERTY_VERSION_MAJOR) as u32,
            self.property(P::RTC_DEVICE_PROPERTY_VERSION_MINOR) as u32,
            self.property(P::RTC_DEVICE_PROPERTY_VERSION_PATCH) as u32,
        )
    }

    /// The widest native ray packet (4, 8 or 16), which tells the ISA Embree selected:
    /// 4 = SSE, 8 = AVX/AVX2, 16 = AVX-512.
    pub fn native_packet_width(&self) -> u32 {
        use sys::RTCDeviceProperty as P;
        if self.property(P::RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED) != 0 {
            16
        } else if self.property(P::RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED) != 0 {
            8
        } else {
            4
        }
    }

    /// A short description of the ISA in use, from the native packet width and the CPU.
    pub fn isa(&self) -> String {
        match self.native_packet_width() {
            16 => "AVX-512".into(),
            8 => {
                #[cfg(target_arch = "x86_64")]
                if std::arch::is_x86_feature_detected!("avx2") {
                    return "AVX2".into();
                }
                "AVX".into()
            }
            _ => {
                if cfg!(target_arch = "aarch64") {
                    "NEON".into()
                } else {
                    "SSE4.2".into()
                }
            }
        }
    }

    /// Whether the library was built with user-geometry and filter support.
    pub fn supports_user_geometry(&self) -> bool {
        use sys::RTCDeviceProperty as P;
        self.property(P::RTC_DEVICE_PROPERTY_USER_GEOMETRY_SUPPORTED) != 0
            && self.property(P::RTC_DEVICE_PROPERTY_FILTER_FUNCTION_SUPPORTED) != 0
    }

    /// Bytes Embree currently holds (memory monitor), and the peak since creation.
    pub fn memory_bytes(&self) -> (i64, i64) {
        let s = &self.inner.state;
        (s.bytes.load(Ordering::Relaxed), s.peak.load(Ordering::Relaxed))
    }
}

/// The instance level count of the headers we were built against (the hit layout depends on it).
pub const MAX_INSTANCE_LEVEL_COUNT: usize = sys::RTC_MAX_INSTANCE_LEVEL_COUNT as usize;

/// The Embree version of the headers we were built against.
pub fn header_version() -> &'static str {
    // The constant is a NUL-terminated ASCII string.
    std::str::from_utf8(&sys::RTC_VERSION_STRING[..sys::RTC_VERSION_STRING.len() - 1]).unwrap_or("?")
}

/// Set flush-to-zero (FTZ) and denormals-are-zero (DAZ) in the calling thread's MXCSR, as
/// Embree's "CPU Performance Recommendations" ask: "It is strongly recommended to have the
/// `Flush to Zero` and `Denormals are Zero` mode of the MXCSR control and status register
/// enabled for each thread before calling the `rtcIntersect`-type and `rtcOccluded`-type
/// functions" (denormals can slow traversal down severely). A no-op off x86_64.
///
/// Prefer [`thread_pool_builder`], which sets the mode on every thread of a rayon pool.
///
/// # Safety
/// Rust's documentation of `_mm_setcsr` calls setting these flags immediate undefined
/// behaviour: the compiler assumes IEEE subnormal arithmetic, so an operation it folds at
/// compile time and the same operation at run time can disagree once the thread flushes
/// subnormals to zero. The caller must make sure that nothing run on this thread afterwards
/// depends for its soundness on subnormal results: no float result may decide an unchecked
/// memory access or another `unsafe` precondition. What can change is a float value near zero,
/// which is what the caller opts into.
pub unsafe fn set_flush_denormals() {
    #[cfg(target_arch = "x86_64")]
    {
        #[allow(deprecated)]
        use std::arch::x86_64::{_mm_getcsr, _mm_setcsr};
        const FTZ: u32 = 1 << 15;
        const DAZ: u32 = 1 << 6;
        // SAFETY: MXCSR exists on every x86_64 CPU (SSE2 is baseline) and only this thread's
        // copy is written; the compiler's assumption of IEEE subnormals is this function's
        // contract, passed to the caller.
        #[allow(deprecated)]
        unsafe {
            _mm_setcsr(_mm_getcsr() | FTZ | DAZ)
        };
    }
}

/// A rayon thread pool builder whose threads set flush-to-zero and denormals-are-zero (see
/// [`set_flush_denormals`]) before they run anything: the one way phongrt's renderer, bench and
/// command line run every thread that traces rays in the float mode Embree recommends.
///
/// Closures run on the pool see subnormal inputs and results of `f32`/`f64` SSE arithmetic
/// as zero. The caller may set the number of threads, names and the rest on the builder; a
/// `start_handler` set afterwards replaces the one that sets the mode.
pub fn thread_pool_builder() -> rayon::ThreadPoolBuilder {
    rayon::ThreadPoolBuilder::new().start_handler(|_| {
        // SAFETY: `set_flush_denormals`' contract: the code phongrt runs on these threads (the
        // ray queries, the user-geometry callbacks, the Phong and shading math) uses float
        // results only as values, never to decide an unchecked memory access (slices are read
        // with bounds checks or `get`, float-to-index conversions saturate), so flushed
        // subnormals change values, not soundness. The flag is documented on this builder
        // for the closures callers run on its pool.
        unsafe { set_flush_denormals() }
    })
}
