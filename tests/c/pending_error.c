/*
 * phongrt_attach_mesh with an Embree error already pending on the device (left by the caller's own
 * earlier call): the attach succeeds, the mesh is traced, and the caller's error code is still
 * there for the caller to read. Prints "ok N checks" and exits 0 when every check passes.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include <embree4/rtcore.h>
#include "phongrt.h"

static int checks = 0, failures = 0;
static void check(int ok, const char* what) {
  checks++;
  if (!ok) {
    failures++;
    printf("FAIL: %s (last error: %s)\n", what, phongrt_last_error());
  }
}

/* An octahedron with unit-sphere normals at its 6 vertices (which lie on the unit sphere). */
static const float octa_p[6 * 3] = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
static const unsigned octa_i[8 * 3] = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4,
                                       2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};

int main(void) {
  RTCDevice device = rtcNewDevice(NULL);
  if (!device) { printf("FAIL: no Embree device\n"); return 2; }
  RTCScene scene = rtcNewScene(device);

  /* The caller's own mistake: a build quality that scenes do not take (refit is for geometries). */
  rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_REFIT);

  phongrt_mesh* mesh = NULL;
  unsigned id = phongrt_attach_mesh(scene, octa_p, octa_p, 6, octa_i, 8, 1.0f, &mesh);
  check(id != RTC_INVALID_GEOMETRY_ID, "the attach succeeds despite the caller's pending error");
  check(mesh != NULL, "the attach hands out the mesh");
  check(strcmp(phongrt_last_error(), "") == 0, "a successful attach leaves no error message");
  check(rtcGetDeviceError(device) != RTC_ERROR_NONE, "the caller's pending error is still theirs to read");

  rtcCommitScene(scene);
  check(rtcGetDeviceError(device) == RTC_ERROR_NONE, "the commit succeeds");

  /* A ray at the +z vertex from z = 4 hits the patch at distance 3. */
  struct RTCRayHit rh;
  memset(&rh, 0, sizeof rh);
  rh.ray.org_z = 4.0f;
  rh.ray.dir_z = -1.0f;
  rh.ray.tfar = INFINITY;
  rh.ray.mask = 0xFFFFFFFFu;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(scene, &rh, NULL);
  check(rh.hit.geomID == id, "the ray hits the Phong mesh");
  check(fabsf(rh.ray.tfar - 3.0f) < 1e-4f, "at the vertex, distance 3");

  rtcReleaseScene(scene);
  phongrt_mesh_release(mesh);
  rtcReleaseDevice(device);
  if (failures) { printf("%d of %d checks failed\n", failures, checks); return 1; }
  printf("ok %d checks\n", checks);
  return 0;
}
