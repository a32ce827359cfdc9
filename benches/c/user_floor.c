/* The user-geometry floor in plain C, as Embree's user_geometry tutorial writes it: the same
 * uv sphere and camera as benches/primary_rays.rs, traced with rtcIntersect1 on one thread,
 * as Embree triangles and as a user geometry whose callback is a Moller-Trumbore test (candidate
 * hit written, filter invoked, restored if rejected). It measures what the callback route costs
 * in Embree itself, without any of our Rust code. Run it with scripts/c-floor.sh.
 *
 * usage: user_floor [segments rings [width]]   (defaults 12 6 128) */
#define _POSIX_C_SOURCE 199309L
#include <embree4/rtcore.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include <pmmintrin.h>
#include <xmmintrin.h>

typedef struct { float x, y, z; } V3;
static V3 *pos;
static unsigned (*idx)[3];
static int np, nt;
static long calls;

static V3 sub(V3 a, V3 b) { V3 r = {a.x - b.x, a.y - b.y, a.z - b.z}; return r; }
static V3 cross(V3 a, V3 b) { V3 r = {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; return r; }
static float dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

/* The uv sphere of src/scene/mod.rs (uv_sphere), radius 1. */
static void sphere(int segs, int rings) {
  pos = malloc(sizeof *pos * (size_t)(segs * (rings - 1) + 2));
  idx = malloc(sizeof *idx * (size_t)(2 * segs * (rings - 1)));
  np = nt = 0;
  pos[np++] = (V3){0, 1, 0};
  for (int r = 1; r < rings; r++) {
    float th = 3.14159265358979f * (float)r / (float)rings;
    for (int s = 0; s < segs; s++) {
      float ph = 2.0f * 3.14159265358979f * (float)s / (float)segs;
      pos[np++] = (V3){sinf(th) * cosf(ph), cosf(th), -sinf(th) * sinf(ph)};
    }
  }
  pos[np++] = (V3){0, -1, 0};
#define RING(r, s) (unsigned)(1 + ((r) - 1) * segs + ((s) % segs))
  unsigned last = (unsigned)np - 1;
  for (int s = 0; s < segs; s++) {
    idx[nt][0] = 0; idx[nt][1] = RING(1, s); idx[nt][2] = RING(1, s + 1); nt++;
    for (int r = 1; r < rings - 1; r++) {
      idx[nt][0] = RING(r, s); idx[nt][1] = RING(r + 1, s); idx[nt][2] = RING(r + 1, s + 1); nt++;
      idx[nt][0] = RING(r, s); idx[nt][1] = RING(r + 1, s + 1); idx[nt][2] = RING(r, s + 1); nt++;
    }
    idx[nt][0] = RING(rings - 1, s); idx[nt][1] = last; idx[nt][2] = RING(rings - 1, s + 1); nt++;
  }
}

static void bounds(const struct RTCBoundsFunctionArguments *a) {
  const unsigned *t = idx[a->primID];
  V3 p0 = pos[t[0]], p1 = pos[t[1]], p2 = pos[t[2]];
  struct RTCBounds *b = a->bounds_o;
  b->lower_x = fminf(p0.x, fminf(p1.x, p2.x)); b->upper_x = fmaxf(p0.x, fmaxf(p1.x, p2.x));
  b->lower_y = fminf(p0.y, fminf(p1.y, p2.y)); b->upper_y = fmaxf(p0.y, fmaxf(p1.y, p2.y));
  b->lower_z = fminf(p0.z, fminf(p1.z, p2.z)); b->upper_z = fmaxf(p0.z, fmaxf(p1.z, p2.z));
}

/* rtcIntersect1 only: N is 1, so rayhit is an RTCRayHit. */
static void intersect(const struct RTCIntersectFunctionNArguments *a) {
  calls++;
  if (a->N != 1 || a->valid[0] != -1) return;
  struct RTCRayHit *rh = (struct RTCRayHit *)a->rayhit;
  const unsigned *t = idx[a->primID];
  V3 v0 = pos[t[0]], v1 = pos[t[1]], v2 = pos[t[2]];
  V3 org = {rh->ray.org_x, rh->ray.org_y, rh->ray.org_z}, dir = {rh->ray.dir_x, rh->ray.dir_y, rh->ray.dir_z};
  V3 e1 = sub(v1, v0), e2 = sub(v2, v0), pv = cross(dir, e2);
  float det = dot(e1, pv);
  if (det == 0.0f) return;
  float inv = 1.0f / det;
  V3 s = sub(org, v0), q = cross(s, e1);
  float u = dot(s, pv) * inv, v = dot(dir, q) * inv;
  if (!(u >= 0 && v >= 0 && u + v <= 1)) return;
  float tt = dot(e2, q) * inv;
  if (!(tt > rh->ray.tnear && tt < rh->ray.tfar)) return;
  struct RTCHit saved = rh->hit;
  float saved_tfar = rh->ray.tfar;
  V3 ng = cross(e1, e2);
  rh->ray.tfar = tt;
  rh->hit.Ng_x = ng.x; rh->hit.Ng_y = ng.y; rh->hit.Ng_z = ng.z;
  rh->hit.u = u; rh->hit.v = v;
  rh->hit.primID = a->primID; rh->hit.geomID = a->geomID;
  for (int l = 0; l < RTC_MAX_INSTANCE_LEVEL_COUNT; l++) {
    rh->hit.instID[l] = a->context->instID[l];
    rh->hit.instPrimID[l] = a->context->instPrimID[l];
  }
  int mask = -1;
  struct RTCFilterFunctionNArguments fa = {&mask, a->geometryUserPtr, a->context, (struct RTCRayN *)&rh->ray, (struct RTCHitN *)&rh->hit, 1};
  rtcInvokeIntersectFilterFromGeometry(a, &fa);
  if (mask != -1) { rh->hit = saved; rh->ray.tfar = saved_tfar; }
}

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Best of `reps` passes over the w x w camera rays of benches/primary_rays.rs. */
static double trace(RTCScene scene, int w, int reps, int *hits) {
  double best = INFINITY;
  for (int rep = 0; rep < reps; rep++) {
    double t0 = now();
    int count = 0;
    for (int y = 0; y < w; y++)
      for (int x = 0; x < w; x++) {
        float sx = ((float)x + 0.5f) / (float)w * 2 - 1, sy = 1 - ((float)y + 0.5f) / (float)w * 2;
        struct RTCRayHit rh = {0};
        rh.ray.org_z = 3; rh.ray.dir_x = sx * 0.45f; rh.ray.dir_y = sy * 0.45f; rh.ray.dir_z = -1;
        rh.ray.tfar = INFINITY; rh.ray.mask = (unsigned)-1;
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        for (int l = 0; l < RTC_MAX_INSTANCE_LEVEL_COUNT; l++) rh.hit.instID[l] = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(scene, &rh, NULL);
        count += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
      }
    double dt = now() - t0;
    if (dt < best) best = dt;
    *hits = count;
  }
  return best;
}

int main(int argc, char **argv) {
  _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
  _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
  int segs = argc > 1 ? atoi(argv[1]) : 12, rings = argc > 2 ? atoi(argv[2]) : 6, w = argc > 3 ? atoi(argv[3]) : 128;
  if (segs < 3 || rings < 2 || w < 1) { fprintf(stderr, "usage: %s [segments>=3 rings>=2 [width>=1]]\n", argv[0]); return 2; }
  sphere(segs, rings);
  RTCDevice dev = rtcNewDevice("threads=1");
  if (!dev) { fprintf(stderr, "rtcNewDevice failed\n"); return 1; }

  RTCScene native = rtcNewScene(dev);
  RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
  float *vb = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 12, (size_t)np);
  for (int i = 0; i < np; i++) { vb[3 * i] = pos[i].x; vb[3 * i + 1] = pos[i].y; vb[3 * i + 2] = pos[i].z; }
  unsigned *ib = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12, (size_t)nt);
  for (int i = 0; i < nt; i++) { ib[3 * i] = idx[i][0]; ib[3 * i + 1] = idx[i][1]; ib[3 * i + 2] = idx[i][2]; }
  rtcSetGeometryMask(g, (unsigned)-1);
  rtcCommitGeometry(g); rtcAttachGeometry(native, g); rtcReleaseGeometry(g); rtcCommitScene(native);

  RTCScene user = rtcNewScene(dev);
  RTCGeometry ug = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_USER);
  rtcSetGeometryUserPrimitiveCount(ug, (unsigned)nt);
  rtcSetGeometryBoundsFunction(ug, bounds, NULL);
  rtcSetGeometryIntersectFunction(ug, intersect);
  rtcSetGeometryMask(ug, (unsigned)-1);
  rtcCommitGeometry(ug); rtcAttachGeometry(user, ug); rtcReleaseGeometry(ug); rtcCommitScene(user);
  if (rtcGetDeviceError(dev) != RTC_ERROR_NONE) { fprintf(stderr, "Embree error while building\n"); return 1; }

  const int reps = 200, rounds = 3;
  double rays = (double)w * w;
  int warm;
  trace(native, w, reps / 10, &warm); /* warm up caches and clocks before the timed rounds */
  trace(user, w, reps / 10, &warm);
  printf("sphere %dx%d (%d triangles), %dx%d rays, rtcIntersect1, 1 thread, best of %d passes\n", segs, rings, nt, w, w, reps);
  for (int k = 0; k < rounds; k++) {
    int hn, hu;
    double tn = trace(native, w, reps, &hn);
    calls = 0;
    double tu = trace(user, w, reps, &hu);
    if (hn != hu) { fprintf(stderr, "hit counts differ: %d native, %d user\n", hn, hu); return 1; }
    printf("native %.3f ms, user geometry %.3f ms, ratio %.2f (%d hits; %.2f callback calls per ray)\n",
           tn * 1e3, tu * 1e3, tu / tn, hn, (double)calls / (reps * rays));
  }
  rtcReleaseScene(native); rtcReleaseScene(user); rtcReleaseDevice(dev);
  free(pos); free(idx);
  return 0;
}
