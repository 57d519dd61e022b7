#include "export_jobs.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <utility>
#include <vector>

#include "preview.h"
#include "qjulia/base/atomic_file.h"
#include "qjulia/base/error.h"
#include "qjulia/pipeline/pipeline.h"

namespace qjulia::explore {
namespace {

using Clock = std::chrono::steady_clock;

// The usual share of each stage in a run's time, for one progress bar over all of them; a stage
// not listed (a new one) counts as nothing.
constexpr std::array<std::pair<const char*, double>, 10> kStageWeights{{{"estimate", 0.3},
                                                                        {"sample", 4},
                                                                        {"extract", 3},
                                                                        {"clean", 0.5},
                                                                        {"scale", 0.1},
                                                                        {"thicken", 2},
                                                                        {"decimate", 2},
                                                                        {"check", 1},
                                                                        {"measure", 0.3},
                                                                        {"write", 1}}};

double stage_weight(const std::string& stage) {
  for (const auto& [name, weight] : kStageWeights)
    if (stage == name) return weight;
  return 0;
}

// The stages a run of `params` goes through, by weight.
double total_weight(const Params& params) {
  double total = stage_weight("estimate") + stage_weight("sample") + stage_weight("extract") +
                 stage_weight("clean") + stage_weight("measure") + stage_weight("write");
  if (params.print.size_mm) total += stage_weight("scale");
  if (params.print.min_thickness_mm) total += stage_weight("thicken");
  if (params.mesh.faces || params.mesh.max_error) total += stage_weight("decimate");
  if (params.print.check) total += stage_weight("check");
  return total;
}

std::string base64(const std::string& bytes) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(bytes[k]); };
  for (; i + 2 < bytes.size(); i += 3) {
    const unsigned v = byte(i) << 16 | byte(i + 1) << 8 | byte(i + 2);
    for (int shift : {18, 12, 6, 0}) out += kAlphabet[(v >> shift) & 63];
  }
  if (i + 1 == bytes.size()) {
    const unsigned v = byte(i) << 16;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == bytes.size()) {
    const unsigned v = byte(i) << 16 | byte(i + 1) << 8;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

}  // namespace

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path.string());
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void embed_gltf_buffers(const std::filesystem::path& path) {
  auto doc = nlohmann::ordered_json::parse(read_file(path));
  std::vector<std::filesystem::path> embedded;
  for (auto& buffer : doc["buffers"]) {
    if (!buffer.contains("uri")) continue;
    const std::string uri = buffer["uri"].get<std::string>();
    if (uri.rfind("data:", 0) == 0) continue;
    // The writer names the buffer after the file, beside it: no directory in the name.
    if (uri.find('/') != std::string::npos || uri.find('%') != std::string::npos)
      throw std::runtime_error("unexpected buffer uri '" + uri + "' in " + path.string());
    const std::filesystem::path bin = path.parent_path() / uri;
    buffer["uri"] = "data:application/octet-stream;base64," + base64(read_file(bin));
    embedded.push_back(bin);
  }
  AtomicFile out(path.string());
  out.write(doc.dump());
  out.commit();
  for (const auto& bin : embedded) std::filesystem::remove(bin);
}

struct ExportJobs::Job {
  CancelToken cancel;
  Clock::time_point begin = Clock::now();
  Clock::time_point end;
  double done_weight = 0;  // of the stages that ended
  double total_weight = 1;
  ExportStatus status;         // guarded by ExportJobs::mutex_
  std::filesystem::path file;  // when done
  MeshFormat format = MeshFormat::kGlb;
};

ExportJobs::ExportJobs(std::filesystem::path dir, std::size_t max_memory)
    : dir_(std::move(dir)), max_memory_(max_memory) {}

ExportJobs::~ExportJobs() { shutdown(); }

std::uint64_t ExportJobs::start(const Params& params, MeshFormat format) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (shut_down_) throw Cancelled();
  if (job_ && job_->status.state == "running") throw ExportBusy(job_->status.id);
  if (thread_.joinable()) thread_.join();  // it has ended
  if (job_ && !job_->file.empty()) {
    std::error_code ignored;
    std::filesystem::remove(job_->file, ignored);
  }
  auto job = std::make_shared<Job>();
  job->format = format;
  job->total_weight = total_weight(params);
  job->status.id = next_id_++;
  job->status.state = "running";
  job->status.format = std::string(extension_of(format)).substr(1);
  job_ = job;
  thread_ = std::thread([this, job, params] { run(job, params); });
  return job->status.id;
}

void ExportJobs::run(const std::shared_ptr<Job>& job, const Params& params) {
  // Progress of a stage: a new stage adds the weight of the one before to what is done.
  const auto report = [this, &job](const std::string& stage, double fraction) {
    std::lock_guard<std::mutex> lock(mutex_);
    ExportStatus& s = job->status;
    if (stage != s.stage) {
      job->done_weight += stage_weight(s.stage);
      s.stage = stage;
    }
    s.stage_fraction = std::clamp(fraction, 0.0, 1.0);
    s.progress = std::min(
        1.0, (job->done_weight + stage_weight(stage) * s.stage_fraction) / job->total_weight);
    return true;
  };
  const std::filesystem::path file =
      dir_ / ("export-" + std::to_string(job->status.id) + extension_of(job->format));
  std::string state = "done", error;
  std::size_t faces = 0;
  try {
    PipelineOptions popts;
    popts.cancel = &job->cancel;
    popts.max_memory = max_memory_;
    popts.progress = report;
    popts.outputs = {job->format};  // a mesh too large for the format is refused before the work
    PipelineResult result = run_pipeline(params, popts);
    if (result.mesh.triangles.empty()) throw InvalidInput(empty_solid(params, result.stats));
    faces = result.mesh.triangles.size();
    ExportOptions eopts;
    eopts.params_json = params_to_json(params);
    eopts.unit = result.stats.unit;
    eopts.cancel = &job->cancel;
    eopts.progress = [&report](double f) { return report("write", f); };
    write_mesh(file.string(), result.mesh, eopts);
    if (job->format == MeshFormat::kGltf) embed_gltf_buffers(file);
  } catch (const Cancelled&) {
    state = "cancelled";
  } catch (const InvalidInput& e) {
    state = "failed";
    error = e.what();
  } catch (const std::exception& e) {
    state = "failed";
    error = std::string("error: ") + e.what();
  }
  if (state != "done") {
    std::error_code ignored;
    for (const auto& f : output_files(file.string())) std::filesystem::remove(f, ignored);
  }
  std::error_code size_error;
  const auto bytes = state == "done" ? std::filesystem::file_size(file, size_error) : 0;
  std::lock_guard<std::mutex> lock(mutex_);
  job->end = Clock::now();
  ExportStatus& s = job->status;
  s.state = state;
  s.error = error;
  s.faces = faces;
  if (state == "done") {
    job->file = file;
    s.bytes = size_error ? 0 : bytes;
    s.progress = 1;
  }
}

std::optional<ExportStatus> ExportJobs::status(std::uint64_t id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!job_ || job_->status.id != id) return std::nullopt;
  ExportStatus s = job_->status;
  const auto end = s.state == "running" ? Clock::now() : job_->end;
  s.seconds = std::chrono::duration<double>(end - job_->begin).count();
  return s;
}

std::optional<std::filesystem::path> ExportJobs::file(std::uint64_t id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!job_ || job_->status.id != id || job_->file.empty()) return std::nullopt;
  return job_->file;
}

bool ExportJobs::cancel(std::uint64_t id) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!job_ || job_->status.id != id) return false;
  job_->cancel.request();
  return true;
}

void ExportJobs::shutdown() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    shut_down_ = true;
    if (job_) job_->cancel.request();
  }
  if (thread_.joinable()) thread_.join();
}

}  // namespace qjulia::explore
