//! Scenes, triangle geometry, instances, and ray queries (single rays and 4/8/16 packets).

use std::any::Any;
use std::marker::PhantomData;
use std::sync::Arc;

use glam::{Mat4, Vec3};

use super::device::{Device, EmbreeError, MAX_INSTANCE_LEVEL_COUNT};
use super::panic::{self, PanicRecord};
use crate::sys;

/// A ray with its valid interval `(tnear, tfar)`; `mask` is tested against geometry masks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// The origin.
    pub org: Vec3,
    /// The direction (any non-zero length; `t` is in its units).
    pub dir: Vec3,
    /// The start of the valid interval.
    pub tnear: f32,
    /// The end of the valid interval.
    pub tfar: f32,
    /// Tested against each geometry's mask: a geometry is hit only if `mask & its mask != 0`.
    pub mask: u32,
    /// The time, for motion blur (Embree's `time`).
    pub time: f32,
}

impl Ray {
    /// A ray over `(0, inf)` that sees every geometry (mask -1: Embree's default geometry mask is 1).
    pub fn new(org: Vec3, dir: Vec3) -> Self {
        Ray { org, dir, tnear: 0.0, tfar: f32::INFINITY, mask: u32::MAX, time: 0.0 }
    }

    /// The same ray over `(tnear, tfar)`.
    pub fn with_range(mut self, tnear: f32, tfar: f32) -> Self {
        self.tnear = tnear;
        self.tfar = tfar;
        self
    }

    /// The point at parameter `t`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.org + t * self.dir
    }

    pub(crate) fn to_sys(self) -> sys::RTCRay {
        sys::RTCRay {
            org_x: self.org.x,
            org_y: self.org.y,
            org_z: self.org.z,
            tnear: self.tnear,
            dir_x: self.dir.x,
            dir_y: self.dir.y,
            dir_z: self.dir.z,
            time: self.time,
            tfar: self.tfar,
            mask: self.mask,
            id: 0,
            flags: 0,
        }
    }
}

/// The nearest hit of a ray, as Embree reports it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// The ray parameter of the hit.
    pub t: f32,
    /// Unnormalised geometric normal (for Phong geometry: the true surface normal).
    pub ng: Vec3,
    /// The barycentric of the primitive's second vertex.
    pub u: f32,
    /// The barycentric of the primitive's third vertex.
    pub v: f32,
    /// The primitive's index in its geometry.
    pub prim_id: u32,
    /// The geometry's ID in the scene that holds it.
    pub geom_id: u32,
    /// Instance IDs from the outermost level; `u32::MAX` where unused.
    pub inst_id: [u32; MAX_INSTANCE_LEVEL_COUNT],
}

/// A raw `RTCRayHit` for `ray` with no hit yet (geomID invalid), for callers of the raw API.
pub fn new_rayhit(ray: Ray) -> sys::RTCRayHit {
    sys::RTCRayHit {
        ray: ray.to_sys(),
        hit: sys::RTCHit {
            geomID: sys::RTC_INVALID_GEOMETRY_ID,
            primID: sys::RTC_INVALID_GEOMETRY_ID,
            instID: [sys::RTC_INVALID_GEOMETRY_ID; MAX_INSTANCE_LEVEL_COUNT],
            instPrimID: [sys::RTC_INVALID_GEOMETRY_ID; MAX_INSTANCE_LEVEL_COUNT],
            ..Default::default()
        },
    }
}

pub(crate) fn hit_of(rh: &sys::RTCRayHit) -> Option<Hit> {
    (rh.hit.geomID != sys::RTC_INVALID_GEOMETRY_ID).then(|| Hit {
        t: rh.ray.tfar,
        ng: Vec3::new(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z),
        u: rh.hit.u,
        v: rh.hit.v,
        prim_id: rh.hit.primID,
        geom_id: rh.hit.geomID,
        inst_id: rh.hit.instID,
    })
}

/// A ray query context (`RTCRayQueryContext`) that can only hold what `rtcInitRayQueryContext`
/// puts there, an empty instance stack, and what Embree itself pushes during a query. Filter
/// functions see it as the `context` of their arguments.
#[derive(Debug)]
#[repr(transparent)]
pub struct QueryContext(sys::RTCRayQueryContext);

impl QueryContext {
    /// A context with an empty instance stack (`rtcInitRayQueryContext` is an inline function
    /// of the header, so it is rewritten here).
    pub fn new() -> Self {
        QueryContext(sys::RTCRayQueryContext {
            instID: [sys::RTC_INVALID_GEOMETRY_ID; MAX_INSTANCE_LEVEL_COUNT],
            instPrimID: [sys::RTC_INVALID_GEOMETRY_ID; MAX_INSTANCE_LEVEL_COUNT],
        })
    }

    /// The raw context (read only).
    pub fn as_raw(&self) -> &sys::RTCRayQueryContext {
        &self.0
    }
}

impl Default for QueryContext {
    fn default() -> Self {
        Self::new()
    }
}

macro_rules! query_args {
    ($(#[$doc:meta])* $name:ident, $raw:ident, $callback:ident) => {
        $(#[$doc])*
        ///
        /// Everything Embree dereferences in it is valid by construction: the context is borrowed
        /// for `'a`, and a filter can only be set through an `unsafe` method whose caller vouches
        /// for it. The feature mask stays `RTC_FEATURE_FLAG_ALL` and the user-geometry callback
        /// in the arguments stays NULL.
        pub struct $name<'a> {
            raw: sys::$raw,
            _context: PhantomData<&'a mut QueryContext>,
        }

        impl<'a> $name<'a> {
            /// Embree's defaults (as the header's inline initialiser sets them): incoherent
            /// rays, all features, no context, no filter.
            pub fn new() -> Self {
                $name {
                    raw: sys::$raw {
                        flags: sys::RTCRayQueryFlags::RTC_RAY_QUERY_FLAG_INCOHERENT,
                        feature_mask: sys::RTCFeatureFlags::RTC_FEATURE_FLAG_ALL,
                        context: std::ptr::null_mut(),
                        filter: None,
                        $callback: None,
                    },
                    _context: PhantomData,
                }
            }

            /// The query flags (coherent or incoherent rays, whether to invoke the argument
            /// filter).
            pub fn flags(mut self, flags: sys::RTCRayQueryFlags) -> Self {
                self.raw.flags = flags;
                self
            }

            /// The query context Embree passes to filters, borrowed for the query.
            pub fn context(mut self, context: &'a mut QueryContext) -> Self {
                self.raw.context = &mut context.0;
                self
            }

            /// A filter function for candidate hits, invoked when the flags include
            /// `RTC_RAY_QUERY_FLAG_INVOKE_ARGUMENT_FILTER` (or a geometry enables argument
            /// filters).
            ///
            /// # Safety
            /// Embree calls `filter` with `RTCFilterFunctionNArguments` describing `N` lanes
            /// (`valid` has `N` ints, `ray`/`hit` are an `RTCRayN`/`RTCHitN` of width `N`,
            /// `context` is this query's context); it must access nothing beyond those, may
            /// only clear `valid` lanes and update the hit as Embree's filter contract allows
            /// (rtcSetGeometryIntersectFilterFunction docs), and must not unwind.
            pub unsafe fn filter(
                mut self,
                filter: unsafe extern "C" fn(args: *const sys::RTCFilterFunctionNArguments),
            ) -> Self {
                self.raw.filter = Some(filter);
                self
            }

            /// The raw arguments (read only).
            pub fn as_raw(&self) -> &sys::$raw {
                &self.raw
            }
        }

        impl Default for $name<'_> {
            fn default() -> Self {
                Self::new()
            }
        }
    };
}

query_args!(
    /// Arguments of an intersect query (`RTCIntersectArguments`).
    IntersectArgs,
    RTCIntersectArguments,
    intersect
);
query_args!(
    /// Arguments of an occlusion query (`RTCOccludedArguments`).
    OccludedArgs,
    RTCOccludedArguments,
    occluded
);

struct SceneHandle {
    raw: sys::RTCScene,
    device: Device,
    /// Data that Embree geometry points into (user-geometry data, instanced child scenes):
    /// dropped only after the scene is released.
    keep_alive: Vec<Box<dyn Any + Send + Sync>>,
    /// The panic record of each user geometry (geomID, record), read by `commit`.
    panics: Vec<(u32, Arc<PanicRecord>)>,
}

// SAFETY: Embree's docs (Introduction): "performing ray queries in a scene is thread-safe".
// Only a `CommittedScene` is shared (`Sync`), and it offers ray queries alone (its bounds and
// flags are read once, at commit); changes go through a `Scene`, which is not `Sync` and is
// changed through `&mut`, so exclusively.
unsafe impl Send for SceneHandle {}
// SAFETY: see Send.
unsafe impl Sync for SceneHandle {}

impl Drop for SceneHandle {
    fn drop(&mut self) {
        // SAFETY: `raw` came from rtcNewScene; this releases our only reference. Geometry data
        // in `keep_alive` is dropped after this (field order), so Embree never sees it freed.
        unsafe { sys::rtcReleaseScene(self.raw) };
    }
}

/// An Embree scene being built: attach geometry, then [`Scene::commit`] it into a
/// [`CommittedScene`], which alone traces rays. A query cannot meet a scene in the wrong
/// state: the builder has no query methods, the committed scene no change methods.
///
/// ```compile_fail
/// # use phongrt::embree::{Device, Ray, Scene};
/// # use glam::Vec3;
/// let scene = Scene::new(&Device::new().unwrap()).unwrap();
/// scene.intersect1(Ray::new(Vec3::ZERO, Vec3::Z)); // a builder cannot be traced: commit it
/// ```
pub struct Scene {
    inner: SceneHandle,
    /// Not `Sync`: `&Scene` calls (raw flags) must not run on two threads at once.
    _not_sync: PhantomData<std::cell::Cell<()>>,
}

/// A committed Embree scene: ray queries (single rays and 4/8/16 packets) from any number of
/// threads at once, as Embree allows. To change it, take the builder back with
/// [`CommittedScene::edit`].
pub struct CommittedScene {
    inner: Arc<SceneHandle>,
    bounds: (Vec3, Vec3),
    robust: bool,
}

/// Options for attaching geometry of any kind: [`Scene::attach_triangles`],
/// [`Scene::attach_user`] and [`Scene::attach_phong`].
#[derive(Clone, Copy, Debug)]
pub struct GeometryOptions {
    /// Geometry mask: a ray sees this geometry only if `ray.mask & mask != 0`. The default is
    /// all bits (Embree's own default is 1), so every [`Ray`] sees it.
    pub mask: u32,
}

impl Default for GeometryOptions {
    fn default() -> Self {
        GeometryOptions { mask: u32::MAX }
    }
}

/// One reference to an Embree buffer, released on drop: on every error path too.
pub(crate) struct OwnedBuffer(sys::RTCBuffer);

impl OwnedBuffer {
    pub(crate) fn raw(&self) -> sys::RTCBuffer {
        self.0
    }
}

impl Drop for OwnedBuffer {
    fn drop(&mut self) {
        // SAFETY: we hold one reference to a live buffer (from rtcNewBuffer); a geometry the
        // buffer is bound to keeps its own (rtcSetGeometryBuffer docs).
        unsafe { sys::rtcReleaseBuffer(self.0) }
    }
}

/// One reference to an Embree geometry, released on drop: on every error path too.
pub(crate) struct OwnedGeometry(sys::RTCGeometry);

impl OwnedGeometry {
    /// Take ownership of one reference to `geom`, just made on `device`; a null handle reports
    /// the device's error, or else names `what` could not be made.
    pub(crate) fn new(
        device: &Device,
        geom: sys::RTCGeometry,
        what: &'static str,
    ) -> Result<Self, EmbreeError> {
        if geom.is_null() {
            device.check()?;
            return Err(EmbreeError::Null(what));
        }
        Ok(OwnedGeometry(geom))
    }
    pub(crate) fn raw(&self) -> sys::RTCGeometry {
        self.0
    }
}

impl Drop for OwnedGeometry {
    fn drop(&mut self) {
        // SAFETY: we hold one reference to a live geometry (from rtcNewGeometry); a scene it is
        // attached to keeps its own (rtcAttachGeometry docs).
        unsafe { sys::rtcReleaseGeometry(self.0) }
    }
}

/// A new Embree buffer holding a copy of `items`, with the 16 bytes of padding Embree asks for
/// after the last element (the last float3 must be readable with a 16-byte load).
fn new_buffer_from<T: Copy>(device: &Device, items: &[T]) -> Result<OwnedBuffer, EmbreeError> {
    let bytes = std::mem::size_of_val(items);
    // SAFETY: the device is live (held by `device`); rtcNewBuffer allocates `bytes + 16` bytes
    // that rtcGetBufferData exposes for writing (rtcNewBuffer docs); we copy exactly `bytes`
    // from a valid slice of plain `Copy` data (Vec3 and [u32; 3] are 12 bytes without padding).
    // rtcNewBuffer returns null exactly when it fails: the device's error is read only then.
    // The device's lock is held for the call that accesses it.
    unsafe {
        let buf = {
            let _device = device.lock();
            sys::rtcNewBuffer(device.raw(), bytes + 16)
        };
        if buf.is_null() {
            device.check()?;
            return Err(EmbreeError::Null("buffer"));
        }
        let buf = OwnedBuffer(buf);
        let ptr = sys::rtcGetBufferData(buf.raw()) as *mut u8;
        std::ptr::copy_nonoverlapping(items.as_ptr() as *const u8, ptr, bytes);
        Ok(buf)
    }
}

/// A new geometry of `kind` on `device`, owned.
fn new_geometry(
    device: &Device,
    kind: sys::RTCGeometryType,
    what: &'static str,
) -> Result<OwnedGeometry, EmbreeError> {
    let geom = {
        let _device = device.lock();
        // SAFETY: the device is live (held by `device`) and locked for the call; rtcNewGeometry
        // returns a geometry with one reference, or null with the error recorded on the device.
        unsafe { sys::rtcNewGeometry(device.raw(), kind) }
    };
    OwnedGeometry::new(device, geom, what)
}

impl Scene {
    /// An empty scene on `device`.
    pub fn new(device: &Device) -> Result<Self, EmbreeError> {
        let raw = {
            let _device = device.lock();
            // SAFETY: the device is live (held by `device`, and by the scene handle from now
            // on) and locked for the call.
            unsafe { sys::rtcNewScene(device.raw()) }
        };
        // rtcNewScene returns null exactly when it fails: the device's error is read only then
        // (an error left pending by the caller's raw calls is theirs); a scene is owned at once.
        if raw.is_null() {
            device.check()?;
            return Err(EmbreeError::Null("scene"));
        }
        let inner = SceneHandle { raw, device: device.clone(), keep_alive: Vec::new(), panics: Vec::new() };
        Ok(Scene { inner, _not_sync: PhantomData })
    }

    /// Embree's robust mode (`RTC_SCENE_FLAG_ROBUST`): acceleration structures that allow robust
    /// traversal and no optimisations that reduce arithmetic accuracy, against rays slipping
    /// between neighbouring primitives. Takes effect at the next commit.
    pub fn set_robust(&mut self, robust: bool) -> Result<(), EmbreeError> {
        let raw = self.inner.raw;
        let bit = sys::RTCSceneFlags::RTC_SCENE_FLAG_ROBUST.0;
        // SAFETY: `raw` is a live scene (held by `self`); rtcGetSceneFlags/rtcSetSceneFlags only
        // read and set its flags, recording any error on the device, which `call` reads.
        self.device().call(|| unsafe {
            let flags = sys::rtcGetSceneFlags(raw).0;
            sys::rtcSetSceneFlags(raw, sys::RTCSceneFlags(if robust { flags | bit } else { flags & !bit }));
        })
    }

    /// Whether robust mode is set (see [`Scene::set_robust`]).
    pub fn robust(&self) -> bool {
        // SAFETY: `self.inner.raw` is a live scene (held by `self`); rtcGetSceneFlags only reads.
        let flags = unsafe { sys::rtcGetSceneFlags(self.inner.raw) };
        flags.0 & sys::RTCSceneFlags::RTC_SCENE_FLAG_ROBUST.0 != 0
    }

    /// The device this scene lives on.
    pub fn device(&self) -> &Device {
        &self.inner.device
    }

    /// The raw handle, for callers mixing this scene with their own Embree code. It stays valid
    /// while `self` lives.
    pub fn raw(&self) -> sys::RTCScene {
        self.inner.raw
    }

    /// Record the panic record of user geometry `geom_id`, for `commit` to report.
    pub(crate) fn watch_panics(&mut self, geom_id: u32, record: Arc<PanicRecord>) {
        self.inner.panics.push((geom_id, record));
    }

    /// Keep `data` alive as long as the scene (for geometry that points into it).
    pub(crate) fn keep_alive(&mut self, data: Box<dyn Any + Send + Sync>) {
        self.inner.keep_alive.push(data);
    }

    /// Attach a committed geometry (our reference to it is released either way); returns its
    /// geomID. On `Err` the geometry is not attached.
    pub(crate) fn attach_raw(&mut self, geom: OwnedGeometry) -> Result<u32, EmbreeError> {
        let raw = self.inner.raw;
        // SAFETY: `geom` is a live, committed geometry of this scene's device; attaching
        // retains it, and `geom` then drops our own reference (rtcAttachGeometry docs).
        let id = unsafe { sys::rtcAttachGeometry(raw, geom.raw()) };
        drop(geom);
        // rtcAttachGeometry returns RTC_INVALID_GEOMETRY_ID exactly when it fails (rtcore's API
        // wrappers): the device's error is read only then, so a geometry in the scene is never
        // reported as a failure.
        if id == sys::RTC_INVALID_GEOMETRY_ID {
            self.device().check()?;
            return Err(EmbreeError::Null("geometry ID"));
        }
        Ok(id)
    }

    /// Attach a triangle mesh (copied into Embree-owned buffers); returns its geomID.
    pub fn attach_triangles(
        &mut self,
        positions: &[Vec3],
        indices: &[[u32; 3]],
        options: GeometryOptions,
    ) -> Result<u32, EmbreeError> {
        if let Some(&index) = indices.iter().flatten().find(|&&i| i as usize >= positions.len()) {
            return Err(EmbreeError::IndexOutOfRange { what: "triangle", index, vertices: positions.len() });
        }
        let device = self.device().clone();
        let vbuf = new_buffer_from(&device, positions)?;
        let ibuf = new_buffer_from(&device, indices)?;
        let geom =
            new_geometry(&device, sys::RTCGeometryType::RTC_GEOMETRY_TYPE_TRIANGLE, "triangle geometry")?;
        // SAFETY: the geometry and both buffers are live; the buffers hold the stated item
        // counts (12-byte items) and are bound before the geometry is committed; the geometry
        // retains them, so our references drop at the end of this function (rtcSetGeometryBuffer docs).
        // These calls return nothing: `call` reads the errors they record.
        device.call(|| unsafe {
            sys::rtcSetGeometryBuffer(
                geom.raw(),
                sys::RTCBufferType::RTC_BUFFER_TYPE_VERTEX,
                0,
                sys::RTCFormat::RTC_FORMAT_FLOAT3,
                vbuf.raw(),
                0,
                12,
                positions.len(),
            );
            sys::rtcSetGeometryBuffer(
                geom.raw(),
                sys::RTCBufferType::RTC_BUFFER_TYPE_INDEX,
                0,
                sys::RTCFormat::RTC_FORMAT_UINT3,
                ibuf.raw(),
                0,
                12,
                indices.len(),
            );
            sys::rtcSetGeometryMask(geom.raw(), options.mask);
            sys::rtcCommitGeometry(geom.raw());
        })?;
        self.attach_raw(geom)
    }

    /// Attach a Catmull–Clark subdivision surface over a triangle control mesh (Embree's own
    /// smooth surface, what an Embree user would reach for instead of Phong tessellation), with
    /// `tessellation_rate` segments per edge. Returns the geomID.
    pub fn attach_subdivision(
        &mut self,
        positions: &[Vec3],
        indices: &[[u32; 3]],
        tessellation_rate: f32,
    ) -> Result<u32, EmbreeError> {
        if let Some(&index) = indices.iter().flatten().find(|&&i| i as usize >= positions.len()) {
            return Err(EmbreeError::IndexOutOfRange {
                what: "subdivision",
                index,
                vertices: positions.len(),
            });
        }
        if !(tessellation_rate.is_finite() && tessellation_rate >= 1.0) {
            return Err(EmbreeError::TessellationRate(tessellation_rate));
        }
        let device = self.device().clone();
        let vbuf = new_buffer_from(&device, positions)?;
        let ibuf = new_buffer_from(&device, indices)?;
        let fbuf = new_buffer_from(&device, &vec![3u32; indices.len()])?;
        let geom = new_geometry(
            &device,
            sys::RTCGeometryType::RTC_GEOMETRY_TYPE_SUBDIVISION,
            "subdivision geometry",
        )?;
        // SAFETY: as in `attach_triangles`; the face buffer holds one u32 (3) per face and the
        // index buffer one u32 per corner, as RTC_GEOMETRY_TYPE_SUBDIVISION requires
        // (rtcNewGeometry docs, "Subdivision geometry").
        device.call(|| unsafe {
            sys::rtcSetGeometryBuffer(
                geom.raw(),
                sys::RTCBufferType::RTC_BUFFER_TYPE_VERTEX,
                0,
                sys::RTCFormat::RTC_FORMAT_FLOAT3,
                vbuf.raw(),
                0,
                12,
                positions.len(),
            );
            sys::rtcSetGeometryBuffer(
                geom.raw(),
                sys::RTCBufferType::RTC_BUFFER_TYPE_INDEX,
                0,
                sys::RTCFormat::RTC_FORMAT_UINT,
                ibuf.raw(),
                0,
                4,
                indices.len() * 3,
            );
            sys::rtcSetGeometryBuffer(
                geom.raw(),
                sys::RTCBufferType::RTC_BUFFER_TYPE_FACE,
                0,
                sys::RTCFormat::RTC_FORMAT_UINT,
                fbuf.raw(),
                0,
                4,
                indices.len(),
            );
            sys::rtcSetGeometryTessellationRate(geom.raw(), tessellation_rate);
            sys::rtcCommitGeometry(geom.raw());
        })?;
        self.attach_raw(geom)
    }

    /// Attach an instance of the committed scene `child` with `transform` (object to world);
    /// returns its geomID (the instID hits inside it report). The instance shares `child`:
    /// while it lives, [`CommittedScene::edit`] on `child` is refused.
    pub fn attach_instance(
        &mut self,
        child: &CommittedScene,
        transform: Mat4,
        mask: u32,
    ) -> Result<u32, EmbreeError> {
        let device = self.device().clone();
        let cols = transform.to_cols_array();
        let geom =
            new_geometry(&device, sys::RTCGeometryType::RTC_GEOMETRY_TYPE_INSTANCE, "instance geometry")?;
        // SAFETY: `child.raw()` is a live committed scene; we keep a reference to its handle
        // below so it outlives this scene. The transform is 16 floats in column-major order,
        // matching RTC_FORMAT_FLOAT4X4_COLUMN_MAJOR, and Embree copies it (rtcSetGeometryTransform docs).
        device.call(|| unsafe {
            sys::rtcSetGeometryInstancedScene(geom.raw(), child.raw());
            sys::rtcSetGeometryTransform(
                geom.raw(),
                0,
                sys::RTCFormat::RTC_FORMAT_FLOAT4X4_COLUMN_MAJOR,
                cols.as_ptr() as *const std::ffi::c_void,
            );
            sys::rtcSetGeometryMask(geom.raw(), mask);
            sys::rtcCommitGeometry(geom.raw());
        })?;
        self.keep_alive(Box::new(child.inner.clone()));
        self.attach_raw(geom)
    }

    /// Build the BVH: the committed scene traces rays.
    ///
    /// A panic in a user geometry's bounds callback (run on Embree's build threads) comes back
    /// as [`EmbreeError::CallbackPanicked`], as does one recorded under the caller's own
    /// Embree queries since the last commit; the scene is then dropped.
    pub fn commit(self) -> Result<CommittedScene, EmbreeError> {
        let raw = self.inner.raw;
        // SAFETY: the scene is live, and no other thread can be tracing it: a `Scene` is owned
        // here and no other scene instances it (instancing takes a `CommittedScene`), and
        // rtcCommitScene must not run concurrently with queries on the scene (rtcCommitScene
        // docs). It returns nothing: `call` reads the error it records.
        self.device().call(|| unsafe { sys::rtcCommitScene(raw) })?;
        // Any panic recorded since the last commit: this commit's bounds callbacks, or ray
        // callbacks under the caller's own Embree calls (taking it clears it).
        for (geom_id, record) in &self.inner.panics {
            if let Some((callback, message)) = record.take() {
                return Err(EmbreeError::CallbackPanicked { geom_id: *geom_id, callback, message });
            }
        }
        let mut b = sys::RTCBounds::default();
        // SAFETY: the scene is live and committed, used by this thread alone; `b` is a
        // properly aligned RTCBounds to write into (rtcGetSceneBounds docs).
        unsafe { sys::rtcGetSceneBounds(raw, &mut b) };
        let bounds = (Vec3::new(b.lower_x, b.lower_y, b.lower_z), Vec3::new(b.upper_x, b.upper_y, b.upper_z));
        let robust = self.robust();
        Ok(CommittedScene { inner: Arc::new(self.inner), bounds, robust })
    }
}

impl std::fmt::Debug for Scene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Scene").field("raw", &self.inner.raw).finish_non_exhaustive()
    }
}

impl std::fmt::Debug for CommittedScene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CommittedScene")
            .field("raw", &self.inner.raw)
            .field("bounds", &self.bounds)
            .field("robust", &self.robust)
            .finish_non_exhaustive()
    }
}

impl CommittedScene {
    /// The builder back, to change the scene and commit it again; refused (the committed
    /// scene given back, still traced) while another scene instances it.
    pub fn edit(self) -> Result<Scene, CommittedScene> {
        match Arc::try_unwrap(self.inner) {
            Ok(inner) => Ok(Scene { inner, _not_sync: PhantomData }),
            Err(inner) => Err(CommittedScene { inner, ..self }),
        }
    }

    /// The device this scene lives on.
    pub fn device(&self) -> &Device {
        &self.inner.device
    }

    /// The raw handle, for callers tracing this scene with their own Embree code. It stays
    /// valid while `self` lives.
    pub fn raw(&self) -> sys::RTCScene {
        self.inner.raw
    }

    /// Whether it was committed in robust mode (see [`Scene::set_robust`]).
    pub fn robust(&self) -> bool {
        self.robust
    }

    /// Bounds of the scene (lower, upper corners), as Embree reported them at commit.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }

    /// The nearest hit along `ray` in `(tnear, tfar)`.
    ///
    /// A panic in a user geometry's callback during the query is resumed here.
    pub fn intersect1(&self, ray: Ray) -> Option<Hit> {
        let mut rh = new_rayhit(ray);
        self.intersect1_raw(&mut rh, None);
        hit_of(&rh)
    }

    /// Whether anything blocks `ray` in `(tnear, tfar)`.
    ///
    /// A panic in a user geometry's callback during the query is resumed here.
    pub fn occluded1(&self, ray: Ray) -> bool {
        let mut r = ray.to_sys();
        self.occluded1_raw(&mut r, None);
        r.tfar == f32::NEG_INFINITY
    }

    /// `rtcIntersect1` on a raw ray-hit with optional arguments (context, filter, flags).
    /// A panic in a user geometry's callback during the query is resumed here.
    pub fn intersect1_raw(&self, rayhit: &mut sys::RTCRayHit, args: Option<&mut IntersectArgs<'_>>) {
        let args = args.map_or(std::ptr::null_mut(), |a| &mut a.raw as *mut _);
        // SAFETY: the scene is live and committed, and nothing can change it; `rayhit`
        // is an exclusive RTCRayHit (plain data); `args` is NULL (Embree's defaults) or
        // arguments whose context is borrowed for the call and whose filter the caller of
        // `IntersectArgs::filter` vouched for (rtcIntersect1 docs).
        panic::query(|| unsafe { sys::rtcIntersect1(self.inner.raw, rayhit, args) });
    }

    /// `rtcOccluded1` on a raw ray with optional arguments; occluded gives `tfar = -inf`.
    /// A panic in a user geometry's callback during the query is resumed here.
    pub fn occluded1_raw(&self, ray: &mut sys::RTCRay, args: Option<&mut OccludedArgs<'_>>) {
        let args = args.map_or(std::ptr::null_mut(), |a| &mut a.raw as *mut _);
        // SAFETY: as in `intersect1_raw`, with `ray` an exclusive RTCRay (rtcOccluded1 docs).
        panic::query(|| unsafe { sys::rtcOccluded1(self.inner.raw, ray, args) });
    }
}

/// A packet valid mask with the alignment Embree requires (16, 32, 64 bytes for 4, 8, 16
/// lanes; 64 covers all).
#[repr(C, align(64))]
struct AlignedValid<const N: usize>([i32; N]);

/// The valid mask Embree reads: -1 for lanes traced, 0 for the others (any other value in
/// `valid` counts as 0).
fn aligned_valid<const N: usize>(valid: &[i32; N]) -> AlignedValid<N> {
    AlignedValid(valid.map(|v| if v == -1 { -1 } else { 0 }))
}

macro_rules! packet_queries {
    ($isect:ident, $occl:ident, $n:literal, $rayhit:ty, $ray:ty, $fi:ident, $fo:ident) => {
        impl CommittedScene {
            #[doc = concat!("`rtcIntersect", stringify!($n), "`: lanes with `valid[i] == -1` are traced.")]
            /// A callback panic is resumed here.
            #[inline]
            pub fn $isect(
                &self,
                valid: &[i32; $n],
                rayhit: &mut $rayhit,
                args: Option<&mut IntersectArgs<'_>>,
            ) {
                let args = args.map_or(std::ptr::null_mut(), |a| &mut a.raw as *mut _);
                let valid = aligned_valid(valid);
                // SAFETY: the scene is live and committed; `valid` has N lanes of -1 or 0 and
                // the alignment rtcIntersectN requires (N*4 bytes); `rayhit` is the bindgen type
                // with Embree's layout and alignment (repr(align) in the bindings), exclusive
                // plain data; `args` as in `intersect1_raw` (rtcIntersect4/8/16 docs).
                panic::query(|| unsafe { sys::$fi(valid.0.as_ptr(), self.inner.raw, rayhit, args) });
            }
            #[doc = concat!("`rtcOccluded", stringify!($n), "`: occluded lanes get `tfar = -inf`.")]
            /// A callback panic is resumed here.
            #[inline]
            pub fn $occl(&self, valid: &[i32; $n], ray: &mut $ray, args: Option<&mut OccludedArgs<'_>>) {
                let args = args.map_or(std::ptr::null_mut(), |a| &mut a.raw as *mut _);
                let valid = aligned_valid(valid);
                // SAFETY: as for the intersect variant (rtcOccluded4/8/16 docs).
                panic::query(|| unsafe { sys::$fo(valid.0.as_ptr(), self.inner.raw, ray, args) });
            }
        }
    };
}
packet_queries!(intersect4, occluded4, 4, sys::RTCRayHit4, sys::RTCRay4, rtcIntersect4, rtcOccluded4);
packet_queries!(intersect8, occluded8, 8, sys::RTCRayHit8, sys::RTCRay8, rtcIntersect8, rtcOccluded8);
packet_queries!(intersect16, occluded16, 16, sys::RTCRayHit16, sys::RTCRay16, rtcIntersect16, rtcOccluded16);

/// The number of rays in a packet of [`CommittedScene::intersect8_rays`] / [`CommittedScene::occluded8_rays`].
pub const PACKET8: usize = 8;

/// An 8-ray packet in Embree's SOA layout, from `rays` (AOS); lane `i` is traced when bit `i`
/// of `active` is set, and its hit starts out empty.
pub(crate) fn rayhit8(rays: &[Ray; PACKET8]) -> sys::RTCRayHit8 {
    let mut rh = sys::RTCRayHit8::default();
    for (k, r) in rays.iter().enumerate() {
        rh.ray.org_x[k] = r.org.x;
        rh.ray.org_y[k] = r.org.y;
        rh.ray.org_z[k] = r.org.z;
        rh.ray.tnear[k] = r.tnear;
        rh.ray.dir_x[k] = r.dir.x;
        rh.ray.dir_y[k] = r.dir.y;
        rh.ray.dir_z[k] = r.dir.z;
        rh.ray.time[k] = r.time;
        rh.ray.tfar[k] = r.tfar;
        rh.ray.mask[k] = r.mask;
        rh.hit.geomID[k] = sys::RTC_INVALID_GEOMETRY_ID;
        rh.hit.primID[k] = sys::RTC_INVALID_GEOMETRY_ID;
        for l in 0..MAX_INSTANCE_LEVEL_COUNT {
            rh.hit.instID[l][k] = sys::RTC_INVALID_GEOMETRY_ID;
            rh.hit.instPrimID[l][k] = sys::RTC_INVALID_GEOMETRY_ID;
        }
    }
    rh
}

/// The valid mask of an 8-ray query: -1 where bit `i` of `active` is set.
pub(crate) fn valid8(active: u8) -> [i32; PACKET8] {
    std::array::from_fn(|k| if active & (1 << k) != 0 { -1 } else { 0 })
}

/// The query flags for coherent or incoherent rays.
pub(crate) fn query_flags(coherent: bool) -> sys::RTCRayQueryFlags {
    if coherent {
        sys::RTCRayQueryFlags::RTC_RAY_QUERY_FLAG_COHERENT
    } else {
        sys::RTCRayQueryFlags::RTC_RAY_QUERY_FLAG_INCOHERENT
    }
}

impl CommittedScene {
    /// The nearest hit of each of 8 rays traced as one packet (`rtcIntersect8`): lane `i` is
    /// traced when bit `i` of `active` is set, the others answer `None`; `coherent` tells
    /// Embree the rays are coherent (`RTC_RAY_QUERY_FLAG_COHERENT`: primary rays from a pixel
    /// block, hard shadows towards one light). Each lane answers as [`CommittedScene::intersect1`] on
    /// its ray. A callback panic is resumed here.
    pub fn intersect8_rays(
        &self,
        rays: &[Ray; PACKET8],
        active: u8,
        coherent: bool,
    ) -> [Option<Hit>; PACKET8] {
        let mut rh = rayhit8(rays);
        let mut args = IntersectArgs::new().flags(query_flags(coherent));
        if active == 0 {
            return [None; PACKET8];
        }
        self.intersect8(&valid8(active), &mut rh, Some(&mut args));
        std::array::from_fn(|k| {
            (active & (1 << k) != 0 && rh.hit.geomID[k] != sys::RTC_INVALID_GEOMETRY_ID).then(|| Hit {
                t: rh.ray.tfar[k],
                ng: Vec3::new(rh.hit.Ng_x[k], rh.hit.Ng_y[k], rh.hit.Ng_z[k]),
                u: rh.hit.u[k],
                v: rh.hit.v[k],
                prim_id: rh.hit.primID[k],
                geom_id: rh.hit.geomID[k],
                inst_id: std::array::from_fn(|l| rh.hit.instID[l][k]),
            })
        })
    }

    /// Whether anything blocks each of 8 rays traced as one packet (`rtcOccluded8`): bit `i` of
    /// the answer is set when lane `i` is active (bit `i` of `active`) and blocked, as
    /// [`CommittedScene::occluded1`] on its ray. `coherent` as in
    /// [`CommittedScene::intersect8_rays`]. A callback panic is resumed here.
    pub fn occluded8_rays(&self, rays: &[Ray; PACKET8], active: u8, coherent: bool) -> u8 {
        let mut ray = rayhit8(rays).ray;
        let mut args = OccludedArgs::new().flags(query_flags(coherent));
        if active == 0 {
            return 0;
        }
        self.occluded8(&valid8(active), &mut ray, Some(&mut args));
        (0..PACKET8)
            .fold(0, |m, k| m | (((active & (1 << k) != 0 && ray.tfar[k] == f32::NEG_INFINITY) as u8) << k))
    }
}
