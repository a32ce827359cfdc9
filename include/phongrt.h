/*
 * phongrt: Phong Tessellation patches as an Embree 4 user geometry, for C and C++ programs.
 *
 * Attach a Phong mesh to your own RTCScene and trace it with rtcIntersect1/4/8/16 and
 * rtcOccluded1/4/8/16 as you would a triangle mesh: hits report geomID, primID, instID, u and v in
 * Embree's triangle convention ((1-u-v) v0 + u v1 + v v2 at alpha = 0) and Ng = the true surface
 * normal dp/du x dp/dv. Intersection and occlusion filters set on the geometry are invoked per
 * candidate hit, as for triangles (a filter passed in the query arguments is not: Embree 4 gives a
 * user geometry no way to invoke it, rtcInvokeIntersectFilterFromGeometry runs the geometry's
 * only). No panic in phongrt's callbacks (which would be a bug) unwinds into Embree or your
 * program: the ray sees a miss.
 *
 * Install and link: scripts/install.sh PREFIX, then
 *   cc prog.c $(PKG_CONFIG_PATH=PREFIX/lib/pkgconfig pkg-config --cflags --libs phongrt)
 * or, in CMake, find_package(phongrt) and target_link_libraries(prog phongrt::phongrt). Both link
 * -lphongrt and -lembree4 and set an rpath to PREFIX/lib; libphongrt.so's SONAME is
 * libphongrt.so.MAJOR.
 *
 * Threads.
 * - Tracing is Embree's business: once a scene is committed, any number of threads may run
 *   rtcIntersect and rtcOccluded on it at once, as with triangles. phongrt's callbacks only read
 *   the mesh (no locks, no shared mutable state).
 * - phongrt_shading_normal, phongrt_shading_normal_rule and phongrt_surface_point only read the
 *   mesh: call them from any threads at once, during tracing or a commit, between the
 *   phongrt_attach_mesh that made the mesh and its phongrt_mesh_release.
 * - phongrt_attach_mesh changes `scene` as rtcAttachGeometry does, under the same rules: several
 *   threads may attach to one scene at once, but not while that scene is committed
 *   (rtcCommitScene, rtcJoinCommitScene) or traced; commit it afterwards. It leaves the device's
 *   error code (rtcGetDeviceError) as it was unless it fails in Embree.
 * - rtcCommitScene, of the scene or of any scene that instances it, calls phongrt's bounds
 *   callback, which reads the mesh.
 * - phongrt_mesh_release frees the mesh that the geometry points into. After it, no scene holding
 *   the geometry, directly or through an instance, may be committed or traced (releasing such a
 *   scene is fine). It must not run concurrently with any call that uses the mesh.
 * - phongrt_last_error's message is per thread.
 *
 * Spaces. Embree hands a user geometry the ray in the object space of the scene it is attached
 * to, so a hit on a Phong mesh inside an instance (hit.instID[0] != RTC_INVALID_GEOMETRY_ID)
 * reports u, v, primID and Ng in the mesh's object space, exactly as for triangles: Ng is not
 * transformed to world space. The helpers below work in that same object space: their `ray_dir`
 * is the ray's direction in the mesh's object space, and the normals and points they return are
 * in object space. For an instanced hit, the caller transforms: ray_dir by the inverse of the
 * instance's object-to-world transform (rtcGetGeometryTransformFromScene gives the transform,
 * compose it along hit.instID[] for nested instances), the returned point by the transform, the
 * returned normal by its inverse transpose (then normalize). Without an instance, object space is
 * world space. The side a normal faces is kept by these transforms; under a non-uniform scale the
 * adapted and paper rules' angle test is the object space's.
 */
#ifndef PHONGRT_H
#define PHONGRT_H

#include <stddef.h>
#include <embree4/rtcore.h>

/*
 * The version of this header and of the library it came with. scripts/install.sh writes the
 * workspace's version here (Cargo.toml); these in-tree values are the same
 * (crates/phongrt-capi/tests/c_install.rs checks that they agree).
 */
#define PHONGRT_VERSION_MAJOR 0
#define PHONGRT_VERSION_MINOR 1
#define PHONGRT_VERSION_PATCH 0
#define PHONGRT_VERSION "0.1.0"

#ifdef __cplusplus
extern "C" {
#endif

/* Mesh data owned by phongrt (copied from the caller's arrays). */
typedef struct phongrt_mesh phongrt_mesh;

/*
 * Build a Phong mesh from `vertex_count` positions and normals (3 floats each; normals need not be
 * unit length but must not be zero: a zero normal is an error naming the vertex) and
 * `triangle_count` triangles (3 vertex indices each; an array may be NULL when its count is 0), with
 * shape factor `alpha` in [0, 1] (0 = flat triangles, 1 = full Phong tessellation), create its user
 * geometry on the scene's device, attach it to `scene` and return its geomID (the scene must then be
 * committed as usual). `*mesh_out` receives the mesh, for the shading helpers and for
 * phongrt_mesh_release. Returns RTC_INVALID_GEOMETRY_ID on error; phongrt_last_error() says why.
 * Embree offers no query for whether a scene is committed or instanced elsewhere, so neither is
 * refused here: attaching to a committed scene is legal in Embree and takes effect at the next
 * rtcCommitScene (of it, and of every scene instancing it).
 *
 * The mesh is watertight: positions within 1e-6 of the mesh's bounding-box diagonal are welded
 * (onto the first of them), so triangles sharing a position share an edge whatever the indexing (a
 * triangle soup too), and every edge that is not smooth (a crease, where the normals at an end
 * differ: split normals; a border; an edge of more than two triangles) is kept straight, so no ray
 * slips between two patches. Triangles keep their order (primID) and corner order (u, v).
 * For plain Phong tessellation, use phongrt_attach_mesh_ex with PHONGRT_MESH_PLAIN.
 */
unsigned int phongrt_attach_mesh(RTCScene scene,
                                 const float* positions, const float* normals, size_t vertex_count,
                                 const unsigned int* indices, size_t triangle_count,
                                 float alpha, phongrt_mesh** mesh_out);

/* phongrt_attach_mesh_ex flag: plain Phong tessellation of the arrays as given (no welding, every
 * edge bent by the normals at its ends, as the paper defines it: split normals then show cracks). */
#define PHONGRT_MESH_PLAIN 1u

/* As phongrt_attach_mesh, with `flags`: 0 (the same as phongrt_attach_mesh) or PHONGRT_MESH_PLAIN.
 * Unknown flags are an error. */
unsigned int phongrt_attach_mesh_ex(RTCScene scene,
                                    const float* positions, const float* normals, size_t vertex_count,
                                    const unsigned int* indices, size_t triangle_count,
                                    float alpha, unsigned int flags, phongrt_mesh** mesh_out);

/* Free a mesh. NULL is ignored. Afterwards no scene holding its geometry, directly or through an
 * instance, may be committed or traced (see "Threads" above): release those scenes first, or
 * rtcDetachGeometry it from each and commit them again. */
void phongrt_mesh_release(phongrt_mesh* mesh);

/* How the shading normal is chosen (see phongrt_shading_normal_rule). */
typedef enum phongrt_shading_rule {
    /* The Phong-interpolated normal, bent just enough that the view vector reflected about it stays
     * above the true surface (Keller et al. 2017, the Iray shading-normal adaptation). Continuous;
     * the default. */
    PHONGRT_SHADING_ADAPTED = 0,
    /* Ogaki & Tokuyoshi, section 4: the interpolated normal, switched to the true surface normal
     * where the reflected view vector would fall below the surface. Discontinuous at the switch. */
    PHONGRT_SHADING_PAPER = 1,
    /* The plain interpolated vertex normal. */
    PHONGRT_SHADING_INTERPOLATED = 2
} phongrt_shading_rule;

/*
 * The shading normal at (u, v) of triangle `prim_id` for a ray arriving along `ray_dir` (any
 * non-zero length), under the default rule (PHONGRT_SHADING_ADAPTED). Unit length, facing the
 * side the ray came from (dot(normal, ray_dir) <= 0). `ray_dir` and the normal are in the mesh's
 * object space: for a hit inside an instance, transform them (see "Spaces" above).
 * Returns 0 on success, -1 on bad input (NULL, a primitive out of range, a non-finite u, v or
 * direction, a zero direction).
 */
int phongrt_shading_normal(const phongrt_mesh* mesh, unsigned int prim_id, float u, float v,
                           const float ray_dir[3], float normal_out[3]);

/* As phongrt_shading_normal, under `rule`. An unknown rule is bad input (-1). */
int phongrt_shading_normal_rule(const phongrt_mesh* mesh, unsigned int prim_id, float u, float v,
                                const float ray_dir[3], phongrt_shading_rule rule, float normal_out[3]);

/* The surface point at (u, v) of triangle `prim_id`, in the mesh's object space (for a hit inside
 * an instance, apply the instance's transform; see "Spaces" above). Returns 0, or -1 for a bad
 * primitive, a non-finite (u, v), or a (u, v) so far outside the triangle that the point is not
 * representable (it is then not written). */
int phongrt_surface_point(const phongrt_mesh* mesh, unsigned int prim_id, float u, float v,
                          float point_out[3]);

/*
 * Why the last failing phongrt call on this thread failed: a NUL-terminated message naming the
 * function and what is wrong, "" if none failed yet. Never NULL. Each thread has its own message.
 * A call that fails replaces it and a successful phongrt_attach_mesh resets it to ""; the other
 * functions leave it as it is when they succeed, so read it when a call has returned its error
 * value. The string belongs to phongrt: it stays valid until the next phongrt call on the same
 * thread other than phongrt_last_error, or until the thread exits (rtcIntersect, rtcOccluded and
 * rtcCommitScene do not change it); copy it to keep it. Do not free it.
 */
const char* phongrt_last_error(void);

#ifdef __cplusplus
}
#endif

#endif /* PHONGRT_H */
