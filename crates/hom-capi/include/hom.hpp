// hom: occlusion culling from C++ — a header-only RAII wrapper over hom.h.
// hom::Buffer owns a HomBuffer (moved, never copied); a failing call throws
// hom::Error with hom_last_error()'s message. Link as for hom.h.
#ifndef HOM_HPP
#define HOM_HPP

#include "hom.h"

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace hom {

/// A failed hom call: its code (HOM_ERROR_*) and message.
class Error : public std::runtime_error {
  public:
    Error(int32_t code, const std::string &message) : std::runtime_error(message), code_(code) {}
    int32_t code() const noexcept { return code_; }

  private:
    int32_t code_;
};

/// A test's answer.
enum class Visibility : int32_t { Visible = HOM_VISIBLE, Occluded = HOM_OCCLUDED, ViewCulled = HOM_VIEW_CULLED };

/// Clip conventions of the matrices passed in.
enum class Clip : int32_t {
    ZeroToOne = HOM_CLIP_ZERO_TO_ONE,
    NegOneToOne = HOM_CLIP_NEG_ONE_TO_ONE,
    ReversedZ = HOM_CLIP_REVERSED_Z,
};

/// Buffer kinds.
enum class Kind : int32_t { Hzb = HOM_KIND_HZB, Hom = HOM_KIND_HOM, Masked = HOM_KIND_MASKED };

/// An occlusion buffer; see hom.h for each call's contract.
class Buffer {
  public:
    Buffer(uint32_t width, uint32_t height, Clip clip, Kind kind = Kind::Hzb)
        : buffer_(hom_buffer_new_kind(static_cast<int32_t>(kind), width, height, static_cast<int32_t>(clip))) {
        if (buffer_ == nullptr) {
            throw Error(HOM_ERROR_INVALID, hom_last_error());
        }
    }
    ~Buffer() { hom_buffer_free(buffer_); }
    Buffer(const Buffer &) = delete;
    Buffer &operator=(const Buffer &) = delete;
    Buffer(Buffer &&other) noexcept : buffer_(std::exchange(other.buffer_, nullptr)) {}
    Buffer &operator=(Buffer &&other) noexcept {
        if (this != &other) {
            hom_buffer_free(buffer_);
            buffer_ = std::exchange(other.buffer_, nullptr);
        }
        return *this;
    }

    void clear() { check(hom_buffer_clear(buffer_)); }

    /// Occluder triangles: positions `stride_bytes` apart, three indices a triangle.
    void render_triangles(const float *positions, std::size_t vertex_count, std::size_t stride_bytes,
                          const uint32_t *indices, std::size_t index_count, const float model_to_clip[16]) {
        check(hom_buffer_render_triangles(buffer_, positions, vertex_count, stride_bytes, indices, index_count,
                                          model_to_clip));
    }

    /// An occluder that is one convex solid (a box, a hull), drawn as its shrunk outline.
    void render_convex_stand_in(const float *positions, std::size_t vertex_count, std::size_t stride_bytes,
                                const uint32_t *indices, std::size_t index_count, const float model_to_clip[16]) {
        check(hom_buffer_render_convex_stand_in(buffer_, positions, vertex_count, stride_bytes, indices, index_count,
                                                model_to_clip));
    }

    Visibility test_aabb(const float min[3], const float max[3], const float model_to_clip[16]) {
        return static_cast<Visibility>(check(hom_buffer_test_aabb(buffer_, min, max, model_to_clip)));
    }

    /// `count` boxes of six floats each; answers (HOM_VISIBLE, ...) to `results`. Many at once run on all threads.
    void test_aabbs(const float *boxes, std::size_t count, const float model_to_clip[16], int32_t *results) {
        check(hom_buffer_test_aabbs(buffer_, boxes, count, model_to_clip, results));
    }

    Visibility test_rect(float min_x, float min_y, float max_x, float max_y, float nearest_depth) {
        return static_cast<Visibility>(check(hom_buffer_test_rect(buffer_, min_x, min_y, max_x, max_y, nearest_depth)));
    }

    HomBufferStats stats() {
        HomBufferStats s{};
        check(hom_buffer_stats(buffer_, &s));
        return s;
    }

    /// The C handle, for calls the wrapper does not have.
    HomBuffer *get() noexcept { return buffer_; }

  private:
    static int32_t check(int32_t code) {
        if (code < 0) {
            throw Error(code, hom_last_error());
        }
        return code;
    }
    HomBuffer *buffer_;
};

/// A mesh cut into clusters (hom_cluster_triangles): the clusters, and each
/// triangle's original index in cluster order.
struct Clusters {
    std::vector<HomCluster> clusters;
    std::vector<uint32_t> order;
};

inline Clusters cluster_triangles(const float *positions, std::size_t vertex_count, std::size_t stride_bytes,
                                  const uint32_t *indices, std::size_t index_count, uint32_t max_triangles = 64,
                                  float max_extent = 3.0f) {
    const int64_t n = hom_cluster_triangles(positions, vertex_count, stride_bytes, indices, index_count,
                                            max_triangles, max_extent, nullptr, 0, nullptr);
    if (n < 0) {
        throw Error(static_cast<int32_t>(n), hom_last_error());
    }
    Clusters out{std::vector<HomCluster>(static_cast<std::size_t>(n)), std::vector<uint32_t>(index_count / 3)};
    const int64_t again = hom_cluster_triangles(positions, vertex_count, stride_bytes, indices, index_count,
                                                max_triangles, max_extent, out.clusters.data(), out.clusters.size(),
                                                out.order.data());
    if (again < 0) {
        throw Error(static_cast<int32_t>(again), hom_last_error());
    }
    return out;
}

/// A scene of meshes and objects; see hom.h's hom_scene_*.
class Scene {
  public:
    Scene() : scene_(hom_scene_new()) {
        if (scene_ == nullptr) {
            throw Error(HOM_ERROR_INTERNAL, hom_last_error());
        }
    }
    ~Scene() { hom_scene_free(scene_); }
    Scene(const Scene &) = delete;
    Scene &operator=(const Scene &) = delete;

    /// A mesh's id.
    uint32_t add_mesh(const float *positions, std::size_t vertex_count, std::size_t stride_bytes,
                      const uint32_t *indices, std::size_t index_count) {
        return static_cast<uint32_t>(
            check(hom_scene_add_mesh(scene_, positions, vertex_count, stride_bytes, indices, index_count)));
    }
    /// An object's id (never reused).
    uint32_t add_object(uint32_t mesh, const float transform[16], bool dynamic = false) {
        return static_cast<uint32_t>(check(hom_scene_add_object(scene_, mesh, transform, dynamic ? 1 : 0)));
    }
    /// The first of the consecutive ids of the mesh's clusters, one static
    /// object cut into clusters; `count` gets how many.
    uint32_t add_clustered_object(uint32_t mesh, const float transform[16], uint32_t &count,
                                  uint32_t max_triangles = 64, float max_extent = 3.0f) {
        return static_cast<uint32_t>(
            check(hom_scene_add_clustered_object(scene_, mesh, transform, max_triangles, max_extent, &count)));
    }
    /// The object (numbered in the order objects were added) that `object` is part of.
    uint32_t parent_of(uint32_t object) const {
        return static_cast<uint32_t>(check(hom_scene_parent_of(scene_, object)));
    }
    void set_transform(uint32_t object, const float transform[16]) {
        check(hom_scene_set_transform(scene_, object, transform));
    }
    void remove_object(uint32_t object) { check(hom_scene_remove_object(scene_, object)); }
    void set_occluder(uint32_t object, bool occluder) {
        check(hom_scene_set_occluder(scene_, object, occluder ? 1 : 0));
    }
    HomScene *get() noexcept { return scene_; }

  private:
    static int64_t check(int64_t code) {
        if (code < 0) {
            throw Error(static_cast<int32_t>(code), hom_last_error());
        }
        return code;
    }
    HomScene *scene_;
};

/// Culler kinds.
enum class CullerKind : int32_t {
    Frustum = HOM_CULLER_FRUSTUM,
    Hom = HOM_CULLER_HOM,
    Hzb = HOM_CULLER_HZB,
    Masked = HOM_CULLER_MASKED,
};

/// A culler for one scene; see hom.h's hom_culler_*.
class Culler {
  public:
    Culler(Scene &scene, CullerKind kind = CullerKind::Hom)
        : culler_(hom_culler_new(scene.get(), static_cast<int32_t>(kind))) {
        if (culler_ == nullptr) {
            throw Error(HOM_ERROR_INVALID, hom_last_error());
        }
    }
    ~Culler() { hom_culler_free(culler_); }
    Culler(const Culler &) = delete;
    Culler &operator=(const Culler &) = delete;

    /// The visible object ids (ascending) into `visible`, resized to fit.
    template <class Vector>
    void cull(Scene &scene, const float view_proj[16], uint32_t width, uint32_t height, Clip clip, Vector &visible) {
        for (;;) {
            const int64_t n = hom_culler_cull(culler_, scene.get(), view_proj, width, height,
                                              static_cast<int32_t>(clip), visible.data(), visible.size());
            if (n < 0) {
                throw Error(static_cast<int32_t>(n), hom_last_error());
            }
            if (static_cast<std::size_t>(n) <= visible.size()) {
                visible.resize(static_cast<std::size_t>(n));
                return;
            }
            visible.resize(static_cast<std::size_t>(n));
        }
    }
    /// The frame's time once drawn (negative: unknown), for the cost model.
    void frame_done(double frame_ms) { hom_culler_frame_done(culler_, frame_ms); }

  private:
    HomCuller *culler_;
};

} // namespace hom

#endif // HOM_HPP
