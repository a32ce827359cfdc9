//! Phong meshes ([`crate::phong::mesh`]) as Embree user geometry: one user primitive per patch
//! (or, opted into, per cluster of up to 8 neighbouring patches: [`crate::phong::cluster`]),
//! bounds and intersection by [`crate::phong`], everything else (BVH, traversal, instancing,
//! filters, masks, packets) by Embree. Hits report the triangle's index as primID either way.

use std::sync::Arc;

use glam::Vec3;

use super::device::EmbreeError;
use super::scene::Scene;
use super::user_geometry::{new_user_geometry, PrimHit, UserData, UserGeometryOptions, UserPrimitives};
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

    #[inline]
    fn intersect(&self, item: u32, org: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> Option<PrimHit> {
        self.intersect_primitive(item, org, dir, tnear, tfar, |_| {})
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
        options: UserGeometryOptions,
    ) -> Result<u32, EmbreeError> {
        self.attach_user(mesh.into(), options)
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
    options: UserGeometryOptions,
) -> Result<RawPhongGeometry, EmbreeError> {
    if scene.is_null() {
        return Err(EmbreeError::Null("scene"));
    }
    let data = Box::new(UserData::new(mesh.into()));
    // SAFETY: the caller guarantees `scene` is live; rtcGetSceneDevice returns its device with
    // a new reference, released below (rtcGetSceneDevice docs). The data box lives in the
    // returned handle, which the caller keeps alive while the scene is traced (this function's
    // contract), so the geometry's user pointer stays valid.
    unsafe {
        let device = sys::rtcGetSceneDevice(scene);
        let geom = new_user_geometry(device, &*data as *const UserData<Arc<PhongMesh>>, options);
        if geom.is_null() {
            sys::rtcReleaseDevice(device);
            return Err(EmbreeError::Null("user geometry"));
        }
        let geom_id = sys::rtcAttachGeometry(scene, geom);
        sys::rtcReleaseGeometry(geom);
        let err = sys::rtcGetDeviceError(device);
        sys::rtcReleaseDevice(device);
        if err != sys::RTCError::RTC_ERROR_NONE {
            return Err(EmbreeError::from_code(err, "attaching a Phong mesh".into()));
        }
        Ok(RawPhongGeometry { data, geom_id })
    }
}
