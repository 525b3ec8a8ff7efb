// The C++ wrapper (hom.hpp): a wall hides a box; misuse throws hom::Error;
// buffers move. Built with `c++ -Wall -Wextra -Werror -std=c++17` by
// scripts/c-api-check.sh (CI).
#include "hom.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

int main() {
    float m[16] = {0};
    const float f = 1.0f / std::tan(0.5f);
    m[0] = f * 0.75f, m[5] = f, m[10] = 100.0f / (0.1f - 100.0f), m[11] = -1.0f, m[14] = 10.0f / (0.1f - 100.0f);
    const float wall[12] = {-10, -5, -10, 10, -5, -10, 10, 5, -10, -10, 5, -10};
    const uint32_t quad[6] = {0, 1, 2, 0, 2, 3};
    const float lo[3] = {-1, -1, -20}, hi[3] = {1, 1, -15};
    int failures = 0;
    for (hom::Kind kind : {hom::Kind::Hzb, hom::Kind::Hom, hom::Kind::Masked}) {
        hom::Buffer b(320, 240, hom::Clip::ZeroToOne, kind);
        hom::Buffer moved = std::move(b);
        moved.clear();
        moved.render_triangles(wall, 4, 12, quad, 6, m);
        failures += moved.test_aabb(lo, hi, m) != hom::Visibility::Occluded;
        failures += moved.stats().triangles_submitted != 2;
        try {
            moved.render_triangles(wall, 4, 12, quad, 5, m);
            failures++;
        } catch (const hom::Error &e) {
            failures += e.code() != HOM_ERROR_INVALID || std::strstr(e.what(), "multiple of 3") == nullptr;
        }
    }
    try {
        hom::Buffer bad(0, 0, hom::Clip::ReversedZ);
        failures++;
    } catch (const hom::Error &e) {
        failures += std::strstr(e.what(), "16384") == nullptr;
    }
    {
        static const float cube[24] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 0, 1, 1, 0, 1, 0, 1, 1, 1, 1, 1};
        static const uint32_t tris[36] = {0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1,
                                          2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3};
        float wall[16] = {20, 0, 0, 0, 0, 10, 0, 0, 0, 0, 1, 0, -10, -5, -11, 1};
        float behind[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -0.5f, -0.5f, -20, 1};
        hom::Scene scene;
        const uint32_t mesh = scene.add_mesh(cube, 8, 12, tris, 36);
        scene.add_object(mesh, wall);
        scene.add_object(mesh, behind, true);
        hom::Culler culler(scene, hom::CullerKind::Hom);
        std::vector<uint32_t> visible;  // empty: the wrapper grows it
        culler.cull(scene, m, 320, 240, hom::Clip::ZeroToOne, visible);
        failures += visible != std::vector<uint32_t>{0};
        uint32_t count = 0;
        const uint32_t first = scene.add_clustered_object(mesh, wall, count);
        failures += first != 2 || count != 1 || scene.parent_of(first) != 2;  // a cube is one cluster
        try {
            scene.add_object(7, wall);
            failures++;
        } catch (const hom::Error &e) {
            failures += std::strstr(e.what(), "mesh 7") == nullptr;
        }
    }
    {
        // A convex wall (a box) drawn as its outline hides the box; a batch answers as single tests;
        // the wall quad is one cluster of two triangles.
        static const float cube[24] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 0, 1, 1, 0, 1, 0, 1, 1, 1, 1, 1};
        static const uint32_t tris[36] = {0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1,
                                          2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3};
        const float box[16] = {20, 0, 0, 0, 0, 10, 0, 0, 0, 0, 1, 0, -10, -5, -11, 1};
        float mvp[16];
        for (int c = 0; c < 4; c++)
            for (int r = 0; r < 4; r++) {
                float s = 0;
                for (int k = 0; k < 4; k++) s += m[k * 4 + r] * box[c * 4 + k];
                mvp[c * 4 + r] = s;
            }
        hom::Buffer b(320, 240, hom::Clip::ZeroToOne);
        b.render_convex_stand_in(cube, 8, 12, tris, 36, mvp);
        const float boxes[12] = {-1, -1, -20, 1, 1, -15, 30, -1, -20, 31, 1, -15};
        int32_t answers[2] = {-1, -1};
        b.test_aabbs(boxes, 2, m, answers);
        failures += answers[0] != HOM_OCCLUDED || answers[1] == HOM_OCCLUDED;
        failures += b.test_aabb(lo, hi, m) != hom::Visibility::Occluded;
        const hom::Clusters cut = hom::cluster_triangles(wall, 4, 12, quad, 6);
        failures += cut.clusters.size() != 1 || cut.clusters[0].triangle_count != 2 || cut.order.size() != 2;
        try {
            hom::cluster_triangles(wall, 4, 12, quad, 6, 0);
            failures++;
        } catch (const hom::Error &e) {
            failures += e.code() != HOM_ERROR_INVALID;
        }
    }
    if (failures != 0) {
        std::fprintf(stderr, "hom C++ test: %d failures\n", failures);
        return 1;
    }
    std::printf("hom C++ test: all checks passed\n");
    return 0;
}
