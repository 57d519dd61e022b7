#pragma once
// The z-buffer pass of render(): triangles binned into tiles, tiles rasterized in parallel with
// integer edge functions. Internal to the render stage.
#include <cstdint>
#include <vector>

#include "qjulia/base/mesh.h"
#include "qjulia/base/progress.h"

namespace qjulia::detail {

constexpr int kSubBits = 8;  ///< sub-pixel precision of the rasterizer (1/256 sample)
constexpr std::int64_t kSubOne = std::int64_t{1} << kSubBits;
constexpr std::uint32_t kNoFace = 0xffffffffu;

/// Screen-space vertex: fixed-point position (1/256 sample, y down) and view depth.
struct ScreenVertex {
  std::int32_t x, y;
  float z;  ///< larger is nearer the viewer
};

/// Edge function of a -> b at p (fixed point): > 0 on the inner side of a triangle with
/// positive area.
inline std::int64_t edge(const ScreenVertex& a, const ScreenVertex& b, std::int64_t px,
                         std::int64_t py) {
  return (std::int64_t{b.x} - a.x) * (py - a.y) - (std::int64_t{b.y} - a.y) * (px - a.x);
}

/// Per sample: the nearest face (kNoFace where none) and its depth.
struct Framebuffer {
  int w = 0, h = 0;
  std::vector<float> depth;
  std::vector<std::uint32_t> face;
  std::uint32_t face_at(int x, int y) const { return face[static_cast<std::size_t>(y) * w + x]; }
};

/// Rasterizes the triangles of `mesh` at `screen` (one per vertex) into a w x h sample buffer.
/// Each tile draws its triangles in index order with a strict depth test (the earlier face wins
/// a tie), so the result does not depend on scheduling. @throws Cancelled when `cancel` is set.
Framebuffer rasterize(const TriMesh& mesh, const std::vector<ScreenVertex>& screen, int w, int h,
                      const CancelToken* cancel);

}  // namespace qjulia::detail
