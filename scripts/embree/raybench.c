/* Single-threaded closest-hit throughput of Embree 3 on the stored ray sets, for a side-by-side
 * comparison with stokes (examples/raybench.rs). Not part of the stokes build; see run.sh.
 *
 *   cc -O3 -march=native scripts/embree/raybench.c -o target/embree-raybench -lembree3 -lm
 *   target/embree-raybench [-d DIR] [-q high,medium,low] [-r ROUNDS] [-n N_RAYS] [-c CONFIG]
 *                          [-R] [-D] SET...
 *
 * -d   ray-set directory (default benches/data/rays)
 * -q   build qualities, comma separated (default high,medium); one scene per quality
 * -r   timed rounds over all rays per quality (default 5)
 * -n   trace only the first N rays (default all)
 * -c   rtcNewDevice config (default "threads=1": single-threaded build, like stokes' obvhs
 *      build without its `parallel` feature; pass -c "" for Embree's default thread count)
 * -R   RTC_SCENE_FLAG_ROBUST
 * -D   leave denormals on (by default the tracing thread sets flush-to-zero and
 *      denormals-are-zero in MXCSR, as the Embree documentation asks of every thread)
 *
 * Ray-set format (tests/common/ray_sets.rs; little-endian, no header): SET_tris.bin 9 f32 per
 * triangle, SET_rays.bin 6 f32 per ray (origin, unit direction; tnear 0, tfar inf),
 * SET_hits_t.bin 1 f32 per ray (inf = miss), SET_hits_prim.bin 1 i32 per ray (-1 = miss).
 *
 * Rays are traced with rtcIntersect1 one at a time (incoherent context), on the calling thread
 * only. Each quality prints one line
 *   embree SET quality=Q tris=.. rays=.. build_ms=.. bvh_kib=.. median X Mrays/s best Y Mrays/s
 *   rounds A B C ..
 * and one `check` line comparing the hits with the stored reference hits using the tolerances of
 * tests/common/ray_sets.rs (t relative 1e-4 + 1e-6 absolute; a different prim id counts as a
 * tie, not a mismatch, if the reference triangle is hit at about the same t).
 */
#include <embree3/rtcore.h>
#include <pmmintrin.h>
#include <xmmintrin.h>
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double now_s(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec + ts.tv_nsec * 1e-9;
}

static void *read_file(const char *dir, const char *set, const char *suffix, size_t elem,
                       size_t *count) {
  char path[4096];
  snprintf(path, sizeof path, "%s/%s_%s.bin", dir, set, suffix);
  FILE *f = fopen(path, "rb");
  if (!f) {
    fprintf(stderr, "%s: %s\n", path, strerror(errno));
    exit(1);
  }
  fseek(f, 0, SEEK_END);
  long len = ftell(f);
  fseek(f, 0, SEEK_SET);
  if (len < 0 || len % elem != 0) {
    fprintf(stderr, "%s: size %ld not a multiple of %zu\n", path, len, elem);
    exit(1);
  }
  /* + 16 bytes: Embree may read a vertex buffer's last float3 with a 16-byte load. */
  void *p = malloc((size_t)len + 16);
  if (!p || fread(p, 1, (size_t)len, f) != (size_t)len) {
    fprintf(stderr, "%s: read failed\n", path);
    exit(1);
  }
  fclose(f);
  *count = (size_t)len / elem;
  return p;
}

static void on_error(void *user, enum RTCError code, const char *msg) {
  (void)user;
  fprintf(stderr, "embree error %d: %s\n", (int)code, msg ? msg : "");
  exit(1);
}

static int64_t mem_bytes; /* net bytes Embree reports through its memory monitor */

static bool on_memory(void *user, ssize_t bytes, bool post) {
  (void)user;
  (void)post;
  __atomic_add_fetch(&mem_bytes, (int64_t)bytes, __ATOMIC_RELAXED);
  return true;
}

static int cmp_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

/* Same tolerances as tests/common/ray_sets.rs. */
#define REL_EPS 1e-4f
#define ABS_EPS 1e-6f
static int t_close(float a, float b, float abs_eps) {
  if (isinf(a) || isinf(b)) return a == b;
  return fabsf(a - b) <= REL_EPS * fmaxf(fabsf(a), fabsf(b)) + abs_eps;
}

/* Double-precision Möller–Trumbore, two-sided; returns t or INFINITY. Used only for ties. */
static float tri_t(const float *tri, const float *ray) {
  double o[3], d[3], e1[3], e2[3], p[3], s[3], q[3];
  for (int k = 0; k < 3; k++) {
    o[k] = ray[k];
    d[k] = ray[3 + k];
    e1[k] = (double)tri[3 + k] - tri[k];
    e2[k] = (double)tri[6 + k] - tri[k];
    s[k] = o[k] - tri[k];
  }
#define CROSS(r, a, b)                  \
  r[0] = a[1] * b[2] - a[2] * b[1];     \
  r[1] = a[2] * b[0] - a[0] * b[2];     \
  r[2] = a[0] * b[1] - a[1] * b[0]
#define DOT(a, b) (a[0] * b[0] + a[1] * b[1] + a[2] * b[2])
  CROSS(p, d, e2);
  double det = DOT(e1, p);
  if (det == 0.0) return INFINITY;
  double u = DOT(s, p) / det;
  CROSS(q, s, e1);
  double v = DOT(d, q) / det;
  double t = DOT(e2, q) / det;
  const double slack = 1e-7;
  if (u < -slack || v < -slack || u + v > 1 + slack || t < 0) return INFINITY;
  return (float)t;
}

static void init_rayhit(struct RTCRayHit *rh, const float *r) {
  rh->ray.org_x = r[0];
  rh->ray.org_y = r[1];
  rh->ray.org_z = r[2];
  rh->ray.dir_x = r[3];
  rh->ray.dir_y = r[4];
  rh->ray.dir_z = r[5];
  rh->ray.tnear = 0.0f;
  rh->ray.tfar = INFINITY;
  rh->ray.time = 0.0f;
  rh->ray.mask = 0xFFFFFFFFu;
  rh->ray.id = 0;
  rh->ray.flags = 0;
  rh->hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh->hit.primID = RTC_INVALID_GEOMETRY_ID;
  rh->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
}

/* The timed loop: one rtcIntersect1 per ray; the checksum keeps the hits live. */
__attribute__((noinline)) static double trace_all(RTCScene scene, const float *rays, size_t n) {
  struct RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  double sum = 0.0;
  for (size_t i = 0; i < n; i++) {
    struct RTCRayHit rh;
    init_rayhit(&rh, rays + 6 * i);
    rtcIntersect1(scene, &ctx, &rh);
    if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) sum += rh.ray.tfar;
  }
  return sum;
}

static void usage(void) {
  fprintf(stderr,
          "usage: embree-raybench [-d DIR] [-q high,medium,low] [-r ROUNDS] [-n N_RAYS] "
          "[-c CONFIG] [-R] [-D] SET...\n");
  exit(2);
}

int main(int argc, char **argv) {
  const char *dir = "benches/data/rays";
  const char *qualities = "high,medium";
  const char *config = "threads=1";
  int rounds = 5;
  long max_rays = -1;
  int robust = 0;
  int ftz = 1;
  int a = 1;
  for (; a < argc && argv[a][0] == '-'; a++) {
    const char *o = argv[a];
    if (!strcmp(o, "-R")) {
      robust = 1;
      continue;
    }
    if (!strcmp(o, "-D")) {
      ftz = 0;
      continue;
    }
    if (a + 1 >= argc) usage();
    const char *v = argv[++a];
    if (!strcmp(o, "-d")) dir = v;
    else if (!strcmp(o, "-q")) qualities = v;
    else if (!strcmp(o, "-c")) config = v;
    else if (!strcmp(o, "-r")) rounds = atoi(v);
    else if (!strcmp(o, "-n")) max_rays = atol(v);
    else usage();
  }
  if (a >= argc || rounds < 1) usage();

  if (ftz) {
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
  }
  RTCDevice device = rtcNewDevice(config);
  if (!device) {
    fprintf(stderr, "rtcNewDevice(\"%s\") failed: error %d\n", config,
            (int)rtcGetDeviceError(NULL));
    return 1;
  }
  rtcSetDeviceErrorFunction(device, on_error, NULL);
  rtcSetDeviceMemoryMonitorFunction(device, on_memory, NULL);
  printf("# Embree %zd.%zd.%zd, device config \"%s\"%s%s, native ray4/8/16 %zd/%zd/%zd, "
         "tracing on 1 thread with rtcIntersect1\n",
         rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_VERSION_MAJOR),
         rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_VERSION_MINOR),
         rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_VERSION_PATCH), config,
         robust ? ", robust" : "", ftz ? ", FTZ/DAZ on" : ", FTZ/DAZ off",
         rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_NATIVE_RAY4_SUPPORTED),
         rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED),
         rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED));

  for (; a < argc; a++) {
    const char *set = argv[a];
    size_t ntris, nrays, nt, np;
    float *tris = read_file(dir, set, "tris", 9 * sizeof(float), &ntris);
    float *rays = read_file(dir, set, "rays", 6 * sizeof(float), &nrays);
    float *ref_t = read_file(dir, set, "hits_t", sizeof(float), &nt);
    int32_t *ref_prim = read_file(dir, set, "hits_prim", sizeof(int32_t), &np);
    if (nt != nrays || np != nrays) {
      fprintf(stderr, "%s: %zu rays but %zu hits_t, %zu hits_prim\n", set, nrays, nt, np);
      return 1;
    }
    size_t n = max_rays >= 0 && (size_t)max_rays < nrays ? (size_t)max_rays : nrays;

    /* Verify the assumed ray layout: unit directions, reference hits in front of the origin. */
    double max_dir_err = 0.0;
    size_t ref_hits = 0, ref_bad = 0;
    for (size_t i = 0; i < nrays; i++) {
      const float *d = rays + 6 * i + 3;
      double len = sqrt((double)d[0] * d[0] + (double)d[1] * d[1] + (double)d[2] * d[2]);
      if (fabs(len - 1.0) > max_dir_err) max_dir_err = fabs(len - 1.0);
      int hit = ref_prim[i] >= 0;
      ref_hits += hit;
      if (hit != !isinf(ref_t[i]) || (hit && (ref_t[i] < 0 || (size_t)ref_prim[i] >= ntris)))
        ref_bad++;
    }
    printf("# %s: %zu tris, %zu rays (tracing %zu), max | |dir| - 1 | %.2e, reference hits "
           "%zu (%.2f%%), inconsistent reference entries %zu\n",
           set, ntris, nrays, n, max_dir_err, ref_hits, 100.0 * ref_hits / nrays, ref_bad);

    char qbuf[256];
    snprintf(qbuf, sizeof qbuf, "%s", qualities);
    for (char *save = NULL, *q = strtok_r(qbuf, ",", &save); q; q = strtok_r(NULL, ",", &save)) {
      enum RTCBuildQuality quality;
      if (!strcmp(q, "high")) quality = RTC_BUILD_QUALITY_HIGH;
      else if (!strcmp(q, "medium")) quality = RTC_BUILD_QUALITY_MEDIUM;
      else if (!strcmp(q, "low")) quality = RTC_BUILD_QUALITY_LOW;
      else {
        fprintf(stderr, "unknown quality %s\n", q);
        return 2;
      }

      /* Build: geometry buffers + scene commit (what stokes' Accel::build covers, too). */
      int64_t mem0 = __atomic_load_n(&mem_bytes, __ATOMIC_RELAXED);
      double t0 = now_s();
      RTCScene scene = rtcNewScene(device);
      rtcSetSceneBuildQuality(scene, quality);
      if (robust) rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST);
      RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
      rtcSetGeometryBuildQuality(geom, quality);
      /* Shared buffers: no copy, Embree reads our arrays (the vertex array has 16 bytes of
       * padding from read_file). */
      rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, tris, 0,
                                 3 * sizeof(float), 3 * ntris);
      uint32_t *idx = malloc(3 * ntris * sizeof(uint32_t));
      for (size_t i = 0; i < 3 * ntris; i++) idx[i] = (uint32_t)i;
      rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, idx, 0,
                                 3 * sizeof(uint32_t), ntris);
      rtcCommitGeometry(geom);
      rtcAttachGeometry(scene, geom);
      rtcReleaseGeometry(geom);
      rtcCommitScene(scene);
      double build_ms = (now_s() - t0) * 1e3;
      double bvh_kib = (double)(__atomic_load_n(&mem_bytes, __ATOMIC_RELAXED) - mem0) / 1024.0;

      /* Timed rounds. */
      double *mrays = malloc(rounds * sizeof(double));
      double chk = 0.0;
      for (int r = 0; r < rounds; r++) {
        double s0 = now_s();
        chk = trace_all(scene, rays, n);
        mrays[r] = n / (now_s() - s0) * 1e-6;
      }
      double *sorted = malloc(rounds * sizeof(double));
      memcpy(sorted, mrays, rounds * sizeof(double));
      qsort(sorted, rounds, sizeof(double), cmp_double);
      double median = rounds % 2 ? sorted[rounds / 2]
                                 : 0.5 * (sorted[rounds / 2 - 1] + sorted[rounds / 2]);
      printf("embree %s quality=%s tris=%zu rays=%zu build_ms=%.2f bvh_kib=%.1f median %.3f "
             "Mrays/s best %.3f Mrays/s rounds",
             set, q, ntris, n, build_ms, bvh_kib, median, sorted[rounds - 1]);
      for (int r = 0; r < rounds; r++) printf(" %.3f", mrays[r]);
      printf(" chk %.3f\n", chk);

      /* Check against the reference hits (untimed). */
      size_t hitmiss = 0, t_bad = 0, t_bad_strict = 0, prim_bad = 0, ties = 0;
      struct RTCIntersectContext ctx;
      rtcInitIntersectContext(&ctx);
      for (size_t i = 0; i < n; i++) {
        struct RTCRayHit rh;
        init_rayhit(&rh, rays + 6 * i);
        rtcIntersect1(scene, &ctx, &rh);
        int hit = rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
        float t = hit ? rh.ray.tfar : INFINITY;
        int32_t prim = hit ? (int32_t)rh.hit.primID : -1;
        if (hit != (ref_prim[i] >= 0)) {
          hitmiss++;
          t_bad++;
          t_bad_strict++;
          continue;
        }
        t_bad_strict += !t_close(t, ref_t[i], 0.0f);
        if (!t_close(t, ref_t[i], ABS_EPS)) {
          t_bad++;
          continue;
        }
        if (prim != ref_prim[i]) {
          float t2 = tri_t(tris + 9 * (size_t)ref_prim[i], rays + 6 * i);
          if (t_close(t2, t, ABS_EPS)) ties++;
          else prim_bad++;
        }
      }
      printf("check %s quality=%s n=%zu hit_miss_mismatch=%zu t_mismatch=%zu "
             "t_mismatch_strict=%zu prim_mismatch=%zu prim_ties=%zu\n",
             set, q, n, hitmiss, t_bad, t_bad_strict, prim_bad, ties);
      fflush(stdout);

      free(mrays);
      free(sorted);
      rtcReleaseScene(scene);
      free(idx);
    }
    free(tris);
    free(rays);
    free(ref_t);
    free(ref_prim);
  }
  rtcReleaseDevice(device);
  return 0;
}
