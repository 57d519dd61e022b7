#include "api.h"

#include <atomic>
#include <chrono>
#include <nlohmann/json.hpp>
#include <regex>

#include "qjulia/base/error.h"
#include "qjulia/io/mesh_io.h"
#include "qjulia/mesh/compare.h"
#include "qjulia/pipeline/pipeline.h"

namespace qjulia::explore {
namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

constexpr const char* kFormats[] = {"glb", "gltf", "obj", "ply", "stl", "3mf"};

Reply json_reply(const json& j, int status = 200) {
  Reply r;
  r.status = status;
  r.body = j.dump();
  return r;
}

// A parameter set as the page edits it (the parameter file as a JSON object).
json params_json(const Params& p) { return json::parse(params_to_json(p, false)); }

// The body of a request that carries a JSON object. @throws InvalidInput.
json parse_object(const std::string& body) {
  json j;
  try {
    j = json::parse(body);
  } catch (const json::exception& e) {
    throw InvalidInput(std::string("request: not valid JSON: ") + e.what());
  }
  if (!j.is_object()) throw InvalidInput("request: a JSON object is expected");
  return j;
}

// The member `key` of a request object. @throws InvalidInput when it is missing.
const json& member(const json& j, const char* key, const char* what) {
  if (!j.contains(key))
    throw InvalidInput(std::string("request: '") + key + "' is missing (" + what + ")");
  return j[key];
}

// Where a message points: "formula 1:16: ..." (the formula's line and column) or nlohmann's
// "line 1, column 21" (the JSON text's).
void add_position(json& j, const std::string& message) {
  static const std::regex kFormula(R"(formula (\d+):(\d+):)");
  static const std::regex kJson(R"(line (\d+), column (\d+))");
  std::smatch m;
  if (std::regex_search(message, m, kFormula)) {
    j["key"] = "formula";
  } else if (std::regex_search(message, m, kJson)) {
    j["key"] = "json";
  } else {
    return;
  }
  j["line"] = std::stoi(m[1].str());
  j["column"] = std::stoi(m[2].str());
}

json mesh_figures(const PreviewMesh& m, const Params& p, bool cached) {
  const MeshMeasure& s = m.stats.measure;
  return {{"faces", s.faces},
          {"vertices", s.vertices},
          {"volume", s.volume},
          {"area", s.area},
          {"closed", s.closed},
          {"manifold", s.manifold},
          {"components", s.components.size()},
          {"evaluations", m.stats.evaluations},
          {"resolution", p.resolution},
          {"seconds", m.seconds},
          {"cached", cached}};
}

const char* content_type_of(MeshFormat f) {
  switch (f) {
    case MeshFormat::kGlb:
      return "model/gltf-binary";
    case MeshFormat::kGltf:
      return "model/gltf+json";
    case MeshFormat::kObj:
      return "model/obj";
    case MeshFormat::kStl:
      return "model/stl";
    case MeshFormat::k3mf:
      return "model/3mf";
    case MeshFormat::kPly:
      break;
  }
  return "application/octet-stream";
}

}  // namespace

Api::Api(ApiOptions options)
    : options_(std::move(options)), exports_(options_.work_dir, options_.export_memory) {
  json list = json::array();
  for (const std::string& name : preset_names())
    list.push_back({{"name", name},
                    {"description", preset_description(name)},
                    {"params", params_json(preset(name))}});
  presets_json_ = list.dump();
}

Reply Api::info() const {
  json formats = json::array();
  for (const char* f : kFormats) formats.push_back(f);
  return json_reply(
      {{"version", version()},
       {"initial", params_json(options_.initial)},
       {"initial_name", options_.initial_name},
       {"preview_max_resolution", options_.preview_max_resolution},
       {"max_body_bytes", options_.max_body},
       {"preview_memory_bytes", options_.preview_memory},
       {"export_memory_bytes", options_.export_memory},
       {"compare_samples", {{"min", kCompareSamplesRange.min}, {"max", kCompareSamplesRange.max}}},
       {"formats", formats}});
}

Reply Api::presets() const {
  Reply r;
  r.body = presets_json_;
  return r;
}

Reply Api::check(const std::string& body) const {
  try {
    return json_reply({{"ok", true}, {"params", params_json(parse_params(body, "parameters"))}});
  } catch (const InvalidInput& e) {
    json j = {{"ok", false}, {"error", e.what()}};
    add_position(j, e.what());
    return json_reply(j);
  }
}

Params Api::parse_preview(const std::string& json_text, const std::string& source) const {
  Params p = parse_params(json_text, source);
  if (p.resolution > options_.preview_max_resolution)
    throw InvalidInput(source + ": 'resolution' " + std::to_string(p.resolution) +
                       " is above the preview limit of " +
                       std::to_string(options_.preview_max_resolution) +
                       " (an export runs at any resolution)");
  return p;
}

std::shared_ptr<const PreviewMesh> Api::preview_mesh(const Params& params,
                                                     const std::string& source,
                                                     const CancelToken& cancel, bool* cached) {
  const std::string key = params_to_json(params, false);
  if (auto hit = cache_.find(key)) {
    *cached = true;
    return hit;
  }
  *cached = false;
  PipelineOptions popts;
  popts.cancel = &cancel;
  popts.max_memory = options_.preview_memory;
  popts.outputs = {MeshFormat::kGlb};
  const auto begin = Clock::now();
  PipelineResult result = run_pipeline(params, popts);
  if (result.mesh.triangles.empty())
    throw InvalidInput(source + ": " + empty_solid(params, result.stats));
  auto mesh = std::make_shared<PreviewMesh>();
  mesh->mesh = std::move(result.mesh);
  mesh->stats = std::move(result.stats);
  mesh->seconds = std::chrono::duration<double>(Clock::now() - begin).count();
  cache_.put(key, mesh);
  return mesh;
}

Reply Api::mesh(const std::string& body) {
  const Params params = parse_preview(body, "parameters");
  Reply reply;
  lane_.run([&](const CancelToken& cancel) {
    bool cached = false;
    const auto mesh = preview_mesh(params, "parameters", cancel, &cached);
    // The GLB writer writes files: one in the server's directory, read back and removed.
    static std::atomic<std::uint64_t> counter{0};
    const std::filesystem::path path =
        options_.work_dir / ("preview-" + std::to_string(++counter) + ".glb");
    ExportOptions eopts;
    eopts.params_json = params_to_json(params);
    eopts.cancel = &cancel;
    write_mesh(path.string(), mesh->mesh, eopts);
    try {
      reply.body = read_file(path);
    } catch (...) {
      std::filesystem::remove(path);
      throw;
    }
    std::filesystem::remove(path);
    reply.content_type = "model/gltf-binary";
    reply.headers.emplace_back("X-Qjulia-Stats", mesh_figures(*mesh, params, cached).dump());
  });
  return reply;
}

Reply Api::compare(const std::string& body) {
  const json request = parse_object(body);
  const Params a = parse_preview(member(request, "a", "the first parameter set").dump(), "a");
  const Params b = parse_preview(member(request, "b", "the second parameter set").dump(), "b");
  CompareOptions copts;
  copts.samples = 200000;
  if (request.contains("samples")) {
    const json& s = request["samples"];
    if (!s.is_number_integer() || !kCompareSamplesRange.contains(s.get<double>()))
      throw InvalidInput("request: 'samples' must be an integer in " +
                         to_string(kCompareSamplesRange));
    copts.samples = s.get<std::size_t>();
  }
  json answer;
  lane_.run([&](const CancelToken& cancel) {
    bool cached_a = false, cached_b = false;
    const auto ma = preview_mesh(a, "a", cancel, &cached_a);
    const auto mb = preview_mesh(b, "b", cancel, &cached_b);
    copts.cancel = &cancel;
    const auto begin = Clock::now();
    const CompareResult result = qjulia::compare(ma->mesh, mb->mesh, copts);
    answer = json::parse(compare_to_json(result, "a", "b"));
    answer["samples"] = copts.samples;
    answer["seconds"] = std::chrono::duration<double>(Clock::now() - begin).count();
    answer["a_figures"] = mesh_figures(*ma, a, cached_a);
    answer["b_figures"] = mesh_figures(*mb, b, cached_b);
  });
  return json_reply(answer);
}

Reply Api::stop_preview() { return json_reply({{"stopped", lane_.stop()}}); }

Reply Api::start_export(const std::string& body) {
  const json request = parse_object(body);
  const Params params =
      parse_params(member(request, "params", "the parameter set").dump(), "params");
  const json& f = member(request, "format", "glb, gltf, obj, ply, stl or 3mf");
  const std::string format = f.is_string() ? f.get<std::string>() : f.dump();
  bool known = false;
  for (const char* k : kFormats) known = known || format == k;
  if (!known)
    throw InvalidInput("request: 'format' must be one of glb, gltf, obj, ply, stl, 3mf, not '" +
                       format + "'");
  const std::uint64_t id = exports_.start(params, format_from_path("export." + format));
  Reply r = export_status(id);
  r.status = 202;
  return r;
}

Reply Api::export_status(std::uint64_t id) const {
  const auto s = exports_.status(id);
  if (!s) return error(404, "no export " + std::to_string(id) + " (only the newest one is kept)");
  json j = {{"id", s->id},
            {"state", s->state},
            {"stage", s->stage},
            {"stage_fraction", s->stage_fraction},
            {"progress", s->progress},
            {"format", s->format},
            {"seconds", s->seconds}};
  if (!s->error.empty()) j["error"] = s->error;
  if (s->state == "done") {
    j["bytes"] = s->bytes;
    j["faces"] = s->faces;
    j["file"] = "/api/export/" + std::to_string(id) + "/file";
  }
  return json_reply(j);
}

Reply Api::export_file(std::uint64_t id) const {
  const auto s = exports_.status(id);
  const auto file = exports_.file(id);
  if (!s || !file)
    return error(404, "export " + std::to_string(id) + " has no file (not done, or dropped)");
  Reply r;
  r.file = *file;
  r.content_type = content_type_of(format_from_path(file->string()));
  // No file name: the page names the download (a name here would take precedence).
  r.headers.emplace_back("Content-Disposition", "attachment");
  return r;
}

Reply Api::cancel_export(std::uint64_t id) {
  if (!exports_.cancel(id)) return error(404, "no export " + std::to_string(id));
  return export_status(id);
}

void Api::shutdown() {
  lane_.shutdown();
  exports_.shutdown();
}

Reply Api::error(int status, const std::string& message) {
  return json_reply({{"error", message}}, status);
}

Reply Api::guarded(const std::function<Reply()>& route) {
  try {
    return route();
  } catch (const PreviewCancelled& e) {
    Reply r = json_reply({{"error", e.what()}, {"cancelled", true}}, 409);
    return r;
  } catch (const ExportBusy& e) {
    return json_reply({{"error", e.what()}, {"running", e.running()}}, 409);
  } catch (const TooLarge& e) {
    return json_reply({{"error", e.what()}, {"too_large", true}}, 400);
  } catch (const InvalidInput& e) {
    json j = {{"error", e.what()}};
    add_position(j, e.what());
    if (says_empty_solid(e.what())) j["empty"] = true;
    return json_reply(j, 400);
  } catch (const Cancelled&) {
    return error(503, "the server is shutting down");
  } catch (const std::exception& e) {
    return error(500, std::string("error: ") + e.what());
  }
}

}  // namespace qjulia::explore
