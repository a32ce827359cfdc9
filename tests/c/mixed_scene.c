/*
 * A C Embree 4 program that mixes native triangles, a Phong mesh and an instance of it, through
 * include/phongrt.h. Prints "ok N checks" and exits 0 when every check passes.
 *
 * The Phong mesh is an octahedron with exact unit-sphere normals at its 6 vertices (which lie on the
 * unit sphere): at alpha = 1 the patch passes through the vertices, and bulges outwards from the
 * flat faces towards the sphere. Rays aimed at a vertex must hit at distance (d - 1); rays aimed at
 * a face centre must hit before the flat face (the bulge) and not beyond the unit sphere.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <embree4/rtcore.h>
#include "phongrt.h"

static int checks = 0, failures = 0;
#define CHECK(cond, ...)                                                   \
  do {                                                                     \
    checks++;                                                              \
    if (!(cond)) {                                                         \
      failures++;                                                          \
      fprintf(stderr, "FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond);      \
      fprintf(stderr, __VA_ARGS__);                                        \
      fprintf(stderr, "\n");                                               \
    }                                                                      \
  } while (0)

static const float octa_p[6 * 3] = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
static const unsigned octa_i[8 * 3] = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4,
                                       2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};

static void ray_init(struct RTCRayHit* rh, float ox, float oy, float oz, float dx, float dy, float dz) {
  memset(rh, 0, sizeof *rh);
  rh->ray.org_x = ox; rh->ray.org_y = oy; rh->ray.org_z = oz;
  rh->ray.dir_x = dx; rh->ray.dir_y = dy; rh->ray.dir_z = dz;
  rh->ray.tnear = 0.0f; rh->ray.tfar = INFINITY; rh->ray.mask = 0xFFFFFFFFu;
  rh->hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
}

int main(void) {
  RTCDevice device = rtcNewDevice(NULL);
  if (!device) { fprintf(stderr, "no Embree device\n"); return 2; }

  /* Child scene: the Phong octahedron alone, to be instanced. */
  RTCScene child = rtcNewScene(device);
  phongrt_mesh* child_mesh = NULL;
  unsigned child_geom = phongrt_attach_mesh(child, octa_p, octa_p, 6, octa_i, 8, 1.0f, &child_mesh);
  CHECK(child_geom != RTC_INVALID_GEOMETRY_ID, "attach failed: %s", phongrt_last_error());
  rtcCommitScene(child);

  /* Top scene: a native ground quad (2 triangles at y = -6, below every ray origin), the Phong octahedron at the origin,
     and an instance of the child translated to x = 8 (clear of every other ray, and of the origins at distance 4). */
  RTCScene scene = rtcNewScene(device);
  RTCGeometry ground = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  float* gv = (float*)rtcSetNewGeometryBuffer(ground, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 4);
  unsigned* gi = (unsigned*)rtcSetNewGeometryBuffer(ground, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), 2);
  const float g[12] = {-20, -6, -20, 20, -6, -20, 20, -6, 20, -20, -6, 20};
  memcpy(gv, g, sizeof g);
  const unsigned gidx[6] = {0, 2, 1, 0, 3, 2};
  memcpy(gi, gidx, sizeof gidx);
  rtcCommitGeometry(ground);
  unsigned ground_id = rtcAttachGeometry(scene, ground);
  rtcReleaseGeometry(ground);

  phongrt_mesh* mesh = NULL;
  unsigned phong_id = phongrt_attach_mesh(scene, octa_p, octa_p, 6, octa_i, 8, 1.0f, &mesh);
  CHECK(phong_id != RTC_INVALID_GEOMETRY_ID, "attach failed: %s", phongrt_last_error());

  RTCGeometry inst = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_INSTANCE);
  rtcSetGeometryInstancedScene(inst, child);
  const float xfm[12] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 8, 0, 0}; /* 3x4 column major */
  rtcSetGeometryTransform(inst, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, xfm);
  rtcCommitGeometry(inst);
  unsigned inst_id = rtcAttachGeometry(scene, inst);
  rtcReleaseGeometry(inst);
  rtcCommitScene(scene);
  CHECK(rtcGetDeviceError(device) == RTC_ERROR_NONE, "Embree error");

  /* Bad input is refused with a message, not a crash. */
  phongrt_mesh* bad = NULL;
  unsigned bad_id = phongrt_attach_mesh(child, octa_p, octa_p, 3, octa_i, 8, 1.0f, &bad);
  CHECK(bad_id == RTC_INVALID_GEOMETRY_ID && bad == NULL, "out-of-range indices accepted");
  CHECK(strlen(phongrt_last_error()) > 0, "no error message");

  /* 1. Rays at the 6 vertices of the Phong octahedron at the origin, from distance 4. */
  for (int k = 0; k < 6; k++) {
    const float* p = &octa_p[3 * k];
    struct RTCRayHit rh;
    ray_init(&rh, 4 * p[0] + 0.0f, 4 * p[1], 4 * p[2], -p[0], -p[1], -p[2]);
    rtcIntersect1(scene, &rh, NULL);
    CHECK(rh.hit.geomID == phong_id, "vertex %d: geomID %u", k, rh.hit.geomID);
    CHECK(fabsf(rh.ray.tfar - 3.0f) < 1e-4f, "vertex %d: t = %.7f", k, rh.ray.tfar);
  }

  /* 2. Rays at face centres: the Phong patch bulges out of the flat face, inside the unit sphere. */
  const float flat_dist = 1.0f / sqrtf(3.0f); /* distance of a face plane from the origin */
  for (int f = 0; f < 8; f++) {
    const unsigned* t = &octa_i[3 * f];
    float c[3];
    for (int a = 0; a < 3; a++) c[a] = (octa_p[3 * t[0] + a] + octa_p[3 * t[1] + a] + octa_p[3 * t[2] + a]) / 3.0f;
    float len = sqrtf(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    float d[3] = {-c[0] / len, -c[1] / len, -c[2] / len};
    struct RTCRayHit rh;
    ray_init(&rh, -4 * d[0], -4 * d[1], -4 * d[2], d[0], d[1], d[2]);
    rtcIntersect1(scene, &rh, NULL);
    float r = 4.0f - rh.ray.tfar; /* distance of the hit from the origin */
    CHECK(rh.hit.geomID == phong_id && rh.hit.primID == (unsigned)f, "face %d: geom %u prim %u", f, rh.hit.geomID, rh.hit.primID);
    CHECK(r > flat_dist + 0.05f && r <= 1.0f + 1e-5f, "face %d: hit radius %.6f", f, r);
    CHECK(fabsf(rh.hit.u - 1.0f / 3.0f) < 1e-3f && fabsf(rh.hit.v - 1.0f / 3.0f) < 1e-3f, "face %d: u,v = %f,%f", f, rh.hit.u, rh.hit.v);
    /* Ng points outwards (along -d). */
    float ngd = rh.hit.Ng_x * d[0] + rh.hit.Ng_y * d[1] + rh.hit.Ng_z * d[2];
    CHECK(ngd < 0.0f, "face %d: Ng points inwards", f);
    float n[3], pt[3];
    CHECK(phongrt_shading_normal(mesh, rh.hit.primID, rh.hit.u, rh.hit.v, d, n) == 0, "shading normal");
    CHECK(n[0] * d[0] + n[1] * d[1] + n[2] * d[2] < -0.99f, "face %d: shading normal not radial", f);
    /* Head-on, every rule gives the interpolated normal; an unknown rule is refused. */
    for (int rule = 0; rule < 3; rule++) {
      float m[3];
      CHECK(phongrt_shading_normal_rule(mesh, rh.hit.primID, rh.hit.u, rh.hit.v, d, (phongrt_shading_rule)rule, m) == 0, "rule %d", rule);
      CHECK(fabsf(m[0] - n[0]) + fabsf(m[1] - n[1]) + fabsf(m[2] - n[2]) < 1e-5f, "face %d: rule %d differs head-on", f, rule);
    }
    CHECK(phongrt_shading_normal_rule(mesh, rh.hit.primID, rh.hit.u, rh.hit.v, d, (phongrt_shading_rule)7, n) == -1, "unknown rule accepted");
    CHECK(strstr(phongrt_last_error(), "unknown rule") != NULL, "unknown rule: error %s", phongrt_last_error());
    CHECK(phongrt_shading_normal(mesh, rh.hit.primID, NAN, rh.hit.v, d, n) == -1, "NaN u accepted");
    CHECK(phongrt_surface_point(mesh, rh.hit.primID, rh.hit.u, rh.hit.v, pt) == 0, "surface point");
    float pr = sqrtf(pt[0] * pt[0] + pt[1] * pt[1] + pt[2] * pt[2]);
    CHECK(fabsf(pr - r) < 1e-4f, "face %d: surface point radius %f vs hit %f", f, pr, r);
  }

  /* 3. The instance: same hit, reported with instID. */
  {
    struct RTCRayHit rh;
    ray_init(&rh, 8.0f, 4.0f, 0.0f, 0.0f, -1.0f, 0.0f);
    rtcIntersect1(scene, &rh, NULL);
    CHECK(rh.hit.instID[0] == inst_id && rh.hit.geomID == child_geom, "instance: inst %u geom %u", rh.hit.instID[0], rh.hit.geomID);
    CHECK(fabsf(rh.ray.tfar - 3.0f) < 1e-4f, "instance: t = %f", rh.ray.tfar);
  }

  /* 4. Native triangles still work beside it, and occlusion is reported with tfar = -inf. */
  {
    struct RTCRayHit rh;
    ray_init(&rh, 10.0f, 4.0f, 3.0f, 0.0f, -1.0f, 0.0f);
    rtcIntersect1(scene, &rh, NULL);
    CHECK(rh.hit.geomID == ground_id && fabsf(rh.ray.tfar - 10.0f) < 1e-5f, "ground: geom %u t %f", rh.hit.geomID, rh.ray.tfar);
    struct RTCRay ray = rh.ray;
    ray.org_x = 0.0f; ray.org_z = 0.0f; ray.tfar = 2.0f; /* from y = 4 down to y = 2: nothing */
    rtcOccluded1(scene, &ray, NULL);
    CHECK(ray.tfar == 2.0f, "occluded over an empty interval");
    ray.tfar = 3.5f; /* reaches the Phong top vertex at y = 1 */
    rtcOccluded1(scene, &ray, NULL);
    CHECK(ray.tfar == -INFINITY, "not occluded by the Phong mesh");
  }

  /* 5. A 4-wide packet through the Phong mesh. */
  {
    RTC_ALIGN(16) int valid[4] = {-1, -1, -1, 0};
    RTC_ALIGN(16) struct RTCRayHit4 rh;
    memset(&rh, 0, sizeof rh);
    for (int k = 0; k < 4; k++) {
      rh.ray.org_x[k] = 0.1f * k; rh.ray.org_y[k] = 4.0f; rh.ray.org_z[k] = 0.0f;
      rh.ray.dir_y[k] = -1.0f; rh.ray.tfar[k] = INFINITY; rh.ray.mask[k] = 0xFFFFFFFFu;
      rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
    }
    rtcIntersect4(valid, scene, &rh, NULL);
    for (int k = 0; k < 3; k++) CHECK(rh.hit.geomID[k] == phong_id, "packet lane %d: geom %u", k, rh.hit.geomID[k]);
    CHECK(rh.hit.geomID[3] == RTC_INVALID_GEOMETRY_ID, "invalid lane traced");
    CHECK(fabsf(rh.ray.tfar[0] - 3.0f) < 1e-4f, "packet lane 0: t = %f", rh.ray.tfar[0]);
  }

  rtcReleaseScene(scene);
  rtcReleaseScene(child);
  phongrt_mesh_release(mesh);
  phongrt_mesh_release(child_mesh);
  rtcReleaseDevice(device);

  if (failures) {
    fprintf(stderr, "%d of %d checks failed\n", failures, checks);
    return 1;
  }
  printf("ok %d checks\n", checks);
  return 0;
}
