#pragma once
/// @file mesh_json.h
/// The one JSON form of a mesh's measures, shared by `--stats` (stats_to_json) and
/// `compare --json` (compare_to_json).
#include <nlohmann/json_fwd.hpp>

#include "qjulia/base/mesh.h"

namespace qjulia::detail {

/// The measures of `m` as a JSON object with the keys vertices, faces, edges, closed, manifold,
/// oriented, boundary_edges, nonmanifold_edges, nonmanifold_vertices, degenerate_faces, volume,
/// area, euler, components (the component count) and bbox {min, max}.
nlohmann::json measure_to_json(const MeshMeasure& m);

}  // namespace qjulia::detail
