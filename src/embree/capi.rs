//! The C API of `include/phongrt.h`: attach Phong meshes to a C/C++ program's own Embree scene.

use std::cell::RefCell;
use std::ffi::{c_char, c_int, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};

use glam::Vec3;

use super::phong_geometry::attach_user_raw;
use super::scene::GeometryOptions;
use super::user_geometry::UserData;
use crate::phong::mesh::PhongMesh;
use crate::phong::ShadingNormal;
use crate::sys;

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

fn set_error(msg: &str) {
    let c = CString::new(msg.replace('\0', " ")).unwrap_or_default();
    // `try_with` and `try_borrow_mut`: this runs outside `catch_unwind` too, so it must not panic
    // (a thread-local being torn down, a re-entrant call) on its way back to C.
    let _ = LAST_ERROR.try_with(|e| e.try_borrow_mut().map(|mut slot| *slot = c));
}

/// Opaque to C: the mesh data a Phong user geometry points into.
#[allow(non_camel_case_types)]
pub struct phongrt_mesh {
    data: UserData<PhongMesh>,
}

/// # Safety
/// `p` must be non-NULL and point to `n` readable float triples.
unsafe fn read_vec3s(p: *const f32, n: usize) -> Vec<Vec3> {
    // SAFETY: this function's contract (the caller checked for NULL; phongrt.h gives the count).
    let s = unsafe { std::slice::from_raw_parts(p, n * 3) };
    s.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect()
}

/// `phongrt_attach_mesh_ex`'s flag for plain Phong tessellation (no welding, no straight edges).
pub const PHONGRT_MESH_PLAIN: u32 = 1;

/// See `phongrt_attach_mesh` in include/phongrt.h (watertight: welded, creases and borders straight).
///
/// # Safety
/// `scene` must be a live RTCScene; `positions`/`normals` must point to `vertex_count` float
/// triples and `indices` to `triangle_count` uint triples; `mesh_out` must be NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn phongrt_attach_mesh(
    scene: sys::RTCScene,
    positions: *const f32,
    normals: *const f32,
    vertex_count: usize,
    indices: *const u32,
    triangle_count: usize,
    alpha: f32,
    mesh_out: *mut *mut phongrt_mesh,
) -> u32 {
    // SAFETY: the same contract as phongrt_attach_mesh_ex's.
    unsafe {
        attach_mesh(
            "phongrt_attach_mesh",
            scene,
            positions,
            normals,
            vertex_count,
            indices,
            triangle_count,
            alpha,
            0,
            mesh_out,
        )
    }
}

/// See `phongrt_attach_mesh_ex` in include/phongrt.h: as `phongrt_attach_mesh`, with `flags`
/// (`PHONGRT_MESH_PLAIN`, or 0).
///
/// # Safety
/// As `phongrt_attach_mesh`.
#[no_mangle]
pub unsafe extern "C" fn phongrt_attach_mesh_ex(
    scene: sys::RTCScene,
    positions: *const f32,
    normals: *const f32,
    vertex_count: usize,
    indices: *const u32,
    triangle_count: usize,
    alpha: f32,
    flags: u32,
    mesh_out: *mut *mut phongrt_mesh,
) -> u32 {
    // SAFETY: this function's contract.
    unsafe {
        attach_mesh(
            "phongrt_attach_mesh_ex",
            scene,
            positions,
            normals,
            vertex_count,
            indices,
            triangle_count,
            alpha,
            flags,
            mesh_out,
        )
    }
}

/// # Safety
/// As `phongrt_attach_mesh`.
#[allow(clippy::too_many_arguments)]
unsafe fn attach_mesh(
    func: &str,
    scene: sys::RTCScene,
    positions: *const f32,
    normals: *const f32,
    vertex_count: usize,
    indices: *const u32,
    triangle_count: usize,
    alpha: f32,
    flags: u32,
    mesh_out: *mut *mut phongrt_mesh,
) -> u32 {
    let arrays = MeshArrays { positions, normals, vertex_count, indices, triangle_count };
    let r = catch_unwind(AssertUnwindSafe(|| -> Result<u32, String> {
        // SAFETY: this function's contract, which is `attach_checked`'s.
        unsafe { attach_checked(func, scene, &arrays, alpha, flags, mesh_out) }
    }));
    // No panic unwinds into C: a caught one is an error like any other.
    match r {
        Ok(Ok(id)) => {
            set_error("");
            id
        }
        Ok(Err(msg)) => {
            set_error(&msg);
            sys::RTC_INVALID_GEOMETRY_ID
        }
        Err(_) => {
            set_error(&format!("{func}: internal error (panic caught)"));
            sys::RTC_INVALID_GEOMETRY_ID
        }
    }
}

/// The caller's mesh arrays as `phongrt_attach_mesh` receives them (not yet checked).
struct MeshArrays {
    positions: *const f32,
    normals: *const f32,
    vertex_count: usize,
    indices: *const u32,
    triangle_count: usize,
}

impl MeshArrays {
    /// Refuse unknown flags, a NULL scene, a NULL array with a non-zero count (an array may be
    /// NULL when its count is 0, phongrt.h) and counts past what a `uint` index or primID can
    /// reach. Only the pointers' NULL-ness is read (and the scene's, given as `scene_is_null`).
    fn check(&self, func: &str, scene_is_null: bool, flags: u32) -> Result<(), String> {
        if flags & !PHONGRT_MESH_PLAIN != 0 {
            return Err(format!(
                "{func}: unknown flags {flags:#x} (PHONGRT_MESH_PLAIN = 1 is the only flag)"
            ));
        }
        if scene_is_null {
            return Err(format!("{func}: NULL scene"));
        }
        let (vertex_count, triangle_count) = (self.vertex_count, self.triangle_count);
        for (ptr_null, what, count) in [
            (self.positions.is_null(), "positions", vertex_count),
            (self.normals.is_null(), "normals", vertex_count),
            (self.indices.is_null(), "indices", triangle_count),
        ] {
            if ptr_null && count > 0 {
                return Err(format!("{func}: {what} is NULL with a count of {count}"));
            }
        }
        if vertex_count > (u32::MAX as usize) {
            return Err(format!("{func}: {vertex_count} vertices: more than a uint index can reach"));
        }
        if triangle_count > (u32::MAX as usize) {
            return Err(format!("{func}: {triangle_count} triangles: more than a primID can count"));
        }
        Ok(())
    }

    /// Copy the arrays: positions, normals, triangles.
    ///
    /// # Safety
    /// Each array holds its stated count (phongrt.h contract) and is non-NULL when its count is
    /// non-zero ([`MeshArrays::check`] passed).
    unsafe fn copy(&self) -> (Vec<Vec3>, Vec<Vec3>, Vec<[u32; 3]>) {
        let (vertex_count, triangle_count) = (self.vertex_count, self.triangle_count);
        // SAFETY: the arrays hold the stated counts (phongrt.h contract) and are non-NULL when
        // the count is non-zero (this function's contract); we copy them.
        unsafe {
            let p = if vertex_count > 0 { read_vec3s(self.positions, vertex_count) } else { Vec::new() };
            let n = if vertex_count > 0 { read_vec3s(self.normals, vertex_count) } else { Vec::new() };
            let idx: Vec<[u32; 3]> = if triangle_count > 0 {
                let i = std::slice::from_raw_parts(self.indices, triangle_count * 3);
                i.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
            } else {
                Vec::new()
            };
            (p, n, idx)
        }
    }
}

/// Check and copy the caller's arrays, build the Phong mesh and attach it to `scene`; the
/// geometry id, or the one-line error naming `func`.
///
/// # Safety
/// As `phongrt_attach_mesh`: `scene` is NULL or live, the arrays hold their stated counts,
/// `mesh_out` is NULL or writable.
unsafe fn attach_checked(
    func: &str,
    scene: sys::RTCScene,
    arrays: &MeshArrays,
    alpha: f32,
    flags: u32,
    mesh_out: *mut *mut phongrt_mesh,
) -> Result<u32, String> {
    if !mesh_out.is_null() {
        // SAFETY: mesh_out is writable per the contract.
        unsafe { *mesh_out = std::ptr::null_mut() };
    }
    arrays.check(func, scene.is_null(), flags)?;
    // SAFETY: the arrays hold the stated counts (phongrt.h contract) and are non-NULL when the
    // count is non-zero (checked above).
    let (p, n, idx) = unsafe { arrays.copy() };
    // Zero and non-finite normals, bad indices and alpha are refused by the builder, naming
    // the vertex, triangle or value.
    let builder = PhongMesh::builder(&p, &n, &idx).alpha(alpha);
    let builder = if flags & PHONGRT_MESH_PLAIN != 0 { builder.plain() } else { builder };
    let mesh = builder.build().map_err(|e| format!("{func}: {e}"))?;
    let boxed = Box::new(phongrt_mesh { data: UserData::new(mesh) });
    // SAFETY: `scene` is live and non-NULL (contract, checked above); the mesh box is
    // leaked to the caller, who frees it with phongrt_mesh_release only after releasing the
    // scene (phongrt.h), so the geometry's user pointer stays valid while it can be traced;
    // on an error nothing is attached and the box is dropped here.
    let id = unsafe { attach_user_raw(scene, &boxed.data, GeometryOptions::default()) }
        .map_err(|e| format!("{func}: {e}"))?;
    if !mesh_out.is_null() {
        // SAFETY: mesh_out is writable per the contract.
        unsafe { *mesh_out = Box::into_raw(boxed) };
    } else {
        // Without a handle the caller can never free it: keep it for the process lifetime.
        Box::leak(boxed);
    }
    Ok(id)
}

/// See `phongrt_mesh_release` in include/phongrt.h.
///
/// # Safety
/// `mesh` must be NULL or come from `phongrt_attach_mesh`, not yet released, and no scene that
/// holds its geometry may be traced afterwards.
#[no_mangle]
pub unsafe extern "C" fn phongrt_mesh_release(mesh: *mut phongrt_mesh) {
    if !mesh.is_null() {
        // SAFETY: `mesh` came from Box::into_raw in phongrt_attach_mesh (contract).
        let _ = catch_unwind(AssertUnwindSafe(|| drop(unsafe { Box::from_raw(mesh) })));
    }
}

/// Why a shading helper could not answer at `(prim, u, v)` (and `dir`, for the shading normals):
/// the first argument that is wrong, with its value and the reason, for `phongrt_last_error`.
fn explain_refusal(func: &str, mesh: &PhongMesh, prim: u32, u: f32, v: f32, dir: Option<Vec3>) -> String {
    let count = mesh.patches().len();
    match mesh.patches().get(prim as usize) {
        None => format!("{func}: prim_id {prim} is out of range: the mesh has {count} triangles"),
        Some(_) if !(u.is_finite() && v.is_finite()) => format!("{func}: (u, v) = ({u}, {v}) is not finite"),
        Some(p) if p.degenerate() => {
            format!("{func}: triangle {prim} is degenerate (zero area after welding): it has no surface")
        }
        Some(_) => match dir {
            Some(d) if !d.is_finite() || d == Vec3::ZERO => {
                format!("{func}: ray_dir ({}, {}, {}) is zero or not finite", d.x, d.y, d.z)
            }
            Some(_) => format!(
                "{func}: the surface of triangle {prim} has no normal at (u, v) = ({u}, {v}) \
                 (a fold, or (u, v) far outside the triangle)"
            ),
            None => {
                format!("{func}: (u, v) = ({u}, {v}) is too far outside triangle {prim}: the point overflows")
            }
        },
    }
}

/// See `phongrt_shading_normal` in include/phongrt.h.
///
/// # Safety
/// `mesh` must be a live mesh; `ray_dir` must point to 3 floats and `normal_out` to 3 writable floats.
#[no_mangle]
pub unsafe extern "C" fn phongrt_shading_normal(
    mesh: *const phongrt_mesh,
    prim_id: u32,
    u: f32,
    v: f32,
    ray_dir: *const f32,
    normal_out: *mut f32,
) -> c_int {
    // SAFETY: the same contract as phongrt_shading_normal_rule's.
    unsafe { phongrt_shading_normal_rule(mesh, prim_id, u, v, ray_dir, 0, normal_out) }
}

/// See `phongrt_shading_normal_rule` in include/phongrt.h. `rule` is the C enum's value.
///
/// # Safety
/// `mesh` must be a live mesh; `ray_dir` must point to 3 floats and `normal_out` to 3 writable floats.
#[no_mangle]
pub unsafe extern "C" fn phongrt_shading_normal_rule(
    mesh: *const phongrt_mesh,
    prim_id: u32,
    u: f32,
    v: f32,
    ray_dir: *const f32,
    rule: c_int,
    normal_out: *mut f32,
) -> c_int {
    if mesh.is_null() || ray_dir.is_null() || normal_out.is_null() {
        set_error("phongrt_shading_normal: NULL argument");
        return -1;
    }
    let rule = match rule {
        0 => ShadingNormal::Adapted,
        1 => ShadingNormal::Paper,
        2 => ShadingNormal::Interpolated,
        _ => {
            set_error(&format!("phongrt_shading_normal_rule: unknown rule {rule} (0, 1 or 2)"));
            return -1;
        }
    };
    let r = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: pointers are valid per the contract (checked non-NULL above).
        let (m, d) = unsafe { (&(*mesh).data.prims, read_vec3s(ray_dir, 1)[0]) };
        m.shading_normal_with(prim_id, u, v, d, rule)
            .ok_or_else(|| explain_refusal("phongrt_shading_normal", m, prim_id, u, v, Some(d)))
    }));
    match r {
        Ok(Ok(n)) => {
            // SAFETY: normal_out has 3 writable floats (contract).
            unsafe { std::ptr::copy_nonoverlapping(n.to_array().as_ptr(), normal_out, 3) };
            0
        }
        Ok(Err(msg)) => {
            set_error(&msg);
            -1
        }
        Err(_) => {
            set_error("phongrt_shading_normal: internal error (panic caught)");
            -1
        }
    }
}

/// See `phongrt_surface_point` in include/phongrt.h.
///
/// # Safety
/// `mesh` must be a live mesh and `point_out` must point to 3 writable floats.
#[no_mangle]
pub unsafe extern "C" fn phongrt_surface_point(
    mesh: *const phongrt_mesh,
    prim_id: u32,
    u: f32,
    v: f32,
    point_out: *mut f32,
) -> c_int {
    if mesh.is_null() || point_out.is_null() {
        set_error("phongrt_surface_point: NULL argument");
        return -1;
    }
    let r = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: `mesh` is live (contract).
        let m = unsafe { &(*mesh).data.prims };
        match m.surface_point(prim_id, u, v) {
            // Far outside the triangle the point overflows: an error, not success with NaN.
            Some((p, _err)) if p.is_finite() => Ok(p),
            _ => Err(explain_refusal("phongrt_surface_point", m, prim_id, u, v, None)),
        }
    }));
    match r {
        Ok(Ok(p)) => {
            // SAFETY: point_out has 3 writable floats (contract).
            unsafe { std::ptr::copy_nonoverlapping(p.to_array().as_ptr(), point_out, 3) };
            0
        }
        Ok(Err(msg)) => {
            set_error(&msg);
            -1
        }
        Err(_) => {
            set_error("phongrt_surface_point: internal error (panic caught)");
            -1
        }
    }
}

/// See `phongrt_last_error` in include/phongrt.h.
#[no_mangle]
pub extern "C" fn phongrt_last_error() -> *const c_char {
    // The CString lives in this thread's slot until the next phongrt call on this thread.
    // Must not panic on its way back to C: a slot being torn down reads as "".
    LAST_ERROR
        .try_with(|e| e.try_borrow().map(|slot| slot.as_ptr()).unwrap_or(c"".as_ptr()))
        .unwrap_or(c"".as_ptr())
}
