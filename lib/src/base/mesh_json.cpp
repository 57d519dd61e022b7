#include "base/mesh_json.h"

#include <nlohmann/json.hpp>

namespace qjulia::detail {

nlohmann::json measure_to_json(const MeshMeasure& m) {
  return {{"vertices", m.vertices},
          {"faces", m.faces},
          {"edges", m.edges},
          {"closed", m.closed},
          {"manifold", m.manifold},
          {"oriented", m.oriented},
          {"boundary_edges", m.boundary_edges},
          {"nonmanifold_edges", m.nonmanifold_edges},
          {"nonmanifold_vertices", m.nonmanifold_vertices},
          {"degenerate_faces", m.degenerate_faces},
          {"volume", m.volume},
          {"area", m.area},
          {"euler", m.euler},
          {"components", m.components.size()},
          {"bbox", {{"min", m.bbox_min}, {"max", m.bbox_max}}}};
}

}  // namespace qjulia::detail
