/*
 * phongrt: Phong Tessellation patches as an Embree 4 user geometry, for C and C++ programs.
 *
 * Attach a Phong mesh to your own RTCScene and trace it with rtcIntersect1/4/8/16 and
 * rtcOccluded1/4/8/16 as you would a triangle mesh: hits report geomID, primID, instID, u and v in
 * Embree's triangle convention ((1-u-v) v0 + u v1 + v v2 at alpha = 0) and Ng = the true surface
 * normal dp/du x dp/dv. Intersection and occlusion filters set on the geometry are invoked per
 * candidate hit, as for triangles (a filter passed in the query arguments is not: Embree 4 gives a
 * user geometry no way to invoke it, rtcInvokeIntersectFilterFromGeometry runs the geometry's only). No panic in phongrt's callbacks
 * (which would be a bug) unwinds into Embree or your program: the ray sees a miss.
 *
 * Link with -lphongrt (libphongrt.so or libphongrt.a) and -lembree4.
 */
#ifndef PHONGRT_H
#define PHONGRT_H

#include <stddef.h>
#include <embree4/rtcore.h>

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

/* Free a mesh. Call only after every scene the mesh was attached to has been released. NULL is ignored. */
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
 * The shading normal at (u, v) of triangle `prim_id` for a ray arriving along `ray_dir`, under the
 * default rule (PHONGRT_SHADING_ADAPTED). Unit length, facing the side the ray came from.
 * Returns 0 on success, -1 on bad input (NULL, a primitive out of range, a non-finite u, v or
 * direction, a zero direction).
 */
int phongrt_shading_normal(const phongrt_mesh* mesh, unsigned int prim_id, float u, float v,
                           const float ray_dir[3], float normal_out[3]);

/* As phongrt_shading_normal, under `rule`. An unknown rule is bad input (-1). */
int phongrt_shading_normal_rule(const phongrt_mesh* mesh, unsigned int prim_id, float u, float v,
                                const float ray_dir[3], phongrt_shading_rule rule, float normal_out[3]);

/* The surface point at (u, v) of triangle `prim_id` (object space). Returns 0, or -1 for a bad
 * primitive, a non-finite (u, v), or a (u, v) so far outside the triangle that the point is not
 * representable (it is then not written). */
int phongrt_surface_point(const phongrt_mesh* mesh, unsigned int prim_id, float u, float v,
                          float point_out[3]);

/* The last error message of this thread ("" if none). Valid until the next phongrt call on it. */
const char* phongrt_last_error(void);

#ifdef __cplusplus
}
#endif

#endif /* PHONGRT_H */
