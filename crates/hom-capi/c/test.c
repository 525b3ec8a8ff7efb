/* The C contract of hom's C ABI, from C: a wall hides a box behind it, not
 * one in front; a box behind the camera is view-culled; misuse returns a code
 * and a message, never a crash. Built with `cc -Wall -Wextra -Werror` and run
 * by scripts/c-api-check.sh (CI). */
#include "hom.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

static int failures = 0;

#define CHECK(cond, what)                                                      \
    do {                                                                       \
        if (!(cond)) {                                                         \
            fprintf(stderr, "FAIL %s:%d: %s (last error: %s)\n", __FILE__,     \
                    __LINE__, what, hom_last_error());                         \
            failures++;                                                        \
        }                                                                      \
    } while (0)

/* A column-major perspective for a camera at the origin looking down -z:
 * x and y scaled by f / aspect and f, clip z = z_ndc in [0, 1] (near 0.1, far 100). */
static void perspective(float m[16]) {
    const float f = 1.0f / tanf(0.5f), aspect = 4.0f / 3.0f, n = 0.1f, far = 100.0f;
    memset(m, 0, 16 * sizeof(float));
    m[0] = f / aspect;
    m[5] = f;
    m[10] = far / (n - far);
    m[11] = -1.0f;
    m[14] = n * far / (n - far);
}

int main(void) {
    float view_proj[16];
    perspective(view_proj);
    /* A 20 m x 10 m wall at z = -10, positions with a fourth float (stride 16). */
    const float wall[16] = {-10, -5, -10, 0, 10, -5, -10, 0, 10, 5, -10, 0, -10, 5, -10, 0};
    const uint32_t quad[6] = {0, 1, 2, 0, 2, 3};
    const float behind_min[3] = {-1, -1, -20}, behind_max[3] = {1, 1, -15};
    const float front_min[3] = {-1, -1, -6}, front_max[3] = {1, 1, -4};
    const float back_min[3] = {-1, -1, 5}, back_max[3] = {1, 1, 8};
    const float nan_min[3] = {NAN, -1, -20};

    HomBuffer *b = hom_buffer_new(320, 240, HOM_CLIP_ZERO_TO_ONE);
    CHECK(b != NULL, "hom_buffer_new");
    for (int frame = 0; frame < 3; frame++) {
        CHECK(hom_buffer_clear(b) == 0, "clear");
        CHECK(hom_buffer_render_triangles(b, wall, 4, 16, quad, 6, view_proj) == 0, "render");
        CHECK(hom_buffer_test_aabb(b, behind_min, behind_max, view_proj) == HOM_OCCLUDED, "behind the wall");
        CHECK(hom_buffer_test_aabb(b, front_min, front_max, view_proj) == HOM_VISIBLE, "in front of the wall");
        CHECK(hom_buffer_test_aabb(b, back_min, back_max, view_proj) == HOM_VIEW_CULLED, "behind the camera");
        CHECK(hom_buffer_test_aabb(b, nan_min, behind_max, view_proj) == HOM_VISIBLE, "a NaN box is visible");
    }
    HomBufferStats stats;
    CHECK(hom_buffer_stats(b, &stats) == 0 && stats.triangles_submitted == 2 && stats.tests == 3,
          "stats since the last clear");

    /* Misuse. */
    const float nan_matrix[16] = {NAN};
    const uint32_t far_index[3] = {0, 1, 9};
    CHECK(hom_buffer_render_triangles(b, NULL, 4, 16, quad, 6, view_proj) == HOM_ERROR_NULL, "NULL positions");
    CHECK(strstr(hom_last_error(), "positions is NULL") != NULL, "its message");
    CHECK(hom_buffer_render_triangles(b, wall, 4, 0, quad, 6, view_proj) == HOM_ERROR_INVALID, "zero stride");
    CHECK(hom_buffer_render_triangles(b, wall, 4, 16, quad, 5, view_proj) == HOM_ERROR_INVALID, "5 indices");
    CHECK(hom_buffer_render_triangles(b, wall, 4, 16, far_index, 3, view_proj) == HOM_ERROR_INVALID,
          "index out of range");
    CHECK(strstr(hom_last_error(), "vertex 9") != NULL || strstr(hom_last_error(), "9") != NULL, "names it");
    CHECK(hom_buffer_render_triangles(b, wall, 4, 16, quad, 6, nan_matrix) == HOM_ERROR_INVALID, "NaN matrix");
    CHECK(hom_buffer_test_aabb(NULL, behind_min, behind_max, view_proj) == HOM_ERROR_NULL, "NULL buffer");
    CHECK(hom_buffer_clear(NULL) == HOM_ERROR_NULL, "NULL clear");
    CHECK(hom_buffer_new(0, 240, HOM_CLIP_ZERO_TO_ONE) == NULL, "zero width");
    CHECK(hom_buffer_new(320, 240, 42) == NULL, "unknown clip convention");
    CHECK(hom_buffer_new_kind(42, 320, 240, HOM_CLIP_ZERO_TO_ONE) == NULL, "unknown kind");
    CHECK(strstr(hom_last_error(), "kind 42") != NULL, "names the kind");
    hom_buffer_free(b);
    hom_buffer_free(NULL);

    /* Every kind answers the wall the same. */
    const int kinds[3] = {HOM_KIND_HZB, HOM_KIND_HOM, HOM_KIND_MASKED};
    for (int k = 0; k < 3; k++) {
        HomBuffer *kb = hom_buffer_new_kind(kinds[k], 320, 240, HOM_CLIP_ZERO_TO_ONE);
        CHECK(kb != NULL, "hom_buffer_new_kind");
        hom_buffer_clear(kb);
        CHECK(hom_buffer_render_triangles(kb, wall, 4, 16, quad, 6, view_proj) == 0, "render");
        CHECK(hom_buffer_test_aabb(kb, behind_min, behind_max, view_proj) == HOM_OCCLUDED, "kind: behind");
        CHECK(hom_buffer_test_aabb(kb, front_min, front_max, view_proj) == HOM_VISIBLE, "kind: in front");
        hom_buffer_free(kb);
    }
    if (failures) {
        fprintf(stderr, "hom C test: %d failures\n", failures);
        return 1;
    }
    printf("hom C test: all checks passed\n");
    return 0;
}
