/* Traces the rays that `penumbra bench rays --export DIR` wrote with Intel Embree (one
 * rtcOccluded1 call per ray, no packets), for a side-by-side speed comparison with penumbra's
 * reference tracer. Built and run by tools/compare_embree.py.
 *
 * usage: embree_rays DIR THREADS REPS
 * prints: build_ms, mrays_per_s (median of REPS), occluded count of one repetition. */
#include <embree3/rtcore.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

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
static int threads;

typedef struct { int id; long occluded; } Job;

static void *work(void *arg) {
    Job *j = arg;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    size_t per = (traced + threads - 1) / threads;
    size_t a = per * j->id, b = a + per < traced ? a + per : traced;
    long occ = 0;
    for (size_t i = a; i < b; i++) {
        const float *r = rays + 7 * (i % nrays);
        struct RTCRay ray;
        ray.org_x = r[0]; ray.org_y = r[1]; ray.org_z = r[2];
        ray.dir_x = r[3]; ray.dir_y = r[4]; ray.dir_z = r[5];
        ray.tnear = 0.0f; ray.tfar = r[6];
        ray.time = 0.0f; ray.mask = 0xffffffffu; ray.id = 0; ray.flags = 0;
        rtcOccluded1(scene, &ctx, &ray);
        occ += ray.tfar < 0.0f;
    }
    j->occluded = occ;
    return NULL;
}

static int cmp(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv) {
    if (argc != 4) { fprintf(stderr, "usage: %s DIR THREADS REPS\n", argv[0]); return 2; }
    const char *dir = argv[1];
    threads = atoi(argv[2]);
    int reps = atoi(argv[3]);
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
    double builds[3];
    for (int k = 0; k < 3; k++) {
        double t0 = now();
        scene = rtcNewScene(dev);
        RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
        float *vb = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 3 * ntri);
        unsigned *ib = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), ntri);
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
