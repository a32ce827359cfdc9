/*
 * A C Embree 4 program as a user of an installed phongrt writes it (built by
 * crates/phongrt-capi/tests/c_install.rs with pkg-config and with CMake against
 * scripts/install.sh's PREFIX): it attaches a Phong mesh to its own RTCScene, traces rays and
 * checks the hits and shading normals. Prints the header's version, then "ok N checks", and exits
 * 0 when every check passes.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include <embree4/rtcore.h>
#include <phongrt.h>

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

static struct RTCRayHit ray(float ox, float oy, float oz, float dx, float dy, float dz) {
  struct RTCRayHit rh;
  memset(&rh, 0, sizeof rh);
  rh.ray.org_x = ox; rh.ray.org_y = oy; rh.ray.org_z = oz;
  rh.ray.dir_x = dx; rh.ray.dir_y = dy; rh.ray.dir_z = dz;
  rh.ray.tfar = INFINITY;
  rh.ray.mask = 0xFFFFFFFFu;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  return rh;
}

int main(void) {
  char v[64];
  snprintf(v, sizeof v, "%d.%d.%d", PHONGRT_VERSION_MAJOR, PHONGRT_VERSION_MINOR, PHONGRT_VERSION_PATCH);
  check(strcmp(v, PHONGRT_VERSION) == 0, "PHONGRT_VERSION agrees with the MAJOR/MINOR/PATCH macros");
  printf("phongrt %s\n", PHONGRT_VERSION);

  RTCDevice device = rtcNewDevice(NULL);
  if (!device) { printf("FAIL: no Embree device\n"); return 2; }
  RTCScene scene = rtcNewScene(device);
  phongrt_mesh* mesh = NULL;
  unsigned id = phongrt_attach_mesh(scene, octa_p, octa_p, 6, octa_i, 8, 1.0f, &mesh);
  check(id != RTC_INVALID_GEOMETRY_ID && mesh != NULL, "phongrt_attach_mesh");
  rtcCommitScene(scene);
  check(rtcGetDeviceError(device) == RTC_ERROR_NONE, "rtcCommitScene");

  /* At the +z vertex (on the unit sphere, normal +z): distance 3, shading normal +z. */
  struct RTCRayHit rh = ray(0, 0, 4, 0, 0, -1);
  rtcIntersect1(scene, &rh, NULL);
  check(rh.hit.geomID == id, "the ray at the +z vertex hits the Phong mesh");
  check(fabsf(rh.ray.tfar - 3.0f) < 1e-4f, "at distance 3");
  float dir[3] = {0, 0, -1}, n[3] = {0, 0, 0};
  check(phongrt_shading_normal(mesh, rh.hit.primID, rh.hit.u, rh.hit.v, dir, n) == 0, "phongrt_shading_normal");
  check(fabsf(n[0]) < 1e-3f && fabsf(n[1]) < 1e-3f && fabsf(n[2] - 1.0f) < 1e-3f, "the shading normal is +z");

  /* At the centre of face (1,1,1): the patch bulges out of the flat face (distance 4 - 1/sqrt(3))
     towards the unit sphere (distance 3), never beyond it. */
  const float s = 1.0f / sqrtf(3.0f);
  rh = ray(4 * s, 4 * s, 4 * s, -s, -s, -s);
  rtcIntersect1(scene, &rh, NULL);
  check(rh.hit.geomID == id, "the ray at a face centre hits the Phong mesh");
  check(rh.ray.tfar < 4.0f - s - 1e-3f && rh.ray.tfar > 3.0f - 1e-4f, "in front of the flat face, not beyond the sphere");

  /* A ray that passes the mesh misses it. */
  rh = ray(3, 3, 4, 0, 0, -1);
  rtcIntersect1(scene, &rh, NULL);
  check(rh.hit.geomID == RTC_INVALID_GEOMETRY_ID, "a ray beside the mesh misses");

  rtcReleaseScene(scene);
  phongrt_mesh_release(mesh);
  rtcReleaseDevice(device);
  if (failures) { printf("%d of %d checks failed\n", failures, checks); return 1; }
  printf("ok %d checks\n", checks);
  return 0;
}
