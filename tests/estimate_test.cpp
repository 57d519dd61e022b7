// The estimate of a run against what runs take: the peak memory of `qjulia mesh` (a process of
// its own each) within 1.5x of the estimate from 256 to 1024; refusals before the work.
#include "qjulia/pipeline/estimate.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <new>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "qjulia/base/error.h"
#include "qjulia/field/params.h"
#include "qjulia/pipeline/pipeline.h"

namespace qjulia {
namespace {

namespace fs = std::filesystem;

struct MeshRun {
  int code = -1;
  std::string err;
  nlohmann::json stats;
  bool written = false;
};

// `qjulia mesh ARGS -o x.ply --stats s.json` in a directory of its own, after the shell
// commands `before` (such as a ulimit). `written`: whether x.ply was there after.
MeshRun mesh(const std::string& args, const std::string& before = "") {
  const fs::path dir =
      fs::temp_directory_path() / ("qjulia_estimate_test_" + std::to_string(::getpid()) + "_" +
                                   std::to_string(std::hash<std::string>()(args)));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string cmd = "cd '" + dir.string() + "' && " + before + "'" QJULIA_CLI "' mesh " +
                          args + " --quiet -o x.ply --stats s.json 2> err.txt > /dev/null";
  MeshRun r;
  const int status = std::system(cmd.c_str());
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream err(dir / "err.txt");
  std::ostringstream s;
  s << err.rdbuf();
  r.err = s.str();
  if (fs::exists(dir / "s.json")) r.stats = nlohmann::json::parse(std::ifstream(dir / "s.json"));
  r.written = fs::exists(dir / "x.ply");
  fs::remove_all(dir);
  return r;
}

void expect_estimate_within_1_5x(const std::string& preset, int resolution) {
  SCOPED_TRACE(preset + " at " + std::to_string(resolution));
  const MeshRun r = mesh("--preset " + preset + " --resolution " + std::to_string(resolution));
  ASSERT_EQ(r.code, 0) << r.err;
  const double estimate = r.stats["estimate"]["peak_bytes"].get<double>();
  const double peak = r.stats["peak_rss_bytes"].get<double>();
  ASSERT_GT(peak, 0);
  EXPECT_LE(estimate, 1.5 * peak) << "estimate " << estimate / 1048576 << " MiB, peak "
                                  << peak / 1048576 << " MiB";
  EXPECT_GE(estimate, peak / 1.5) << "estimate " << estimate / 1048576 << " MiB, peak "
                                  << peak / 1048576 << " MiB";
  // The faces too, which the format limits go by.
  const double faces = r.stats["estimate"]["faces"].get<double>();
  const double actual = r.stats["faces"].get<double>();
  EXPECT_LE(faces, 1.5 * actual);
  EXPECT_GE(faces, actual / 1.5);
  // The memory bound by the output: newton-cubic peaks at most at twice its mesh (12 bytes a
  // vertex and a face) + 150 MB.
  if (preset == "newton-cubic" && resolution >= 512) {
    const double mesh_bytes = 12 * (r.stats["vertices"].get<double>() + actual);
    EXPECT_LE(peak, 2 * mesh_bytes + 150e6)
        << "peak " << peak / 1e6 << " MB, mesh " << mesh_bytes / 1e6 << " MB";
  }
}

TEST(Estimate, PeakMemoryWithinOneAndAHalfTimesAt256And512) {
  for (const char* preset : {"newton-cubic", "classic-julia", "rosa-rational", "sine-julia"})
    for (int resolution : {256, 512}) expect_estimate_within_1_5x(preset, resolution);
}

TEST(Estimate, PeakMemoryWithinOneAndAHalfTimesAt1024) {
  expect_estimate_within_1_5x("classic-julia", 1024);
  expect_estimate_within_1_5x("newton-cubic", 1024);
}

// Thickening re-meshes the surface on a level set of a quarter of the thickness: its faces and
// its memory, not the extracted mesh's, make the run's peak (classic-julia at 64 thickened by
// 0.035: 24,000 faces become about 700,000).
TEST(Estimate, PeakMemoryWithinOneAndAHalfTimesWhenThickening) {
  const MeshRun r = mesh("--preset classic-julia --resolution 64 --min-thickness 0.035");
  ASSERT_EQ(r.code, 0) << r.err;
  const double faces = r.stats["faces"].get<double>();
  const double thickened = r.stats["estimate"]["thickened_faces"].get<double>();
  EXPECT_GT(faces, 20 * r.stats["estimate"]["faces"].get<double>());
  EXPECT_LE(thickened, 1.5 * faces);
  EXPECT_GE(thickened, faces / 1.5);
  const double estimate = r.stats["estimate"]["peak_bytes"].get<double>();
  const double peak = r.stats["peak_rss_bytes"].get<double>();
  EXPECT_LE(estimate, 1.5 * peak) << estimate / 1048576 << " MiB, peak " << peak / 1048576;
  EXPECT_GE(estimate, peak / 1.5) << estimate / 1048576 << " MiB, peak " << peak / 1048576;
}

// check_run's refusal of a run: its TooLarge message, or "" (a failure) when it accepts it.
std::string refusal(const Params& p, const RunPlan& plan, const RunEstimate& e,
                    const MemoryLimits& limits) {
  try {
    check_run(p, plan, e, limits);
  } catch (const TooLarge& error) {
    return error.what();
  }
  ADD_FAILURE() << "resolution " << p.resolution << " (" << e.faces << " faces, "
                << e.largest_output << " bytes written) was accepted";
  return "";
}

// The resolution a refusal names as the largest that fits; 0 when it names none.
int offered_resolution(const std::string& what) {
  const std::string lead = "the largest resolution that fits is ";
  const auto at = what.find(lead);
  return at == std::string::npos ? 0 : std::stoi(what.substr(at + lead.size()));
}

TEST(Estimate, RefusesWhatDoesNotFitWithTheLargestResolutionThatDoes) {
  const MeshRun r = mesh("--resolution 2048 --max-memory 1G");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("1.00 GiB (--max-memory)"), std::string::npos) << r.err;
  const int fits = offered_resolution(r.err);
  ASSERT_GT(fits, 0) << r.err;
  EXPECT_GT(fits, 256);
  EXPECT_LT(fits, 2048);
  // That resolution is accepted under the same limit, and one well above it is not.
  const MeshRun ok = mesh("--resolution " + std::to_string(fits) + " --max-memory 1G");
  EXPECT_EQ(ok.code, 0) << ok.err;
  EXPECT_LE(ok.stats["peak_rss_bytes"].get<double>(), 1.5 * 1073741824.0);
  const MeshRun over = mesh("--resolution " + std::to_string(fits * 5 / 4) + " --max-memory 1G");
  EXPECT_EQ(over.code, 2) << over.err;
}

// The thickness a refusal names as the smallest that fits (mm); 0 when it names none.
double offered_thickness(const std::string& what) {
  const std::string lead = "the smallest minimum thickness that fits is ";
  const auto at = what.find(lead);
  return at == std::string::npos ? 0 : std::stod(what.substr(at + lead.size()));
}

// A thickness too fine for the memory (a 0.1 mm wall on an 80 mm ball is a level set of 88
// million faces) is refused before the work, naming the smallest thickness that fits; that one
// runs within the limit, and a finer one is refused.
TEST(Estimate, RefusesWhatDoesNotFitWithTheSmallestThicknessThatDoes) {
  const std::string ball = "--preset unit-ball --resolution 32 --size 80mm --max-memory 200M ";
  const MeshRun r = mesh(ball + "--min-thickness 0.1mm");
  EXPECT_EQ(r.code, 2);
  EXPECT_FALSE(r.written);
  EXPECT_EQ(r.err.find("qjulia mesh: a minimum thickness of 0.1 mm needs about "), 0u) << r.err;
  EXPECT_NE(r.err.find("200.0 MiB (--max-memory)"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << r.err;
  const double fits = offered_thickness(r.err);
  ASSERT_GT(fits, 0.1) << r.err;
  EXPECT_LT(fits, 10.0) << r.err;
  const MeshRun ok = mesh(ball + "--min-thickness " + std::to_string(fits) + "mm");
  EXPECT_EQ(ok.code, 0) << ok.err;
  EXPECT_LE(ok.stats["peak_rss_bytes"].get<double>(), 1.5 * 200 * 1048576.0);
  const MeshRun over = mesh(ball + "--min-thickness " + std::to_string(fits * 0.8) + "mm");
  EXPECT_EQ(over.code, 2) << over.err;
  EXPECT_NEAR(offered_thickness(over.err), fits, 0.011 * fits) << over.err;
}

// The faces of a thickened mesh decide what its formats hold, in the estimate itself: a level set
// of a 1 mm wall over a 2 m ball makes more faces than binary STL counts.
TEST(Estimate, AThickenedMeshIsCheckedAgainstItsFormats) {
  Params p = preset("unit-ball");
  p.resolution = 64;
  p.print.size_mm = 2000;
  p.print.min_thickness_mm = 1;
  RunPlan plan;
  plan.outputs = {MeshFormat::kStl};
  const RunEstimate e = estimate_run(p, plan);
  // 4 pi (1000 mm)^2 of surface at a voxel of 0.25 mm: about 16 faces a square millimetre.
  EXPECT_GT(double(e.thickened_faces), 1e8);
  EXPECT_EQ(e.final_faces, e.thickened_faces);
  MemoryLimits unlimited;
  EXPECT_NO_THROW(check_run(p, plan, e, unlimited));
  p.print.min_thickness_mm = 0.01;  // 10,000 times the faces: past STL's count
  const RunEstimate fine = estimate_at(p, plan, e, p.resolution);
  EXPECT_GT(double(fine.final_faces), 4294967295.0);
  const std::string what = refusal(p, plan, fine, unlimited);
  EXPECT_NE(what.find("STL's 32-bit count"), std::string::npos) << what;
  // Decimated to a million faces, it is written.
  p.mesh.faces = 1000000;
  EXPECT_NO_THROW(check_run(p, plan, estimate_at(p, plan, e, p.resolution), unlimited));
}

// Under an address-space limit (ulimit -v), a run completes or is refused before its work,
// naming that limit: the estimate counts what malloc reserves beyond the memory it holds, and
// no run starts that then runs out of address space. classic-julia at 512 on one thread and on
// two (a worker's heap), from limits that refuse it to limits it runs under.
TEST(Estimate, AddressSpaceLimitRefusesRatherThanRunningOut) {
  for (int threads : {1, 2}) {
    int completed = 0, refused = 0;
    for (int kib = 150000; kib <= 350000; kib += 50000) {
      SCOPED_TRACE(std::to_string(threads) + " threads, ulimit -v " + std::to_string(kib));
      const MeshRun r =
          mesh("--preset classic-julia --resolution 512 --threads " + std::to_string(threads),
               "ulimit -v " + std::to_string(kib) + " && ");
      if (r.code == 0) {
        ++completed;
        EXPECT_TRUE(r.written);
        continue;
      }
      ++refused;
      EXPECT_EQ(r.code, 2) << r.err;
      EXPECT_NE(r.err.find("needs about"), std::string::npos) << r.err;
      EXPECT_NE(r.err.find("(the address-space limit) is available"), std::string::npos) << r.err;
      EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "one line: " << r.err;
      EXPECT_FALSE(r.written);
    }
    EXPECT_GT(completed, 0) << threads << " threads";
    EXPECT_GT(refused, 0) << threads << " threads";
  }
}

// The message of the TooLarge that classic-julia at 64 ends in when an allocation fails in
// `stage` (a std::bad_alloc thrown from the stage's progress callback once it has begun); ""
// (a failure) when the run completes.
std::string out_of_memory_in(const std::string& stage) {
  Params p = preset("classic-julia");
  p.resolution = 64;
  PipelineOptions opts;
  opts.progress = [stage](const std::string& now, double f) -> bool {
    if (now == stage && (f > 0 || stage == "estimate")) throw std::bad_alloc();
    return true;
  };
  try {
    run_pipeline(p, opts);
  } catch (const TooLarge& e) {
    return e.what();
  }
  ADD_FAILURE() << "the run completed";
  return "";
}

// A run that runs out of memory all the same ends in one TooLarge naming the resolution, the
// stage, the memory held, the estimate and the limit, not a bare std::bad_alloc.
TEST(Estimate, ARunThatRunsOutOfMemoryNamesItsStageAndItsEstimate) {
  const std::string extract = out_of_memory_in("extract");
  EXPECT_EQ(extract.find("resolution 64 ran out of memory in the extract stage (peak "), 0u)
      << extract;
  EXPECT_NE(extract.find(" resident; estimated "), std::string::npos) << extract;
  EXPECT_NE(extract.find(", limit "), std::string::npos) << extract;
  EXPECT_EQ(extract.find('\n'), std::string::npos) << extract;
  // Before the estimate there is none to give.
  const std::string estimate = out_of_memory_in("estimate");
  EXPECT_NE(estimate.find("in the estimate stage (peak "), std::string::npos) << estimate;
  EXPECT_EQ(estimate.find("estimated"), std::string::npos) << estimate;
}

TEST(Estimate, RefusesAGlbBeyondFourGibibytesBeforeTheWork) {
  // The unit ball at 8192: about 300 million faces (its probes are quick, even under the
  // sanitizers).
  Params p = preset("unit-ball");
  p.resolution = 8192;
  RunPlan plan;
  plan.outputs = {MeshFormat::kGlb};
  const RunEstimate e = estimate_run(p, plan);
  EXPECT_GT(e.faces, 200000000u);
  MemoryLimits unlimited;
  const std::string what = refusal(p, plan, e, unlimited);
  EXPECT_NE(what.find("GLB holds at most 4 GiB"), std::string::npos) << what;
  EXPECT_NE(what.find(".ply"), std::string::npos) << what;
  // The same mesh as PLY, or decimated to a million faces as GLB, is accepted.
  plan.outputs = {MeshFormat::kPly};
  EXPECT_NO_THROW(check_run(p, plan, e, unlimited));
  p.mesh.faces = 1000000;
  plan.outputs = {MeshFormat::kGlb};
  EXPECT_NO_THROW(check_run(p, plan, estimate_at(p, plan, e, p.resolution), unlimited));
}

// Binary STL counts its triangles in 32 bits: a mesh of more faces (but fewer than 2^32
// vertices) is refused before the work as STL, and accepted as OBJ.
TEST(Estimate, RefusesAnStlOfMoreThanFourBillionFaces) {
  Params p = preset("unit-ball");
  p.resolution = 512;
  RunPlan plan;
  plan.outputs = {MeshFormat::kStl};
  const RunEstimate base = estimate_run(p, plan);
  // The resolution where the estimate reaches six billion faces (3 billion vertices).
  const double r = 512 * std::pow(6e9 / double(base.faces), 1 / base.exponent);
  p.resolution = static_cast<int>(r);
  const RunEstimate e = estimate_at(p, plan, base, p.resolution);
  ASSERT_GT(double(e.faces), 4294967295.0);
  ASSERT_LT(double(e.vertices), 4294967295.0);
  MemoryLimits unlimited;
  const std::string what = refusal(p, plan, e, unlimited);
  EXPECT_NE(what.find("STL's 32-bit count"), std::string::npos) << what;
  plan.outputs = {MeshFormat::kObj};
  EXPECT_NO_THROW(check_run(p, plan, estimate_at(p, plan, base, p.resolution), unlimited));
}

// The resolution a memory refusal offers is one the run then accepts: in memory and in its output
// formats (a GLB of the largest resolution that fits in 64 GiB would pass GLB's 4 GiB).
TEST(Estimate, TheLargestResolutionOfferedFitsTheOutputFormatsToo) {
  Params p = preset("unit-ball");
  p.resolution = 100000;
  MemoryLimits limits;
  limits.requested = std::size_t(64) << 30;
  for (MeshFormat format : {MeshFormat::kGlb, MeshFormat::kPly}) {
    RunPlan plan;
    plan.outputs = {format};
    const std::string what = refusal(p, plan, estimate_run(p, plan), limits);
    const int fits = offered_resolution(what);
    ASSERT_GT(fits, 256) << what;
    Params q = p;
    q.resolution = fits;
    EXPECT_NO_THROW(check_run(q, plan, estimate_run(q, plan), limits)) << what;
    q.resolution = fits * 11 / 10;
    EXPECT_THROW(check_run(q, plan, estimate_run(q, plan), limits), TooLarge) << what;
    // GLB's 4 GiB holds fewer faces than 64 GiB of memory makes: it is what binds, and the
    // message says so; PLY is bound by the memory alone.
    EXPECT_EQ(what.find("held back by GLB's 4 GiB") != std::string::npos,
              format == MeshFormat::kGlb)
        << what;
  }
}

TEST(Estimate, ScalesWithTheResolution) {
  // A sphere's crossing cells grow as the square of the resolution.
  Params p = preset("unit-ball");
  p.resolution = 512;
  const RunEstimate e = estimate_run(p, RunPlan{});
  EXPECT_NEAR(e.exponent, 2.0, 0.1);
  const RunEstimate twice = estimate_at(p, RunPlan{}, e, 1024);
  EXPECT_NEAR(double(twice.cells) / double(e.cells), 4.0, 0.5);
  // The largest resolution that fits a budget has an estimate within it, and the next does not.
  const std::size_t budget = std::size_t(1) << 30;
  const int fits = largest_fitting_resolution(p, RunPlan{}, e, budget);
  EXPECT_LE(estimate_at(p, RunPlan{}, e, fits).peak_bytes, budget);
  EXPECT_GT(estimate_at(p, RunPlan{}, e, fits + 1).peak_bytes, budget);
}

TEST(Estimate, ProbesAtAQuarterOfTheRunUpTo256OrFrom2048On512) {
  Params p = preset("unit-ball");
  for (const auto& [resolution, probe] :
       std::vector<std::pair<int, int>>{{512, 128}, {1024, 256}, {2047, 256}, {2048, 512}}) {
    p.resolution = resolution;
    const RunEstimate e = estimate_run(p, RunPlan{});
    EXPECT_EQ(e.probe_resolution, probe) << resolution;
    // A sphere's bricks grow as the square of the resolution, as its crossing cells do, once
    // the probes see more than a few bricks across it (at 64 and 128: 2.3).
    if (resolution >= 1024) {
      EXPECT_NEAR(e.brick_exponent, 2.0, 0.1) << resolution;
    }
    std::printf("%d: probes at %d, bricks as N^%.3f, crossing cells as N^%.3f\n", resolution,
                e.probe_resolution, e.brick_exponent, e.exponent);
  }
  // A run the probes at 128 and 256 put above twice its limit is refused on them, at once; one
  // within twice its limit gets the probe at 512.
  p.resolution = 1024;  // probes at 128 and 256: their estimate of 2048
  const RunEstimate first = estimate_at(p, RunPlan{}, estimate_run(p, RunPlan{}), 2048);
  p.resolution = 2048;
  RunPlan plan;
  plan.limit = first.peak_bytes / 3;
  EXPECT_EQ(estimate_run(p, plan).probe_resolution, 256);
  plan.limit = first.peak_bytes;
  EXPECT_EQ(estimate_run(p, plan).probe_resolution, 512);
}

// Where the bricks outweigh the mesh (many level-8 candidates, few crossing cells), the
// sampling's end is the peak: about 1330 bytes a brick.
TEST(Estimate, CountsTheSamplingsBricksWhereTheyOutweighTheMesh) {
  Params p = preset("unit-ball");
  p.resolution = 1024;
  RunEstimate base;
  base.probe_resolution = 256;
  base.probe_cells = 10000;
  base.probe_bricks = 100000;
  base.exponent = 2;
  base.brick_exponent = 2;
  const RunEstimate e = estimate_at(p, RunPlan{}, base, 1024);
  // 1.6M bricks at 1024; the crossing cells alone (160,000) would make about 41 MB.
  EXPECT_GT(double(e.peak_bytes), 1330.0 * 1.6e6);
  EXPECT_LT(double(e.peak_bytes), 1.5 * 1330.0 * 1.6e6);
}

}  // namespace
}  // namespace qjulia
