/* A game-style loop through hom's C ABI: a street of box buildings and small
 * props, a camera walking down it with a reversed-Z, infinite-far projection
 * (as modern engines use). Every frame: clear, draw the buildings within 60 m
 * as occluders, test every building and prop, count what would not be drawn.
 *
 *   cc -O2 -Icrates/hom-capi/include crates/hom-capi/c/example.c \
 *      target/release/libhom_capi.a -lpthread -ldl -lm -o engine_loop && ./engine_loop [FRAMES]
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

/* Right-handed look-at from `eye` towards -z (and a little to the side). */
static void view_matrix(const float eye[3], float m[16]) {
    memset(m, 0, 16 * sizeof(float));
    m[0] = m[5] = m[10] = m[15] = 1.0f;
    m[12] = -eye[0];
    m[13] = -eye[1];
    m[14] = -eye[2];
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

enum { ROWS = 60, PROPS_PER_ROW = 20 };

int main(int argc, char **argv) {
    static const float cube[24] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 0, 1, 1, 0, 1, 0, 1, 1, 1, 1, 1};
    static const uint32_t tris[36] = {0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1,
                                      2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3};
    static Box buildings[2 * ROWS], props[2 * ROWS * PROPS_PER_ROW];
    static int32_t answers[2 * ROWS * (1 + PROPS_PER_ROW)];
    int nb = 0, np = 0;
    unsigned seed = 12345;
    for (int r = 0; r < ROWS; r++) {
        for (int side = -1; side <= 1; side += 2) {
            const float z0 = -12.0f * (float)r, x0 = side < 0 ? -26.0f : 6.0f;
            seed = seed * 1103515245u + 12345u;
            const float h = 8.0f + (float)(seed >> 16 & 31);
            buildings[nb++] = (Box){{x0, 0, z0 - 10}, {x0 + 20, h, z0}};
            for (int k = 0; k < PROPS_PER_ROW; k++) {
                const float x = (side < 0 ? -40.0f : 28.0f) + (float)(k % 5) * 2.5f;
                const float z = z0 - 2.0f * (float)(k / 5);
                props[np++] = (Box){{x, 0, z - 1}, {x + 1, 2, z}};
            }
        }
    }
    HomBuffer *buffer = hom_buffer_new(1024, 768, HOM_CLIP_REVERSED_Z);
    if (!buffer) {
        fprintf(stderr, "hom_buffer_new: %s\n", hom_last_error());
        return 1;
    }
    float proj[16], view[16], view_proj[16], model[16], mvp[16];
    reversed_infinite(1.0f, 1024.0f / 768.0f, 0.1f, proj);
    long culled = 0, tested = 0;
    const int frames = argc > 1 ? atoi(argv[1]) : 120; /* ./engine_loop [FRAMES] */
    if (frames < 1) {
        fprintf(stderr, "usage: %s [FRAMES >= 1]\n", argv[0]);
        return 2;
    }
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    for (int frame = 0; frame < frames; frame++) {
        const float eye[3] = {0.0f, 1.7f, 5.0f - 4.0f * (float)frame};
        view_matrix(eye, view);
        mul(proj, view, view_proj);
        if (hom_buffer_clear(buffer) != 0) return 1;
        for (int i = 0; i < nb; i++) {
            const float dz = eye[2] - buildings[i].max[2];
            if (dz < -10.0f || dz > 60.0f) continue; /* behind the camera, or far: no occluder */
            box_model(&buildings[i], model);
            mul(view_proj, model, mvp);
            if (hom_buffer_render_triangles(buffer, cube, 8, 12, tris, 36, mvp) != 0) {
                fprintf(stderr, "render: %s\n", hom_last_error());
                return 1;
            }
        }
        /* Every building and prop in one call (hom_buffer_test_aabb asks one). */
        if (hom_buffer_test_aabbs(buffer, &buildings[0].min[0], (size_t)nb, view_proj, answers) != 0 ||
            hom_buffer_test_aabbs(buffer, &props[0].min[0], (size_t)np, view_proj, answers + nb) != 0) {
            fprintf(stderr, "test: %s\n", hom_last_error());
            return 1;
        }
        for (int i = 0; i < nb + np; i++) {
            culled += answers[i] != HOM_VISIBLE;
            tested++;
        }
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    const double ms = (double)(t1.tv_sec - t0.tv_sec) * 1e3 + (double)(t1.tv_nsec - t0.tv_nsec) / 1e6;
    printf("hom C example: %d frames, %d buildings and %d props, %.1f %% not drawn (occluded or out of view), "
           "%.3f ms a frame\n",
           frames, nb, np, 100.0 * (double)culled / (double)tested, ms / frames);
    hom_buffer_free(buffer);
    return 0;
}
