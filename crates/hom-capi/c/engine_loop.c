/* hom-occlusion's `engine_loop` example through hom's C ABI: the same city,
 * walk and work, to measure what the C ABI costs against the Rust front door
 * (`scripts/c-api-check.sh --bench` runs both).
 *
 * A 12 x 12 grid of box buildings and 1,728 small props; a camera walks down
 * a street with a reversed-Z, infinite-far projection, as modern engines
 * use. Every frame: clear the buffer, draw the 24 nearest buildings as
 * occluders (each one convex box, drawn as its shrunk outline), test every
 * building and prop, and the clusters of the 125,000-triangle ground (cut
 * once at load), counting what would not be drawn.
 *
 *   cc -O2 -Icrates/hom-capi/include crates/hom-capi/c/engine_loop.c \
 *      target/release/libhom_capi.a -lpthread -ldl -lm -o engine_loop && ./engine_loop
 */
#define _POSIX_C_SOURCE 199309L /* clock_gettime under -std=c11 */
#include "hom.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef struct {
    float min[3], max[3];
} Box;

/* Column-major c = a * b. */
static void mul(const float a[16], const float b[16], float c[16]) {
    for (int col = 0; col < 4; col++)
        for (int row = 0; row < 4; row++) {
            float s = 0;
            for (int k = 0; k < 4; k++) s += a[k * 4 + row] * b[col * 4 + k];
            c[col * 4 + row] = s;
        }
}

static void sub3(const float a[3], const float b[3], float c[3]) {
    for (int i = 0; i < 3; i++) c[i] = a[i] - b[i];
}
static float dot3(const float a[3], const float b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static void cross3(const float a[3], const float b[3], float c[3]) {
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}
static void normalize3(float a[3]) {
    const float l = sqrtf(dot3(a, a));
    for (int i = 0; i < 3; i++) a[i] /= l;
}

/* Right-handed look-at (glam's look_at_rh). */
static void look_at(const float eye[3], const float target[3], float m[16]) {
    const float up[3] = {0, 1, 0};
    float f[3], s[3], u[3];
    sub3(target, eye, f);
    normalize3(f);
    cross3(f, up, s);
    normalize3(s);
    cross3(s, f, u);
    const float cols[16] = {s[0], u[0], -f[0], 0, s[1], u[1], -f[1], 0, s[2], u[2], -f[2], 0,
                            -dot3(s, eye), -dot3(u, eye), dot3(f, eye), 1};
    memcpy(m, cols, sizeof cols);
}

/* Reversed Z, infinite far plane: clip z = near, clip w = -z_view. */
static void reversed_infinite(float fov_y, float aspect, float near, float m[16]) {
    const float f = 1.0f / tanf(fov_y * 0.5f);
    memset(m, 0, 16 * sizeof(float));
    m[0] = f / aspect;
    m[5] = f;
    m[11] = -1.0f;
    m[14] = near;
}

/* The model matrix placing the unit cube on `b`. */
static void box_model(const Box *b, float m[16]) {
    memset(m, 0, 16 * sizeof(float));
    m[0] = b->max[0] - b->min[0];
    m[5] = b->max[1] - b->min[1];
    m[10] = b->max[2] - b->min[2];
    m[12] = b->min[0];
    m[13] = b->min[1];
    m[14] = b->min[2];
    m[15] = 1.0f;
}

/* Squared distance from `p` to the box (0 inside). */
static float distance_squared(const Box *b, const float p[3]) {
    float d = 0;
    for (int i = 0; i < 3; i++) {
        const float below = b->min[i] - p[i], above = p[i] - b->max[i];
        const float e = below > 0 ? below : above > 0 ? above : 0;
        d += e * e;
    }
    return d;
}

/* The same xorshift as the Rust example, so the city is the same. */
static unsigned long long seed = 0x2545F4914F6CDD1DULL;
static float rnd(void) {
    seed ^= seed << 13;
    seed ^= seed >> 7;
    seed ^= seed << 17;
    return (float)(seed >> 40) / 16777216.0f;
}

typedef struct {
    float d;
    int k;
} Near;
static int by_distance(const void *a, const void *b) {
    const Near *x = a, *y = b;
    if (x->d != y->d) return x->d < y->d ? -1 : 1;
    return x->k - y->k; /* as Rust's stable sort */
}

enum { BLOCKS = 12, PROPS_PER_BLOCK = 12, GROUND_QUADS = 250, NEAREST = 24 };

int main(int argc, char **argv) {
    static const float cube[24] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 0, 1, 1, 0, 1, 0, 1, 1, 1, 1, 1};
    static const uint32_t tris[36] = {0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1,
                                      2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3};
    /* Buildings first, then props: one array, tested in one call. */
    static Box things[BLOCKS * BLOCKS * (1 + PROPS_PER_BLOCK)];
    static int32_t answers[BLOCKS * BLOCKS * (1 + PROPS_PER_BLOCK)];
    const int nb = BLOCKS * BLOCKS;
    int np = 0;
    for (int i = 0; i < BLOCKS; i++) {
        for (int j = 0; j < BLOCKS; j++) {
            const float x = (float)i * 40.0f - 240.0f, z = (float)j * -40.0f;
            const float height = 8.0f + rnd() * 40.0f;
            things[i * BLOCKS + j] = (Box){{x, 0, z - 28.0f}, {x + 28.0f, height, z}};
            for (int k = 0; k < PROPS_PER_BLOCK; k++) {
                /* One draw at a time: C leaves an initializer's order open. */
                const float px = x - 6.0f + rnd() * 40.0f;
                const float pz = z + 6.0f - rnd() * 40.0f;
                const float sx = 0.5f + rnd(), sy = 0.5f + rnd();
                const float sz = 0.5f + rnd();
                things[nb + np++] = (Box){{px, 0, pz}, {px + sx, sy, pz + sz}};
            }
        }
    }
    /* Rolling ground over x -260..240, z -480..20 in 2 m quads: one mesh of 125,000 triangles. */
    const int n = GROUND_QUADS, nv = (n + 1) * (n + 1), nt = 2 * n * n;
    float *ground = malloc(sizeof(float) * 3 * (size_t)nv);
    uint32_t *ground_tris = malloc(sizeof(uint32_t) * 3 * (size_t)nt);
    HomCluster *clusters = NULL;
    if (!ground || !ground_tris) return 1;
    for (int j = 0; j <= n; j++)
        for (int i = 0; i <= n; i++) {
            float *p = ground + 3 * (j * (n + 1) + i);
            p[0] = -260.0f + 2.0f * (float)i;
            p[1] = 0.15f * (sinf((float)i * 0.3f) + cosf((float)j * 0.2f)) - 0.3f;
            p[2] = -480.0f + 2.0f * (float)j;
        }
    for (int j = 0, t = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            const uint32_t a = (uint32_t)(j * (n + 1) + i), b = a + (uint32_t)(n + 1);
            const uint32_t quad[6] = {a, b, a + 1, a + 1, b, b + 1};
            memcpy(ground_tris + 6 * t++, quad, sizeof quad);
        }
    /* Cut once at load: at most 64 triangles and 16 m a cluster. First ask how many. */
    const int64_t count = hom_cluster_triangles(ground, (size_t)nv, 12, ground_tris, 3 * (size_t)nt, 64, 16.0f, NULL, 0, NULL);
    if (count < 0) {
        fprintf(stderr, "hom_cluster_triangles: %s\n", hom_last_error());
        return 1;
    }
    clusters = malloc(sizeof(HomCluster) * (size_t)count);
    Box *cluster_boxes = malloc(sizeof(Box) * (size_t)count);
    int32_t *cluster_answers = malloc(sizeof(int32_t) * (size_t)count);
    if (!clusters || !cluster_boxes || !cluster_answers) return 1;
    if (hom_cluster_triangles(ground, (size_t)nv, 12, ground_tris, 3 * (size_t)nt, 64, 16.0f, clusters,
                              (size_t)count, NULL) != count)
        return 1;
    for (int64_t c = 0; c < count; c++) cluster_boxes[c] = (Box){{clusters[c].min[0], clusters[c].min[1], clusters[c].min[2]},
                                                                   {clusters[c].max[0], clusters[c].max[1], clusters[c].max[2]}};

    const uint32_t width = 640, height = 360;
    HomBuffer *buffer = hom_buffer_new(width, height, HOM_CLIP_REVERSED_Z);
    if (!buffer) {
        fprintf(stderr, "hom_buffer_new: %s\n", hom_last_error());
        return 1;
    }
    float proj[16], view[16], view_proj[16], model[16], mvp[16];
    reversed_infinite(1.0f, (float)width / (float)height, 0.1f, proj);
    const int frames = argc > 1 ? atoi(argv[1]) : 240; /* ./engine_loop [FRAMES] */
    if (frames < 1) {
        fprintf(stderr, "usage: %s [FRAMES >= 1]\n", argv[0]);
        return 2;
    }
    static Near near[BLOCKS * BLOCKS];
    long drawn = 0, tested = 0, ground_drawn = 0;
    double cull_ms = 0;
    for (int frame = 0; frame < frames; frame++) {
        const float t = (float)frame / (float)frames;
        const float eye[3] = {-206.0f, 1.7f, 10.0f - t * 440.0f};
        const float target[3] = {eye[0] + sinf(t * 9.0f) * 0.3f, eye[1], eye[2] - 1.0f};
        look_at(eye, target, view);
        mul(proj, view, view_proj);

        struct timespec t0, t1;
        clock_gettime(CLOCK_MONOTONIC, &t0);
        if (hom_buffer_clear(buffer) != 0) return 1;
        for (int k = 0; k < nb; k++) near[k] = (Near){distance_squared(&things[k], eye), k};
        qsort(near, (size_t)nb, sizeof(Near), by_distance);
        for (int k = 0; k < NEAREST; k++) {
            box_model(&things[near[k].k], model);
            mul(view_proj, model, mvp);
            if (hom_buffer_render_convex_stand_in(buffer, cube, 8, 12, tris, 36, mvp) != 0) {
                fprintf(stderr, "render: %s\n", hom_last_error());
                return 1;
            }
        }
        if (hom_buffer_test_aabbs(buffer, &things[0].min[0], (size_t)(nb + np), view_proj, answers) != 0 ||
            hom_buffer_test_aabbs(buffer, &cluster_boxes[0].min[0], (size_t)count, view_proj, cluster_answers) != 0) {
            fprintf(stderr, "test: %s\n", hom_last_error());
            return 1;
        }
        long visible = 0, ground_visible = 0;
        for (int k = 0; k < nb + np; k++) visible += answers[k] == HOM_VISIBLE;
        for (int64_t c = 0; c < count; c++)
            if (cluster_answers[c] == HOM_VISIBLE) ground_visible += clusters[c].triangle_count;
        clock_gettime(CLOCK_MONOTONIC, &t1);
        cull_ms += (double)(t1.tv_sec - t0.tv_sec) * 1e3 + (double)(t1.tv_nsec - t0.tv_nsec) / 1e6;
        drawn += visible;
        tested += nb + np;
        ground_drawn += ground_visible;
    }
    printf("hom C engine_loop: %d frames: %.1f %% of the objects drawn, %.1f %% of the ground's triangles "
           "(%lld clusters), %.3f ms culling per frame\n",
           frames, 100.0 * (double)drawn / (double)tested, 100.0 * (double)ground_drawn / ((double)frames * nt),
           (long long)count, cull_ms / frames);
    hom_buffer_free(buffer);
    free(ground);
    free(ground_tris);
    free(clusters);
    free(cluster_boxes);
    free(cluster_answers);
    return 0;
}
