#pragma once
/// @file render.h
/// Preview images: a deterministic multi-threaded CPU rasterizer with simple Lambertian,
/// Lambertian and Phong shading, and contact sheets.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "qjulia/mesh.h"

namespace qjulia {

/// An 8-bit RGB image, row-major, top row first.
struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;  ///< width * height * 3
};

enum class Shading { kSimple, kLambert, kPhong };

/// Options of render().
struct RenderOptions {
  int width = 800, height = 800;  ///< pixels
  Shading shading = Shading::kPhong;
  std::vector<std::array<double, 3>> lights;  ///< directions towards the lights (view space);
                                              ///< empty = one default light
  double ambient = 0.15;                      ///< 0..1
  double specular = 0.4;                      ///< 0..1 (Phong only)
  std::array<double, 3> rotate_deg{0, 0, 0};  ///< rotation about X, then Y, then Z, degrees
  std::array<std::uint8_t, 3> background{255, 255, 255};
};

/// Renders `mesh` framed automatically. Same input, same pixels.
/// @throws InvalidInput for a bad size or option.
Image render(const TriMesh& mesh, const RenderOptions& opts = {});

/// Writes a PNG through a temporary file. @throws std::runtime_error on failure.
void write_png(const std::string& path, const Image& image);

}  // namespace qjulia
