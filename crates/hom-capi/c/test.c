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
    /* A scene: a wall and two boxes, one behind it; every culler kind keeps the
     * wall and the box in front, and the occlusion cullers cull the one behind. */
    {
        static const float cube[24] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 0, 1, 1, 0, 1, 0, 1, 1, 1, 1, 1};
        static const uint32_t tris[36] = {0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1,
                                          2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3};
        float wall_model[16] = {0}, behind_model[16] = {0}, front_model[16] = {0};
        /* Column-major scale-then-translate: a 20 x 10 x 1 wall at z = -11..-10. */
        wall_model[0] = 20, wall_model[5] = 10, wall_model[10] = 1, wall_model[15] = 1;
        wall_model[12] = -10, wall_model[13] = -5, wall_model[14] = -11;
        behind_model[0] = behind_model[5] = behind_model[10] = behind_model[15] = 1;
        behind_model[12] = -0.5f, behind_model[13] = -0.5f, behind_model[14] = -20;
        memcpy(front_model, behind_model, sizeof front_model);
        front_model[14] = -5;
        HomScene *scene = hom_scene_new();
        CHECK(scene != NULL, "hom_scene_new");
        CHECK(hom_scene_add_mesh(scene, cube, 8, 12, tris, 36) == 0, "add_mesh");
        CHECK(hom_scene_add_object(scene, 0, wall_model, 0) == 0, "wall");
        CHECK(hom_scene_add_object(scene, 0, behind_model, 0) == 1, "box behind");
        CHECK(hom_scene_add_object(scene, 0, front_model, 1) == 2, "box in front, dynamic");
        CHECK(hom_scene_add_object(scene, 5, front_model, 0) == HOM_ERROR_INVALID, "no mesh 5");
        CHECK(hom_scene_parent_of(scene, 2) == 2 && hom_scene_parent_of(scene, 3) == HOM_ERROR_INVALID,
              "objects added whole are their own parents");
        const int kinds[4] = {HOM_CULLER_FRUSTUM, HOM_CULLER_HOM, HOM_CULLER_HZB, HOM_CULLER_MASKED};
        for (int k = 0; k < 4; k++) {
            HomCuller *culler = hom_culler_new(scene, kinds[k]);
            CHECK(culler != NULL, "hom_culler_new");
            uint32_t ids[8];
            for (int frame = 0; frame < 3; frame++) {
                const int64_t n = hom_culler_cull(culler, scene, view_proj, 320, 240, HOM_CLIP_ZERO_TO_ONE, ids, 8);
                const int64_t want = kinds[k] == HOM_CULLER_FRUSTUM ? 3 : 2;
                CHECK(n == want, "visible count");
                CHECK(n >= 2 && ids[0] == 0 && ids[n - 1] == 2, "the wall and the box in front");
                CHECK(hom_culler_frame_done(culler, -1.0) == 0, "frame_done");
            }
            hom_culler_free(culler);
        }
        CHECK(hom_scene_remove_object(scene, 1) == 0 && hom_scene_remove_object(scene, 1) == HOM_ERROR_INVALID,
              "remove once");
        hom_scene_free(scene);
    }
    {
        /* The wall as one convex box (outline) hides the box behind it; the
         * wall quad is one cluster of its two triangles; a cluster size of 0 is refused. */
        static const float cube[24] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 0, 1, 1, 0, 1, 0, 1, 1, 1, 1, 1};
        static const uint32_t tris[36] = {0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1,
                                          2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3};
        const float box[16] = {20, 0, 0, 0, 0, 10, 0, 0, 0, 0, 1, 0, -10, -5, -11, 1};
        float mvp[16];
        for (int c = 0; c < 4; c++)
            for (int r = 0; r < 4; r++) {
                float sum = 0;
                for (int k = 0; k < 4; k++) sum += view_proj[k * 4 + r] * box[c * 4 + k];
                mvp[c * 4 + r] = sum;
            }
        HomBuffer *b = hom_buffer_new(320, 240, HOM_CLIP_ZERO_TO_ONE);
        CHECK(hom_buffer_render_convex_stand_in(b, cube, 8, 12, tris, 36, mvp) == 0, "convex stand-in");
        CHECK(hom_buffer_render_convex_stand_in(b, cube, 8, 12, tris, 35, mvp) == HOM_ERROR_INVALID, "35 indices");
        CHECK(hom_buffer_test_aabb(b, behind_min, behind_max, view_proj) == HOM_OCCLUDED, "behind the box wall");
        hom_buffer_free(b);
        HomCluster one[2];
        uint32_t order[2] = {9, 9};
        CHECK(hom_cluster_triangles(wall, 4, 16, quad, 6, 64, 3.0f, one, 2, order) == 1, "one cluster");
        CHECK(one[0].first_triangle == 0 && one[0].triangle_count == 2, "of both triangles");
        CHECK(order[0] + order[1] == 1, "each triangle once");
        CHECK(hom_cluster_triangles(wall, 4, 16, quad, 6, 0, 3.0f, one, 2, NULL) == HOM_ERROR_INVALID,
              "clusters of no triangles");
        CHECK(hom_cluster_triangles(wall, 4, 16, quad, 6, 64, 3.0f, NULL, 2, NULL) == HOM_ERROR_NULL,
              "NULL clusters with room for two");
    }
    if (failures) {
        fprintf(stderr, "hom C test: %d failures\n", failures);
        return 1;
    }
    printf("hom C test: all checks passed\n");
    return 0;
}
