#include "qjulia/pipeline/estimate.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <deque>
#include <limits>
#include <mutex>
#include <string>
#include <utility>

#include "grid/grid_impl.h"
#include "qjulia/base/error.h"
#include "qjulia/field/classify.h"
#include "qjulia/grid/sample.h"

namespace qjulia {
namespace {

// The memory model, measured on the Release build (docs/design.md, "Memory"): the process
// itself, bytes per crossing cell of the sparse run written as PLY (sampling, extraction and
// the written mesh, which peak at different times), the faces and bricks per crossing cell,
// and what the other stages and formats add.
constexpr double kProcess = 28.0 * (1 << 20);
constexpr double kPerCell = 72;
constexpr double kFacesPerCell = 2.1;
constexpr double kBrickBytes = 2600;  // a brick with its values, sampling and extraction
// The sampling's own peak, at its end: the process then, every brick made (level-8 candidates
// with their corners, refined bricks with their values, their links) and what grows with the
// crossing cells. It is the run's peak where the mesh is small beside its bricks (classic-julia
// from 1024 on).
constexpr double kSampleProcess = 12.0 * (1 << 20);
constexpr double kSampleBrickBytes = 1330;
constexpr double kSampleCellBytes = 14;
constexpr double kDenseBrickBytes = 3600;  // a brick of the dense path (all 729 values)
constexpr double kVdbBrickBytes = 2400;    // a VDB leaf with its values and masks
// The simplifier's copies and the Hausdorff tree, per face of the whole mesh: above the run
// without decimation, newton-cubic asked for 200,000 faces at 256 (2.06M faces) peaked 220 MiB
// higher (112 bytes a face), asked for 1,000,000 at 512 (9.9M) 791 MiB (84 bytes); classic-julia
// asked for 44,000 at 256 (0.44M) 45 MiB (106 bytes), for 200,000 at 512 (1.8M) 174 MiB (101).
constexpr double kDecimatePerFace = 120;
// Thickening re-meshes the whole surface on a level set whose voxel is a quarter of the
// thickness: its faces are the mesh's faces times the square of the ratio of the two voxels
// (classic-julia at 64 thickened by 0.4 to 0.0125, 5,860 to 5,446,164 faces, within 15% of
// that), and its level sets and their mesh hold about 170 bytes a face of the result (155-172
// measured from 1.4M faces on).
constexpr double kThickenPerFace = 170;
// OpenVDB's module, loaded to thicken or to write the grid: its libraries and their start.
constexpr double kVdbModuleBytes = 38.0 * (1 << 20);
constexpr double kPreviewBytes = 64.0 * (1 << 20);
constexpr double kGltfPerFace = 30;     // tinygltf's buffers beside the mesh
constexpr double kThreeMfPerFace = 60;  // lib3mf's mesh and the archive in memory

// GLB's length fields are 32 bits.
constexpr double kGlbLimit = 4294967295.0;

struct Probe {
  std::uint64_t cells = 0, bricks = 0;
  double extent = 0;  // the longest side of the crossing cells' box, model units
};

// The longest side of the box of the crossing cells of `grid` (the mesh's box, within a voxel
// on each side), in model units.
double surface_extent(const SampledGrid& grid) {
  int lo[3] = {INT32_MAX, INT32_MAX, INT32_MAX}, hi[3] = {INT32_MIN, INT32_MIN, INT32_MIN};
  for (const auto& b : grid.impl().bricks) {
    if (!b->surface.any()) continue;
    b->surface.for_each([&](int c) {
      const int g[3] = {b->at.x * detail::kBrick + c / 64, b->at.y * detail::kBrick + (c / 8) % 8,
                        b->at.z * detail::kBrick + c % 8};
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], g[a]);
        hi[a] = std::max(hi[a], g[a] + 1);
      }
    });
  }
  if (hi[0] < lo[0]) return 0;  // no crossing cell
  long long side = 0;
  for (int a = 0; a < 3; ++a) side = std::max<long long>(side, hi[a] - lo[a]);
  return static_cast<double>(side) * grid.voxel_size();
}

// The probes made so far in this process, by the set's parameters (all but the resolution) and
// the probe's resolution: a refusal estimates several resolutions of one set, whose probes are
// the same from 2048 on (sampling is deterministic, whatever the threads). The last few kept.
class ProbeCache {
 public:
  bool find(const std::string& key, Probe& out) {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [k, p] : entries_)
      if (k == key) {
        out = p;
        return true;
      }
    return false;
  }
  void add(std::string key, const Probe& p) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (entries_.size() == kEntries) entries_.pop_front();
    entries_.emplace_back(std::move(key), p);
  }

 private:
  static constexpr std::size_t kEntries = 16;
  std::mutex mutex_;
  std::deque<std::pair<std::string, Probe>> entries_;
};

Probe probe(const Solid& solid, int resolution, const CancelToken* cancel) {
  static ProbeCache cache;
  Params key_params = solid.classifier().params();
  key_params.resolution = 0;
  const std::string key = std::to_string(resolution) + " " + params_to_json(key_params, false);
  Probe p;
  if (cache.find(key, p)) return p;
  SampleOptions so;
  so.cancel = cancel;
  const SampledGrid grid = sample(solid.at_resolution(resolution), so);
  p = {grid.crossing_cells(), grid.bricks(), surface_extent(grid)};
  cache.add(key, p);
  return p;
}

// The bytes of the largest file `format` makes of the mesh.
double file_bytes(MeshFormat format, double faces, double vertices, bool colour) {
  switch (format) {
    case MeshFormat::kGlb:
    case MeshFormat::kGltf:
      return vertices * (colour ? 36 : 24) + faces * 12 + 65536;
    case MeshFormat::kPly:
      return vertices * (colour ? 27 : 24) + faces * 13 + 65536;
    case MeshFormat::kStl:
      return faces * 50 + 84;
    case MeshFormat::kObj:
      return vertices * (colour ? 100 : 64) + faces * 32;
    case MeshFormat::k3mf:
      return vertices * 20 + faces * 16;
  }
  return 0;
}

std::string rounded(double x) {
  char buf[32];
  if (x >= 1e9)
    std::snprintf(buf, sizeof buf, "%.1f billion", x / 1e9);
  else if (x >= 1e6)
    std::snprintf(buf, sizeof buf, "%.1f million", x / 1e6);
  else
    std::snprintf(buf, sizeof buf, "%.0f", x);
  return buf;
}

// What an output format cannot hold: the limit's short name and the refusal (both empty when
// the outputs hold the mesh of `e`).
struct FormatLimit {
  std::string name, message;
};

FormatLimit format_limit(const Params& params, const RunPlan& plan, const RunEstimate& e) {
  // The vertices of a TriMesh are numbered in 32 bits; PLY's indices are signed.
  const double vertices = static_cast<double>(e.vertices);
  if (vertices > 4294967295.0)
    return {"32-bit vertex numbers",
            "the mesh would have about " + rounded(vertices) +
                " vertices, more than 32-bit indices can number; lower the resolution"};
  const double final_vertices = 0.5 * static_cast<double>(e.final_faces);
  for (MeshFormat f : plan.outputs) {
    if (f == MeshFormat::kPly && final_vertices > 2147483647.0)
      return {"PLY's indices", "the mesh would have about " + rounded(final_vertices) +
                                   " vertices, more than PLY's signed 32-bit indices hold; write "
                                   ".obj or .stl, or reduce it with --faces"};
    if (f == MeshFormat::kStl && static_cast<double>(e.final_faces) > 4294967295.0)
      return {"STL's triangle count", "the mesh would have about " +
                                          rounded(static_cast<double>(e.final_faces)) +
                                          " faces, more than binary STL's 32-bit count holds; "
                                          "write .obj, or reduce it with --faces"};
    if (f == MeshFormat::kGlb) {
      const double bytes = file_bytes(f, static_cast<double>(e.final_faces), final_vertices,
                                      params.mesh.color != ColorMode::kNone);
      if (bytes > kGlbLimit)
        return {"GLB's 4 GiB",
                "the mesh would make a GLB of about " + format_bytes(bytes) + " (" +
                    rounded(static_cast<double>(e.final_faces)) +
                    " faces, estimated); GLB holds at most 4 GiB: write .gltf (its buffer is a "
                    "separate .bin), .ply, .obj or .stl, or reduce it with --faces"};
    }
  }
  return {};
}

// The faces of the thickened mesh: `faces` (the extracted mesh's at `resolution`) times the
// square of the ratio of the grid's voxel to the level set's (a quarter of the thickness, in
// model units: the mesh is scaled to --size first, its longest side the probe's surface extent).
double thickened_faces(const Params& params, const RunEstimate& base, int resolution,
                       double faces) {
  if (!params.print.min_thickness_mm) return 0;
  double longest = 0;
  for (int a = 0; a < 3; ++a)
    longest = std::max(longest, params.bounds.max[a] - params.bounds.min[a]);
  const double extent = base.surface_extent > 0 ? base.surface_extent : longest;
  const double scale = params.print.size_mm ? *params.print.size_mm / extent : 1.0;
  const double level_set_voxel = *params.print.min_thickness_mm / 4 / scale;
  const double ratio = longest / std::max(1, resolution) / level_set_voxel;
  return faces * ratio * ratio;
}

}  // namespace

RunEstimate estimate_at(const Params& params, const RunPlan& plan, const RunEstimate& base,
                        int resolution) {
  RunEstimate e = base;
  e.resolution = resolution;
  const double ratio = static_cast<double>(resolution) / std::max(1, base.probe_resolution);
  const double cells = base.probe_resolution == resolution
                           ? static_cast<double>(base.probe_cells)
                           : static_cast<double>(base.probe_cells) * std::pow(ratio, base.exponent);
  const double faces = kFacesPerCell * cells;
  const double vertices = 0.5 * faces;
  // The stages after the extraction work on the thickened mesh where there is one.
  const double thickened = thickened_faces(params, base, resolution, faces);
  const double whole = params.print.min_thickness_mm ? thickened : faces;
  double final_faces = whole;
  if (params.mesh.faces)
    final_faces = std::min(final_faces, static_cast<double>(*params.mesh.faces));
  const double final_vertices = 0.5 * final_faces;
  const bool colour = params.mesh.color != ColorMode::kNone;

  // A distributed run: each rank samples and meshes its share; a gathered mesh is whole on
  // rank 0 (the largest rank, which the estimate is of).
  const double share = plan.ranks > 1 && !plan.gathered ? 1.0 / plan.ranks : 1.0;
  double peak = kProcess + kPerCell * cells * share;
  if (colour) peak += 24 * vertices * share;  // the colours, and their copy for the file
  // The bricks grow as the crossing cells do.
  const double bricks =
      base.probe_cells ? static_cast<double>(base.probe_bricks) * cells / base.probe_cells : 0.0;
  // The sampling's peak: its bricks grow by their own power of the resolution (faster than the
  // crossing cells: more level-8 candidates per crossing cell as the resolution grows).
  // The dense path has its own term instead.
  double sampling = 0;
  if (plan.dense) {
    const double side = std::ceil(resolution / 8.0) + 1;
    peak += side * side * side * kDenseBrickBytes;
  } else {
    const double sampled_bricks =
        base.probe_resolution == resolution
            ? static_cast<double>(base.probe_bricks)
            : static_cast<double>(base.probe_bricks) * std::pow(ratio, base.brick_exponent);
    sampling =
        kSampleProcess + (kSampleBrickBytes * sampled_bricks + kSampleCellBytes * cells) * share;
  }
  if (plan.keep_grid) peak += bricks * (kBrickBytes + kVdbBrickBytes);
  if (plan.keep_grid || params.print.min_thickness_mm) peak += kVdbModuleBytes;
  if (params.mesh.faces || params.mesh.max_error) peak += kDecimatePerFace * whole;
  if (params.print.min_thickness_mm) peak += kThickenPerFace * thickened;
  if (plan.preview) peak += kPreviewBytes;
  double largest = 0;
  for (MeshFormat f : plan.outputs) {
    if (f == MeshFormat::kGlb || f == MeshFormat::kGltf) peak += kGltfPerFace * final_faces;
    if (f == MeshFormat::k3mf) peak += kThreeMfPerFace * final_faces;
    largest = std::max(largest, file_bytes(f, final_faces, final_vertices, colour));
  }
  // The other stages come after the sampling's peak.
  peak = std::max(peak, sampling);
  auto clamp = [](double x) {
    return x >= 1.8e19 ? std::numeric_limits<std::uint64_t>::max() : static_cast<std::uint64_t>(x);
  };
  e.cells = clamp(cells);
  e.faces = clamp(faces);
  e.vertices = clamp(vertices);
  e.thickened_faces = params.print.min_thickness_mm ? clamp(thickened) : 0;
  e.final_faces = clamp(final_faces);
  e.peak_bytes = clamp(peak);
  e.largest_output = clamp(largest);
  return e;
}

RunEstimate estimate_run(const Params& params, const RunPlan& plan) {
  return estimate_run(Solid(params), plan);
}

RunEstimate estimate_run(const Solid& solid, const RunPlan& plan) {
  const Params& params = solid.classifier().params();
  const int n = params.resolution;
  RunEstimate e;
  if (n <= 64) {
    // Small enough to sample itself (a few milliseconds).
    const Probe p = probe(solid, n, plan.cancel);
    e.probe_resolution = n;
    e.probe_cells = p.cells;
    e.probe_bricks = p.bricks;
    e.surface_extent = p.extent;
    e.exponent = 2;
    e.brick_exponent = 2;
  } else {
    // Two samplings at a quarter and an eighth of the run (at most 256 and 128, or 512 and 256
    // from 2048 on, where extrapolating eightfold missed the peak by a third): the crossing cells
    // and the bricks grow as powers of the resolution (2 for a smooth surface, more for a
    // fractal). A run of 2048 or more that the probes at 128 and 256 put above twice its limit
    // is refused on their estimate, at once.
    auto from_probes = [&](int fine) {
      const Probe c = probe(solid, fine / 2, plan.cancel);
      const Probe p = probe(solid, fine, plan.cancel);
      RunEstimate r;
      r.probe_resolution = fine;
      r.probe_cells = p.cells;
      r.probe_bricks = p.bricks;
      r.surface_extent = p.extent;
      // The power of the resolution from a count at half the resolution to one at the full.
      auto growth = [](std::uint64_t half, std::uint64_t full, double otherwise) {
        return half > 0 && full > 0 ? std::clamp(std::log2(double(full) / double(half)), 1.5, 3.0)
                                    : otherwise;
      };
      r.exponent = growth(c.cells, p.cells, 2.0);
      r.brick_exponent = growth(c.bricks, p.bricks, r.exponent);
      return r;
    };
    e = from_probes(std::min(256, n / 4));
    if (n >= 2048 && !(plan.limit > 0 && double(estimate_at(params, plan, e, n).peak_bytes) >
                                             2.0 * double(plan.limit)))
      e = from_probes(512);
    const std::uint64_t b = e.probe_cells;
    // A surface the probes barely see (a few cells) may be finer than they resolve: at least
    // the cells of a sphere filling the box.
    if (b < 64) {
      e.probe_cells = std::max<std::uint64_t>(b, 64);
      e.probe_bricks = std::max<std::uint64_t>(e.probe_bricks, 1);
      e.exponent = 3.0;
      e.brick_exponent = 3.0;
    }
  }
  return estimate_at(params, plan, e, n);
}

int largest_fitting_resolution(const Params& params, const RunPlan& plan, const RunEstimate& base,
                               std::size_t bytes) {
  auto fits = [&](int r) {
    const RunEstimate e = estimate_at(params, plan, base, r);
    return e.peak_bytes <= bytes && format_limit(params, plan, e).name.empty();
  };
  if (!fits(1)) return 0;
  int lo = 1, hi = 2;
  while (hi < 1000000 && fits(hi)) {
    lo = hi;
    hi = std::min(1000000, hi * 2);
  }
  if (fits(hi)) return hi;
  while (hi - lo > 1) {
    const int mid = lo + (hi - lo) / 2;
    (fits(mid) ? lo : hi) = mid;
  }
  return lo;
}

namespace {

// The smallest thickness (mm, three significant digits) at which the run of `e` fits in `bytes`
// and its outputs, or 0 when none does: the thickened mesh shrinks as the square of the thickness.
double smallest_fitting_thickness(const Params& params, const RunPlan& plan, const RunEstimate& e,
                                  std::size_t bytes) {
  auto fits = [&](double mm) {
    Params q = params;
    q.print.min_thickness_mm = mm;
    const RunEstimate r = estimate_at(q, plan, e, e.resolution);
    return r.peak_bytes <= bytes && format_limit(q, plan, r).name.empty();
  };
  const double given = *params.print.min_thickness_mm;
  double lo = given, hi = given;
  for (int i = 0; !fits(hi); ++i) {
    if (i == 64) return 0;
    lo = hi;
    hi *= 2;
  }
  for (int i = 0; i < 60 && hi > lo * (1 + 1e-4); ++i) {
    const double mid = std::sqrt(lo * hi);
    (fits(mid) ? hi : lo) = mid;
  }
  // Rounded up to three significant digits, and up again until that fits.
  const double unit = std::pow(10.0, std::floor(std::log10(hi)) - 2);
  double mm = std::ceil(hi / unit - 1e-9) * unit;
  while (!fits(mm)) mm += unit;
  return mm;
}

std::string millimetres(double mm) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g mm", mm);
  return buf;
}

}  // namespace

void check_run(const Params& params, const RunPlan& plan, const RunEstimate& e,
               const MemoryLimits& limits) {
  const std::size_t limit = limits.effective();
  if (e.peak_bytes > limit && params.print.min_thickness_mm) {
    // A thickening whose level set is too fine for the memory: what fits is a thicker one (the
    // resolution hardly changes it: a coarser mesh has fewer faces, each resampled finer).
    const double mm = smallest_fitting_thickness(params, plan, e, limit);
    if (mm > 0)
      throw TooLarge("a minimum thickness of " + millimetres(*params.print.min_thickness_mm) +
                     " needs about " + format_bytes(static_cast<double>(e.peak_bytes)) +
                     " (estimated: the thickening re-meshes the surface with a voxel of a "
                     "quarter of it, into about " +
                     rounded(static_cast<double>(e.thickened_faces)) + " faces) but " +
                     limits.describe() +
                     " is available; the smallest minimum thickness that "
                     "fits is " +
                     millimetres(mm) + " (--max-memory sets the limit)");
  }
  if (e.peak_bytes > limit) {
    // The probes of another resolution differ (a quarter of it): the answer is checked by the
    // estimate of a run at that resolution itself, and lowered until that one fits too.
    int fits = largest_fitting_resolution(params, plan, e, limit);
    for (int round = 0; round < 4 && fits > 0; ++round) {
      Params q = params;
      q.resolution = fits;
      const RunEstimate own = estimate_run(q, plan);
      if (own.peak_bytes <= limit && format_limit(q, plan, own).name.empty()) break;
      fits = std::min(fits - 1, largest_fitting_resolution(q, plan, own, limit));
    }
    // Where an output format, not the memory, is what stops the next resolution: said so.
    std::string bound;
    if (fits > 0) {
      const RunEstimate next = estimate_at(params, plan, e, fits + 1);
      const FormatLimit format = format_limit(params, plan, next);
      if (next.peak_bytes <= limit && !format.name.empty()) bound = ", held back by " + format.name;
    }
    throw TooLarge("resolution " + std::to_string(params.resolution) + " needs about " +
                   format_bytes(static_cast<double>(e.peak_bytes)) + " (estimated, " +
                   rounded(static_cast<double>(e.faces)) + " faces) but " + limits.describe() +
                   " is available; " +
                   (fits > 0 ? "the largest resolution that fits is " + std::to_string(fits) + bound
                             : std::string("no resolution fits")) +
                   " (--max-memory sets the limit)");
  }
  const FormatLimit format = format_limit(params, plan, e);
  if (!format.message.empty()) throw TooLarge(format.message);
}

}  // namespace qjulia
