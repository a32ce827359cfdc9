/*
 * Hostile calls to the C API (issue 19, defect 10), run by crates/phongrt-cli/tests/hostile_inputs.rs:
 *  - a zero normal is refused, naming the vertex (the patch would never be hit);
 *  - phongrt_surface_point far outside the triangle fails instead of writing inf/NaN;
 *  - NULL arrays with zero counts are accepted (an empty mesh), NULL with a count is refused;
 *  - the shading helpers' errors name the argument that is wrong and why.
 * Prints "ok" and exits 0 when every case behaves; else prints the failing case and exits 1.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include <embree4/rtcore.h>
#include "phongrt.h"

static int failures = 0;

static void check(int cond, const char* what) {
    if (!cond) {
        printf("FAIL: %s (last error: %s)\n", what, phongrt_last_error());
        failures++;
    }
}

int main(void) {
    RTCDevice device = rtcNewDevice(NULL);
    RTCScene scene = rtcNewScene(device);

    /* One triangle; the normal of vertex 2 is zero. */
    const float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const float zero_n[9] = {0, 0, 1, 0, 0, 1, 0, 0, 0};
    const float good_n[9] = {0, 0, 1, 0, 0, 1, 0, 0, 1};
    const unsigned int tri[3] = {0, 1, 2};
    phongrt_mesh* mesh = NULL;

    unsigned int id = phongrt_attach_mesh(scene, pos, zero_n, 3, tri, 1, 1.0f, &mesh);
    check(id == RTC_INVALID_GEOMETRY_ID, "a zero normal is refused");
    check(strstr(phongrt_last_error(), "vertex 2") != NULL, "the zero-normal error names vertex 2");
    check(mesh == NULL, "no mesh for a refused call");

    id = phongrt_attach_mesh(scene, pos, good_n, 3, tri, 1, 1.0f, &mesh);
    check(id != RTC_INVALID_GEOMETRY_ID && mesh != NULL, "a good mesh is accepted");
    float p[3] = {7, 7, 7};
    check(phongrt_surface_point(mesh, 0, 0.25f, 0.25f, p) == 0 && isfinite(p[0]) && isfinite(p[1]) &&
              isfinite(p[2]),
          "surface point inside the triangle");
    p[0] = p[1] = p[2] = 7;
    check(phongrt_surface_point(mesh, 0, 1e30f, 1e30f, p) == -1, "surface point at u = v = 1e30 fails");
    check(p[0] == 7 && p[1] == 7 && p[2] == 7, "the failed call writes nothing");
    check(strstr(phongrt_last_error(), "too far outside triangle 0") != NULL, "the failure says why");
    check(phongrt_surface_point(mesh, 5, 0.25f, 0.25f, p) == -1, "surface point of primitive 5 fails");
    check(strstr(phongrt_last_error(), "prim_id 5 is out of range: the mesh has 1 triangles") != NULL,
          "the error names the out-of-range prim_id and the count");
    float n[3], zero_dir[3] = {0, 0, 0}, down[3] = {0, 0, -1};
    check(phongrt_shading_normal(mesh, 0, 0.25f, 0.25f, zero_dir, n) == -1, "a zero ray_dir fails");
    check(strstr(phongrt_last_error(), "ray_dir (0, 0, 0) is zero or not finite") != NULL,
          "the error names ray_dir and why");
    check(phongrt_shading_normal(mesh, 0, NAN, 0.25f, down, n) == -1, "a NaN u fails");
    check(strstr(phongrt_last_error(), "(u, v) = (NaN, 0.25) is not finite") != NULL, "the error names (u, v)");

    phongrt_mesh* empty = NULL;
    id = phongrt_attach_mesh(scene, NULL, NULL, 0, NULL, 0, 1.0f, &empty);
    check(id != RTC_INVALID_GEOMETRY_ID && empty != NULL, "NULL arrays with zero counts are accepted");
    id = phongrt_attach_mesh(scene, NULL, NULL, 3, tri, 1, 1.0f, NULL);
    check(id == RTC_INVALID_GEOMETRY_ID, "NULL arrays with a non-zero count are refused");

    rtcCommitScene(scene);
    check(rtcGetDeviceError(device) == RTC_ERROR_NONE, "the scene commits");
    rtcReleaseScene(scene);
    phongrt_mesh_release(mesh);
    phongrt_mesh_release(empty);
    rtcReleaseDevice(device);
    if (failures == 0) {
        printf("ok hostile calls\n");
        return 0;
    }
    return 1;
}
