/* Traces the rays that `penumbra bench rays --export DIR` wrote with Intel Embree, for a
 * side-by-side speed comparison with penumbra's reference tracer. Built and run by
 * tools/compare_embree.py.
 *
 * Embree 4 (default): the shared library of the `embreex` wheel on PyPI, which ships no C
 * headers: the few entry points and the ray layouts used here are declared below from Embree
 * 4's API manual. Single rays (rtcOccluded1, one call per ray) or packets of 8 or 16
 * consecutive rays (rtcOccluded8/16: the exported shadow rays are in pixel order, so a packet
 * is 8 or 16 neighbouring pixels of a row).
 * Embree 3 (-DEMBREE3, with Debian's <embree3/rtcore.h>): single rays only.
 * `robust` builds the scene with RTC_SCENE_FLAG_ROBUST (robust traversal, no optimisation
 * that reduces arithmetic accuracy: the Embree mode closest to penumbra's reference, whose
 * traversal is always robust and whose triangle test is watertight).
 *
 * usage: embree_rays DIR THREADS REPS [1|8|16] [robust]
 * prints: build_ms, mrays_per_s (median of REPS), occluded count of one repetition. */
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#ifdef EMBREE3
#include <embree3/rtcore.h>
enum { GEOMETRY_TRIANGLE = RTC_GEOMETRY_TYPE_TRIANGLE, BUFFER_INDEX = RTC_BUFFER_TYPE_INDEX,
       BUFFER_VERTEX = RTC_BUFFER_TYPE_VERTEX, FORMAT_UINT3 = RTC_FORMAT_UINT3, FORMAT_FLOAT3 = RTC_FORMAT_FLOAT3 };
#define Ray1 RTCRay
struct Ray8 { int unused; };
struct Ray16 { int unused; };
#else
/* Embree 4 API (rtcore.h), the part this program calls. */
typedef struct RTCDeviceTy *RTCDevice;
typedef struct RTCSceneTy *RTCScene;
typedef struct RTCGeometryTy *RTCGeometry;
enum { GEOMETRY_TRIANGLE = 0, BUFFER_INDEX = 0, BUFFER_VERTEX = 1, FORMAT_UINT3 = 0x5003, FORMAT_FLOAT3 = 0x9003 };
enum { RTC_SCENE_FLAG_ROBUST = 1 << 2 };
struct __attribute__((aligned(16))) Ray1 {
    float org_x, org_y, org_z, tnear, dir_x, dir_y, dir_z, time, tfar;
    unsigned mask, id, flags;
};
#define PACKET(N) struct __attribute__((aligned(4 * N))) Ray##N { \
    float org_x[N], org_y[N], org_z[N], tnear[N], dir_x[N], dir_y[N], dir_z[N], time[N], tfar[N]; \
    unsigned mask[N], id[N], flags[N]; }
PACKET(8);
PACKET(16);
RTCDevice rtcNewDevice(const char *config);
RTCScene rtcNewScene(RTCDevice device);
RTCGeometry rtcNewGeometry(RTCDevice device, int type);
void *rtcSetNewGeometryBuffer(RTCGeometry g, int type, unsigned slot, int format, size_t stride, size_t count);
void rtcCommitGeometry(RTCGeometry g);
unsigned rtcAttachGeometry(RTCScene scene, RTCGeometry g);
void rtcReleaseGeometry(RTCGeometry g);
void rtcSetSceneFlags(RTCScene scene, int flags);
void rtcCommitScene(RTCScene scene);
void rtcReleaseScene(RTCScene scene);
void rtcOccluded1(RTCScene scene, struct Ray1 *ray, void *args);
void rtcOccluded8(const int *valid, RTCScene scene, struct Ray8 *ray, void *args);
void rtcOccluded16(const int *valid, RTCScene scene, struct Ray16 *ray, void *args);
#endif

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + t.tv_nsec * 1e-9;
}

static void *slurp(const char *dir, const char *name, size_t *len) {
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "rb");
    if (!f) { perror(path); exit(1); }
    fseek(f, 0, SEEK_END);
    *len = (size_t)ftell(f);
    fseek(f, 0, SEEK_SET);
    void *p = malloc(*len);
    if (fread(p, 1, *len, f) != *len) { perror(path); exit(1); }
    fclose(f);
    return p;
}

static RTCScene scene;
static const float *rays;
static size_t nrays, traced;
static int threads, width;

typedef struct { int id; long occluded; } Job;

/* Packets of N rays: one thread takes whole packets (its range is rounded to N). */
#define TRACE_PACKETS(N) do { \
    struct Ray##N p; int valid[N]; \
    for (size_t i = a; i < b; i += N) { \
        for (int k = 0; k < N; k++) { \
            size_t r = i + k; \
            valid[k] = r < b ? -1 : 0; \
            const float *q = rays + 7 * ((r < b ? r : i) % nrays); \
            p.org_x[k] = q[0]; p.org_y[k] = q[1]; p.org_z[k] = q[2]; \
            p.dir_x[k] = q[3]; p.dir_y[k] = q[4]; p.dir_z[k] = q[5]; \
            p.tnear[k] = 0.0f; p.tfar[k] = q[6]; p.time[k] = 0.0f; \
            p.mask[k] = 0xffffffffu; p.id[k] = 0; p.flags[k] = 0; \
        } \
        rtcOccluded##N(valid, scene, &p, NULL); \
        for (int k = 0; k < N; k++) occ += valid[k] && p.tfar[k] < 0.0f; \
    } } while (0)

static void *work(void *arg) {
    Job *j = arg;
#ifdef EMBREE3
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
#define OCCLUDED1(s, r) rtcOccluded1(s, &ctx, r)
#else
#define OCCLUDED1(s, r) rtcOccluded1(s, r, NULL)
#endif
    size_t per = (traced + threads - 1) / threads;
    per = (per + 15) / 16 * 16;
    size_t a = per * j->id, b = a + per < traced ? a + per : traced;
    long occ = 0;
    if (width == 1) {
        for (size_t i = a; i < b; i++) {
            const float *r = rays + 7 * (i % nrays);
            struct Ray1 ray = { r[0], r[1], r[2], 0.0f, r[3], r[4], r[5], 0.0f, r[6], 0xffffffffu, 0, 0 };
            OCCLUDED1(scene, &ray);
            occ += ray.tfar < 0.0f;
        }
    }
#ifndef EMBREE3
    else if (width == 8) {
        TRACE_PACKETS(8);
    } else {
        TRACE_PACKETS(16);
    }
#endif
    j->occluded = occ;
    return NULL;
}

static int cmp(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv) {
    if (argc < 4) { fprintf(stderr, "usage: %s DIR THREADS REPS [1|8|16] [robust]\n", argv[0]); return 2; }
    const char *dir = argv[1];
    threads = atoi(argv[2]);
    int reps = atoi(argv[3]);
    width = argc > 4 ? atoi(argv[4]) : 1;
    int robust = argc > 5 && strcmp(argv[5], "robust") == 0;
    if (argc > 6 || (argc > 5 && !robust)) { fprintf(stderr, "bad arguments\n"); return 2; }
#ifdef EMBREE3
    if (width != 1) { fprintf(stderr, "Embree 3: single rays only\n"); return 2; }
#endif
    if (threads < 1 || threads > 64 || reps < 1 || (width != 1 && width != 8 && width != 16)) {
        fprintf(stderr, "bad arguments\n");
        return 2;
    }
    size_t tl, rl, il;
    float *tri = slurp(dir, "triangles.f32", &tl);
    rays = slurp(dir, "rays.f32", &rl);
    char *info = slurp(dir, "rays.txt", &il);
    nrays = rl / 28;
    const char *t = strstr(info, "traced ");
    traced = t ? strtoull(t + 7, NULL, 10) : nrays;
    size_t ntri = tl / 36;

    char cfg[64];
    snprintf(cfg, sizeof cfg, "threads=%d", threads);
    RTCDevice dev = rtcNewDevice(cfg);
    if (!dev) { fprintf(stderr, "rtcNewDevice failed\n"); return 1; }
    double builds[3];
    for (int k = 0; k < 3; k++) {
        double t0 = now();
        scene = rtcNewScene(dev);
        if (robust) rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST);
        RTCGeometry g = rtcNewGeometry(dev, GEOMETRY_TRIANGLE);
        float *vb = rtcSetNewGeometryBuffer(g, BUFFER_VERTEX, 0, FORMAT_FLOAT3, 3 * sizeof(float), 3 * ntri);
        unsigned *ib = rtcSetNewGeometryBuffer(g, BUFFER_INDEX, 0, FORMAT_UINT3, 3 * sizeof(unsigned), ntri);
        memcpy(vb, tri, tl);
        for (size_t i = 0; i < 3 * ntri; i++) ib[i] = (unsigned)i;
        rtcCommitGeometry(g);
        rtcAttachGeometry(scene, g);
        rtcReleaseGeometry(g);
        rtcCommitScene(scene);
        builds[k] = (now() - t0) * 1e3;
        if (k < 2) rtcReleaseScene(scene);
    }
    qsort(builds, 3, sizeof(double), cmp);

    double *times = malloc(sizeof(double) * (reps + 1));
    long occluded = 0;
    for (int k = 0; k <= reps; k++) {
        pthread_t th[64];
        Job jobs[64];
        double t0 = now();
        for (int i = 0; i < threads; i++) { jobs[i].id = i; pthread_create(&th[i], NULL, work, &jobs[i]); }
        occluded = 0;
        for (int i = 0; i < threads; i++) { pthread_join(th[i], NULL); occluded += jobs[i].occluded; }
        times[k] = now() - t0; /* k = 0 is the warm-up */
    }
    qsort(times + 1, reps, sizeof(double), cmp);
    double s = times[1 + reps / 2];
    printf("build_ms %.2f\nmrays_per_s %.3f\noccluded %ld\ntriangles %zu\nrays %zu\n", builds[1], traced / s / 1e6, occluded, ntri, traced);
    return 0;
}
