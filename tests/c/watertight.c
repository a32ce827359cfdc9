/*
 * Watertight meshes from a C program's own arrays: scenes/cylinder_capped.obj (path in argv[1]) as a
 * triangle soup with split normals (flat caps, radial sides) and a box whose faces have their own
 * normals tilted towards the corners, attached with phongrt_attach_mesh (watertight by default)
 * and with phongrt_attach_mesh_ex(PHONGRT_MESH_PLAIN). Rays from points inside count escapes.
 * Prints "NAME escapes E of 1000000 (plain: P of 100000)" per mesh; exits non-zero on an error.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <embree4/rtcore.h>
#include "phongrt.h"

#define MAXV 4096

static float P[MAXV * 3], N[MAXV * 3];
static unsigned I[MAXV * 3];
static size_t nv, nt;

static void corner(const float* p, const float* n) {
  memcpy(&P[nv * 3], p, 3 * sizeof(float));
  memcpy(&N[nv * 3], n, 3 * sizeof(float));
  nv++;
}

static int load_cylinder_soup(const char* path) {
  static float v[MAXV][3];
  size_t count = 0;
  char line[512];
  FILE* f = fopen(path, "r");
  if (!f) { perror(path); return -1; }
  nv = nt = 0;
  while (fgets(line, sizeof line, f)) {
    if (line[0] == 'v' && line[1] == ' ') {
      if (count == MAXV || sscanf(line + 2, "%f %f %f", &v[count][0], &v[count][1], &v[count][2]) != 3) return -1;
      count++;
    } else if (line[0] == 'f' && line[1] == ' ') {
      int idx[8], k = 0, off = 0, used;
      while (k < 8 && sscanf(line + 1 + off, "%d%n", &idx[k], &used) == 1) { off += used; idx[k]--; k++; }
      int cap = 1;
      for (int j = 1; j < k; j++) cap &= v[idx[j]][2] == v[idx[0]][2];
      for (int j = 1; j + 1 < k; j++) {
        int tri[3] = {idx[0], idx[j], idx[j + 1]};
        for (int c = 0; c < 3; c++) {
          const float* q = v[tri[c]];
          float n[3] = {0, 0, q[2] > 0 ? 1.0f : -1.0f};
          if (!cap) { n[0] = q[0]; n[1] = q[1]; n[2] = 0; }
          corner(q, n);
        }
        I[nt * 3] = (unsigned)nv - 3; I[nt * 3 + 1] = (unsigned)nv - 2; I[nt * 3 + 2] = (unsigned)nv - 1;
        nt++;
      }
    }
  }
  fclose(f);
  return nt == 64 ? 0 : -1;
}

static void make_box(void) {
  nv = nt = 0;
  for (int axis = 0; axis < 3; axis++) {
    for (int s = -1; s <= 1; s += 2) {
      const float st[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
      unsigned base = (unsigned)nv;
      for (int c = 0; c < 4; c++) {
        float q[3], n[3];
        q[axis] = (float)s; q[(axis + 1) % 3] = st[c][0]; q[(axis + 2) % 3] = st[c][1];
        for (int j = 0; j < 3; j++) n[j] = (j == axis ? (float)s : 0.0f) + 0.5f * q[j];
        corner(q, n);
      }
      const unsigned quad[2][4] = {{0, 3, 2, 1}, {0, 1, 2, 3}};
      const unsigned* o = quad[s > 0];
      unsigned t[6] = {o[0], o[1], o[2], o[0], o[2], o[3]};
      for (int j = 0; j < 6; j++) I[nt * 3 + j] = base + t[j];
      nt += 2;
    }
  }
}

static uint64_t rng = 7;
static double next01(void) {
  uint64_t z = (rng += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return (double)((z ^ (z >> 31)) >> 11) / 9007199254740992.0;
}

/* Rays from four points inside, `per` random directions each; returns the escapes or -1. */
static long escapes(RTCDevice device, unsigned flags, long per) {
  RTCScene scene = rtcNewScene(device);
  phongrt_mesh* mesh = NULL;
  unsigned id = phongrt_attach_mesh_ex(scene, P, N, nv, I, nt, 1.0f, flags, &mesh);
  if (id == RTC_INVALID_GEOMETRY_ID) {
    fprintf(stderr, "attach failed: %s\n", phongrt_last_error());
    rtcReleaseScene(scene);
    return -1;
  }
  rtcCommitScene(scene);
  const float org[4][3] = {{0, 0, 0}, {0.3f, -0.4f, 0.5f}, {-0.6f, 0.2f, -0.7f}, {0.5f, 0.5f, 0.9f}};
  long esc = 0;
  for (int o = 0; o < 4; o++) {
    for (long k = 0; k < per; k++) {
      double z = 2.0 * next01() - 1.0, a = 6.283185307179586 * next01(), r = sqrt(1.0 - z * z);
      struct RTCRayHit rh;
      memset(&rh, 0, sizeof rh);
      rh.ray.org_x = org[o][0]; rh.ray.org_y = org[o][1]; rh.ray.org_z = org[o][2];
      rh.ray.dir_x = (float)(r * cos(a)); rh.ray.dir_y = (float)(r * sin(a)); rh.ray.dir_z = (float)z;
      rh.ray.tfar = INFINITY; rh.ray.mask = 0xFFFFFFFFu;
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
      rtcIntersect1(scene, &rh, NULL);
      esc += rh.hit.geomID == RTC_INVALID_GEOMETRY_ID;
    }
  }
  rtcReleaseScene(scene);
  phongrt_mesh_release(mesh);
  return esc;
}

int main(int argc, char** argv) {
  if (argc != 2) { fprintf(stderr, "usage: watertight CYLINDER.obj\n"); return 2; }
  RTCDevice device = rtcNewDevice(NULL);
  if (!device) { fprintf(stderr, "no Embree device\n"); return 2; }
  int status = 0;
  for (int m = 0; m < 2; m++) {
    const char* name = m == 0 ? "cylinder" : "box";
    if (m == 0 ? load_cylinder_soup(argv[1]) != 0 : (make_box(), 0)) {
      fprintf(stderr, "cannot read %s\n", argv[1]);
      return 2;
    }
    long e = escapes(device, 0, 250000), plain = escapes(device, PHONGRT_MESH_PLAIN, 25000);
    if (e < 0 || plain < 0) status = 1;
    printf("%s escapes %ld of 1000000 (plain: %ld of 100000)\n", name, e, plain);
  }
  /* Unknown flags are refused, naming them. */
  RTCScene scene = rtcNewScene(device);
  if (phongrt_attach_mesh_ex(scene, P, N, nv, I, nt, 1.0f, 6u, NULL) != RTC_INVALID_GEOMETRY_ID ||
      strstr(phongrt_last_error(), "unknown flags 0x6") == NULL) {
    fprintf(stderr, "unknown flags accepted: %s\n", phongrt_last_error());
    status = 1;
  }
  rtcReleaseScene(scene);
  rtcReleaseDevice(device);
  return status;
}
