#pragma once
/// @file mesh_io.h
/// Internals of the export stage: one writer and one reader per format, and the helpers they
/// share. write_mesh()/read_mesh() in export.cpp check the input and dispatch here.
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "qjulia/io/mesh_io.h"
#include "qjulia/base/mesh.h"

namespace qjulia::detail {

/// What every writer receives: the checked mesh, unit normals for every vertex, colours
/// clamped to [0, 1] (or empty), and the parameters pretty-printed (or empty).
struct ExportData {
  const TriMesh& mesh;
  std::vector<std::array<float, 3>> normals;  ///< #V unit vectors
  std::vector<std::array<float, 3>> colors;   ///< empty or #V linear RGB in [0, 1]
  std::string params_json;                    ///< the parameters as pretty JSON, or empty
  std::vector<std::string> params_lines;      ///< params_json split at newlines
  std::string unit;                           ///< ExportOptions::unit
  std::string generator;                      ///< "qjulia VERSION"
};

void write_gltf(const std::string& path, const ExportData& data, bool binary);
void write_obj(const std::string& path, const ExportData& data);
void write_ply(const std::string& path, const ExportData& data);
void write_stl(const std::string& path, const ExportData& data);
void write_3mf(const std::string& path, const ExportData& data);

TriMesh read_gltf(const std::string& path, bool binary);
TriMesh read_obj(const std::string& path);
TriMesh read_ply(const std::string& path);
TriMesh read_stl(const std::string& path);
TriMesh read_3mf(const std::string& path);

std::string read_gltf_params(const std::string& path, bool binary);
std::string read_3mf_params(const std::string& path);
std::string read_obj_params(const std::string& path);
std::string read_ply_params(const std::string& path);

/// The comment prefix that marks parameter lines in OBJ ("# params ") and PLY ("params ").
inline constexpr const char* kParamsTag = "params ";

/// Reads a whole file. @throws InvalidInput "PATH: cannot read the file (reason)".
std::string read_file(const std::string& path);

/// Throws InvalidInput("PATH: " + reason).
[[noreturn]] void fail(const std::string& path, const std::string& reason);

/// Unit normal of triangle (a, b, c) by the cross product, or zero when it has no area.
std::array<float, 3> face_normal(const std::array<float, 3>& a, const std::array<float, 3>& b,
                                 const std::array<float, 3>& c);

/// sRGB transfer function (IEC 61966-2-1) for 8-bit/text colour formats (PLY, OBJ).
inline float linear_to_srgb(float c) {
  return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}
inline float srgb_to_linear(float c) {
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

/// Merges corners with bit-identical positions (after -0 -> +0): `corners` holds 3 positions
/// per triangle; fills mesh.positions and mesh.triangles.
void weld_corners(const std::vector<std::array<float, 3>>& corners, TriMesh& mesh);

}  // namespace qjulia::detail
