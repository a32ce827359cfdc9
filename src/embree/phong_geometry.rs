//! Phong meshes ([`crate::phong::mesh`]) as Embree user geometry: one user primitive per patch
//! (or, opted into, per cluster of up to 8 neighbouring patches: [`crate::phong::cluster`]),
//! bounds and intersection by [`crate::phong`], everything else (BVH, traversal, instancing,
//! filters, masks, packets) by Embree. Hits report the triangle's index as primID either way.

use std::sync::Arc;

use glam::Vec3;

use super::device::EmbreeError;
use super::scene::{GeometryOptions, Scene};
use super::user_geometry::{
    new_user_geometry, LaneOrigins, OriginPrim, PacketRays, PrimHit, UserData, UserPrimitives, MAX_PACKET,
};
use crate::phong::intersect::{LaneRays, LANES};
use crate::phong::mesh::PhongMesh;
use crate::sys;

impl UserPrimitives for PhongMesh {
    fn count(&self) -> u32 {
        if self.clusters().is_empty() {
            self.patches().len() as u32
        } else {
            self.clusters().len() as u32
        }
    }

    fn bounds(&self, item: u32) -> Option<(Vec3, Vec3)> {
        if !self.clusters().is_empty() {
            return Some(self.clusters().get(item as usize)?.bounds());
        }
        // A degenerate patch is excluded from the BVH (and counted in `degenerate`).
        self.patches().get(item as usize)?.bounds_f32()
    }

    #[inline(always)]
    fn intersect(&self, item: u32, org: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> Option<PrimHit> {
        self.intersect_primitive(item, org, dir, tnear, tfar, |_| {})
    }

    #[inline(always)]
    fn intersect_from(
        &self,
        item: u32,
        origin: Option<OriginPrim>,
        org: Vec3,
        dir: Vec3,
        tnear: f32,
        tfar: f32,
    ) -> Option<PrimHit> {
        self.intersect_primitive_from(item, origin, org, dir, tnear, tfar, |_| {})
    }

    /// The packet's lanes in blocks of [`LANES`], each block tested together
    /// ([`PhongMesh::intersect_lanes`], which settles a lane's origin patch without a solve where
    /// it can), shadow rays as camera rays. Shadow packets went lane by lane while the lane
    /// kernel cost them more; since its hull stage is a function of its own it costs them less
    /// (sphere-120 1,787 -> 1,739 instructions per shadow ray, the head 4,770 -> 4,091;
    /// scripts/instructions.sh).
    #[allow(clippy::needless_range_loop)] // lane loops index several arrays by the lane
    fn intersect_packet(&self, item: u32, rays: &PacketRays, hits: &mut [Option<PrimHit>; MAX_PACKET]) {
        let n = rays.n.min(MAX_PACKET);
        // Blocks of LANES from lanes 0 and 8: lanes past the packet's width are inactive zeros
        // in `rays` (their answers are dropped).
        for start in (0..n).step_by(LANES) {
            let lanes = start..start + LANES;
            let active: [bool; LANES] = rays.active[lanes.clone()].try_into().unwrap_or([false; LANES]);
            if !active.contains(&true) {
                continue;
            }
            let field = |a: &[f32; MAX_PACKET]| a[lanes.clone()].try_into().unwrap_or([0.0; LANES]);
            let block = LaneRays {
                org: [field(&rays.org[0]), field(&rays.org[1]), field(&rays.org[2])],
                dir: [field(&rays.dir[0]), field(&rays.dir[1]), field(&rays.dir[2])],
                tmin: field(&rays.tnear),
                tmax: field(&rays.tfar),
            };
            let origin = rays.origin[lanes.clone()].try_into().unwrap_or([None; LANES]);
            let found = self.intersect_lanes(item, &block, active, &LaneOrigins::given(origin));
            for i in 0..LANES {
                if active[i] {
                    hits[start + i] = found[i];
                }
            }
        }
    }

    /// The packet's lanes tested together as [`PhongMesh::intersect_lanes`] (as
    /// `intersect_packet` above), straight from the lanes the callback read.
    #[inline(always)]
    fn intersect_packet8(
        &self,
        item: u32,
        rays: &LaneRays,
        active: [bool; LANES],
        origin: &LaneOrigins,
    ) -> [Option<PrimHit>; LANES] {
        self.intersect_lanes(item, rays, active, origin)
    }
}

impl Scene {
    /// Attach a Phong mesh as one user geometry. Returns the geomID.
    ///
    /// The scene shares the mesh: pass an `Arc<PhongMesh>` and keep a clone of the `Arc` for
    /// shading queries ([`PhongMesh::shading_normal`] and the rest), no copy of the patches is
    /// made. A `PhongMesh` passed by value is moved into a new `Arc` the scene alone holds.
    pub fn attach_phong(
        &mut self,
        mesh: impl Into<Arc<PhongMesh>>,
        options: GeometryOptions,
    ) -> Result<u32, EmbreeError> {
        self.attach_shared_phong(mesh.into(), options)
    }

    /// [`Scene::attach_phong`] past the conversion: not generic, so that the Phong callbacks
    /// are compiled once, in this crate. Reached from the generic `attach_phong` directly, they
    /// were compiled again in each crate that called it, their code then depending on how that
    /// crate was split into codegen units (8-ray packets 415.4 or 420.3 instructions a sphere
    /// primary ray, by changes elsewhere in the calling crate).
    #[inline(never)]
    fn attach_shared_phong(
        &mut self,
        mesh: Arc<PhongMesh>,
        options: GeometryOptions,
    ) -> Result<u32, EmbreeError> {
        self.attach_user(mesh, options)
    }
}

/// A Phong mesh attached to a raw `RTCScene` the caller manages: keep this handle alive until
/// every scene holding the geometry is released, then drop it.
pub struct RawPhongGeometry {
    data: Box<UserData<Arc<PhongMesh>>>,
    geom_id: u32,
}

impl RawPhongGeometry {
    /// The mesh (for shading helpers).
    pub fn mesh(&self) -> &PhongMesh {
        &self.data.prims
    }

    /// The mesh as the shared handle the geometry holds (cloning it copies no patch).
    pub fn shared_mesh(&self) -> Arc<PhongMesh> {
        self.data.prims.clone()
    }

    /// The geomID in the caller's scene.
    pub fn geom_id(&self) -> u32 {
        self.geom_id
    }

    /// How many times a ray callback of this geometry panicked under the caller's own
    /// `rtcIntersect*`/`rtcOccluded*` (there is no Rust caller to resume the panic in: the ray
    /// saw a miss instead), or a bounds callback under the caller's `rtcCommitScene`.
    pub fn callback_panics(&self) -> u64 {
        self.data.recorded_panics()
    }
}

/// Attach `mesh` (a `PhongMesh`, or an `Arc<PhongMesh>` the caller shares) to a raw Embree scene
/// created by the caller's own Embree code.
///
/// # Safety
/// `scene` must be a live `RTCScene`, and the returned handle must outlive every use of the
/// scene (and of any scene instancing it) in ray queries.
pub unsafe fn attach_phong_raw(
    scene: sys::RTCScene,
    mesh: impl Into<Arc<PhongMesh>>,
    options: GeometryOptions,
) -> Result<RawPhongGeometry, EmbreeError> {
    // SAFETY: this function's contract is `attach_shared_phong_raw`'s.
    unsafe { attach_shared_phong_raw(scene, mesh.into(), options) }
}

/// [`attach_phong_raw`] past the conversion: not generic, so that the Phong callbacks are
/// compiled once, in this crate (as [`Scene::attach_phong`]'s).
///
/// # Safety
/// As [`attach_phong_raw`].
#[inline(never)]
unsafe fn attach_shared_phong_raw(
    scene: sys::RTCScene,
    mesh: Arc<PhongMesh>,
    options: GeometryOptions,
) -> Result<RawPhongGeometry, EmbreeError> {
    if scene.is_null() {
        return Err(EmbreeError::Null("scene"));
    }
    let data = Box::new(UserData::new(mesh));
    // SAFETY: the caller guarantees `scene` is live. The data box lives in the returned handle,
    // which the caller keeps alive while the scene is traced (this function's contract); on an
    // error nothing is attached, so dropping the box then is sound.
    let geom_id = unsafe { attach_user_raw(scene, &*data as *const UserData<Arc<PhongMesh>>, options)? };
    Ok(RawPhongGeometry { data, geom_id })
}

/// Attach the user geometry of `data` to a raw scene of the caller's own Embree code: the one
/// raw-attach path, shared by [`attach_phong_raw`] and the C API. Returns the geomID.
///
/// The device's error code is read only when a call's return value says it failed (a null
/// geometry, `RTC_INVALID_GEOMETRY_ID` from the attach): an error left pending by the caller's
/// own earlier calls is theirs, and must not turn a successful attach (the geometry is in the
/// scene, pointing into `data`) into a failure that frees the data under it. On `Err` nothing
/// is attached.
///
/// # Safety
/// `scene` must be a live, non-null `RTCScene`, and `data` must stay valid (not moved, not
/// freed) until every scene holding the geometry (and every scene instancing one) is released.
pub(crate) unsafe fn attach_user_raw<T: UserPrimitives>(
    scene: sys::RTCScene,
    data: *const UserData<T>,
    options: GeometryOptions,
) -> Result<u32, EmbreeError> {
    // SAFETY: `scene` is live (this function's contract); rtcGetSceneDevice returns its device
    // with a new reference, released below (rtcGetSceneDevice docs); `data` outlives the
    // geometry (contract). rtcNewGeometry returns null and rtcAttachGeometry returns
    // RTC_INVALID_GEOMETRY_ID exactly when they fail (rtcore's API wrappers), so the error code
    // read then is theirs.
    unsafe {
        let device = sys::rtcGetSceneDevice(scene);
        let geom = new_user_geometry(device, data, options);
        let result = if geom.is_null() {
            Err(raw_error(device, "user geometry", "creating a user geometry"))
        } else {
            let geom_id = sys::rtcAttachGeometry(scene, geom);
            // The scene holds its own reference when the attach succeeded (rtcAttachGeometry docs).
            sys::rtcReleaseGeometry(geom);
            if geom_id == sys::RTC_INVALID_GEOMETRY_ID {
                Err(raw_error(device, "geometry ID", "attaching a user geometry"))
            } else {
                Ok(geom_id)
            }
        };
        sys::rtcReleaseDevice(device);
        result
    }
}

/// The error of a raw call on `device` whose return value said it failed: the device's code,
/// or [`EmbreeError::Null`] naming `what` came back when Embree recorded none.
///
/// # Safety
/// `device` must be a live `RTCDevice`.
unsafe fn raw_error(device: sys::RTCDevice, what: &'static str, doing: &str) -> EmbreeError {
    // SAFETY: `device` is live (this function's contract); reading its error has no other
    // precondition (rtcGetDeviceError docs).
    let code = unsafe { sys::rtcGetDeviceError(device) };
    if code == sys::RTCError::RTC_ERROR_NONE {
        EmbreeError::Null(what)
    } else {
        EmbreeError::from_code(code, doing.into())
    }
}
