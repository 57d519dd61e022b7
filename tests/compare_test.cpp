// compare: distances between surfaces with known answers (identical, refined, shifted meshes),
// and the `qjulia compare` / `qjulia experiment` commands end to end.
#include "qjulia/mesh/compare.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "base/bvh.h"
#include "io_fixtures.h"
#include "qjulia/base/error.h"
#include "qjulia/field/params.h"
#include "qjulia/io/mesh_io.h"
#include "qjulia/pipeline/pipeline.h"
#include "test_meshes.h"

namespace {

using qjulia::TriMesh;

using fixtures::icosphere;

// The unit cube [0, 1]^3, outward, 12 triangles.
TriMesh cube() {
  TriMesh m;
  for (int i = 0; i < 8; ++i)
    m.positions.push_back(
        {static_cast<float>(i & 1), static_cast<float>((i >> 1) & 1), static_cast<float>(i >> 2)});
  m.triangles = {{0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}, {0, 1, 5}, {0, 5, 4},
                 {2, 6, 7}, {2, 7, 3}, {0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}};
  return m;
}

TriMesh shifted(TriMesh m, float dx, float dy, float dz) {
  for (auto& p : m.positions) {
    p[0] += dx;
    p[1] += dy;
    p[2] += dz;
  }
  return m;
}

// The longest edge of a mesh.
double max_edge(const TriMesh& m) {
  double e = 0;
  for (const auto& f : m.triangles)
    for (int k = 0; k < 3; ++k) {
      const auto &a = m.positions[f[k]], &b = m.positions[f[(k + 1) % 3]];
      e = std::max(e, std::hypot(double(a[0] - b[0]), double(a[1] - b[1]), double(a[2] - b[2])));
    }
  return e;
}

qjulia::CompareOptions small_options() {
  qjulia::CompareOptions o;
  o.samples = 200000;
  return o;
}

}  // namespace

TEST(Compare, IdenticalMeshesCompareAtDistanceZero) {
  const TriMesh sphere = icosphere(3);
  const auto r = qjulia::compare(sphere, sphere, small_options());
  EXPECT_LT(r.hausdorff, 1e-6);
  EXPECT_LT(r.a_to_b.mean, 1e-7);
  EXPECT_LT(r.b_to_a.rms, 1e-7);
  EXPECT_EQ(r.a_to_b.samples, small_options().samples);  // the vertices count towards them
  ASSERT_EQ(r.a_vertex_distance.size(), sphere.vertex_count());
  for (float d : r.a_vertex_distance) EXPECT_EQ(d, 0.0f);
}

TEST(Compare, UnitSphereAtTwoResolutionsComparesWithinOneEdgeOfTheCoarser) {
  const TriMesh coarse = icosphere(2), fine = icosphere(5);
  const double edge = max_edge(coarse);
  const auto r = qjulia::compare(coarse, fine, small_options());
  EXPECT_GT(r.hausdorff, 0.0);
  EXPECT_LT(r.hausdorff, edge);
  // Both inscribed in the unit sphere: the coarse one lies inside the fine one, farthest at
  // face centres, where it is at most the sagitta of its edges away.
  EXPECT_LT(r.hausdorff, edge * edge / 2);
  EXPECT_LE(r.a_to_b.mean, r.a_to_b.rms);
  EXPECT_LE(r.a_to_b.rms, r.a_to_b.max);
  EXPECT_DOUBLE_EQ(r.hausdorff, std::max(r.a_to_b.max, r.b_to_a.max));
}

TEST(Compare, ShiftedCubeComparesExactlyAtTheShift) {
  // The corner (1,1,1) + s moves farthest from the unit cube: the distance is |s|, exactly.
  const TriMesh a = cube();
  const float s = 0.1f;
  const auto r = qjulia::compare(a, shifted(a, s, s, s), small_options());
  EXPECT_NEAR(r.hausdorff, std::sqrt(3.0) * s, 1e-6);
  EXPECT_NEAR(r.a_to_b.max, std::sqrt(3.0) * s, 1e-6);
  EXPECT_NEAR(r.b_to_a.max, std::sqrt(3.0) * s, 1e-6);
}

TEST(Compare, ShiftedSphereComparesAtTheShiftWithinSamplingTolerance) {
  // For the exact sphere the distance to a copy shifted by s is |s|. The icosphere is within
  // its sagitta e of the sphere, and the samples are about `gap` apart.
  const TriMesh a = icosphere(4);
  const double edge = max_edge(a), sagitta = edge * edge / 2, gap = edge / 4;
  const float s = 0.05f;
  const auto r = qjulia::compare(a, shifted(a, s, 0, 0), small_options());
  EXPECT_LE(r.hausdorff, s + 2 * sagitta);
  EXPECT_GE(r.hausdorff, s - 2 * sagitta - gap);
  EXPECT_LT(r.a_to_b.mean, s);  // most of the surface moves less than the shift
  EXPECT_GT(r.a_to_b.mean, 0.25 * s);
}

TEST(Compare, TheSameInputGivesTheSameResult) {
  const TriMesh a = icosphere(3), b = shifted(icosphere(2), 0.02f, -0.01f, 0.03f);
  const auto r1 = qjulia::compare(a, b, small_options());
  const auto r2 = qjulia::compare(a, b, small_options());
  EXPECT_EQ(r1.hausdorff, r2.hausdorff);
  EXPECT_EQ(r1.a_to_b.mean, r2.a_to_b.mean);
  EXPECT_EQ(r1.b_to_a.rms, r2.b_to_a.rms);
  EXPECT_EQ(r1.a_vertex_distance, r2.a_vertex_distance);
}

TEST(Compare, MeasuresBothSurfaces) {
  const TriMesh a = cube(), b = icosphere(3);
  const auto r = qjulia::compare(a, b, small_options());
  EXPECT_EQ(r.a.faces, 12u);
  EXPECT_EQ(r.a.vertices, 8u);
  EXPECT_NEAR(r.a.volume, 1.0, 1e-6);
  EXPECT_NEAR(r.a.area, 6.0, 1e-6);
  EXPECT_EQ(r.b.faces, b.face_count());
  EXPECT_EQ(qjulia::genus_summary(r.a), "genus 0 x1");
}

// A file that splits its vertices at seams (glTF and PLY exporters give each face of a cube its
// own four) is measured with them merged: closed, one component, Euler characteristic 2, as the
// same cube with shared vertices; the distances are those of the shared cube.
TEST(Compare, VerticesSplitAtSeamsAreMergedForTheMeasures) {
  const TriMesh shared = cube();
  TriMesh split;
  for (const auto& t : shared.triangles) {
    const auto base = static_cast<std::uint32_t>(split.positions.size());
    for (std::uint32_t v : t) split.positions.push_back(shared.positions[v]);
    split.triangles.push_back({base, base + 1, base + 2});
  }
  ASSERT_EQ(split.positions.size(), 36u);
  const auto r = qjulia::compare(split, shared, small_options());
  EXPECT_EQ(r.a_welded, 28u);
  EXPECT_EQ(r.b_welded, 0u);
  EXPECT_EQ(r.a.vertices, 8u);
  EXPECT_EQ(r.a.faces, 12u);
  EXPECT_TRUE(r.a.closed);
  EXPECT_TRUE(r.a.manifold);
  EXPECT_EQ(r.a.components.size(), 1u);
  EXPECT_EQ(r.a.euler, 2);
  EXPECT_NEAR(r.a.volume, 1.0, 1e-6);
  EXPECT_LT(r.hausdorff, 1e-6);  // the same surface, to float rounding
  const auto j = nlohmann::json::parse(qjulia::compare_to_json(r, "split", "shared"));
  EXPECT_EQ(j["a_welded_vertices"], 28);
  EXPECT_EQ(j["b_welded_vertices"], 0);
}

TEST(Compare, AnEmptyOrBrokenMeshIsInvalidInput) {
  const TriMesh empty;
  EXPECT_THROW(qjulia::compare(empty, cube()), qjulia::InvalidInput);
  EXPECT_THROW(qjulia::compare(cube(), empty), qjulia::InvalidInput);
  TriMesh broken = cube();
  broken.triangles[3][1] = 99;
  EXPECT_THROW(qjulia::compare(broken, cube()), qjulia::InvalidInput);
  TriMesh nan = cube();
  nan.positions[2][1] = std::nanf("");
  EXPECT_THROW(qjulia::compare(cube(), nan), qjulia::InvalidInput);
}

// More samples than the CLI's --samples takes are refused before any is drawn (a caller of the
// library, such as the Python module, could otherwise ask for 10^12 of 32 bytes each).
TEST(Compare, MoreSamplesThanTheMostIsInvalidInput) {
  qjulia::CompareOptions opts;
  opts.samples = qjulia::kMostCompareSamples + 1;
  EXPECT_THROW(qjulia::compare(cube(), cube(), opts), qjulia::InvalidInput);
  opts.samples = 1000;
  EXPECT_LT(qjulia::compare(cube(), cube(), opts).hausdorff, 1e-6);
}

TEST(Compare, ProgressCanCancel) {
  auto o = small_options();
  o.progress = [](double f) { return f < 0.5; };
  EXPECT_THROW(qjulia::compare(icosphere(4), icosphere(3), o), qjulia::Cancelled);
}

TEST(Compare, DistanceColorsRampFromBlueToRed) {
  const auto c = qjulia::distance_colors({0.0f, 0.5f, 1.0f, 2.0f, -1.0f}, 0.0, 1.0);
  ASSERT_EQ(c.size(), 5u);
  EXPECT_GT(c[0][2], c[0][0]);  // low: blue
  EXPECT_GT(c[2][0], c[2][2]);  // high: red
  EXPECT_EQ(c[3], c[2]);        // clamped
  EXPECT_EQ(c[4], c[0]);
  for (const auto& rgb : c)
    for (float x : rgb) {
      EXPECT_GE(x, 0.0f);
      EXPECT_LE(x, 1.0f);
    }
}

// ---------------------------------------------------------------------------------------------
// The methods compared: the escape method fails on Newton's cubic (docs/design.md; the paper's
// table 1). Its solid is the bailout ball with holes, the cut-off solid a thin shell around J.

TEST(Compare, UnitBallMeshedAtTwoResolutionsComparesWithinOneVoxelOfTheCoarser) {
  qjulia::Params coarse = qjulia::preset("unit-ball"), fine = coarse;
  coarse.resolution = 24;
  fine.resolution = 48;
  const TriMesh a = qjulia::run_pipeline(coarse).mesh, b = qjulia::run_pipeline(fine).mesh;
  const double voxel = (coarse.bounds.max[0] - coarse.bounds.min[0]) / coarse.resolution;
  const auto r = qjulia::compare(a, b, small_options());
  EXPECT_GT(r.hausdorff, 0.0);
  EXPECT_LT(r.hausdorff, voxel);
  EXPECT_NEAR(r.a.volume, 4.0 / 3 * M_PI, 0.05 * 4.0 / 3 * M_PI);
}

TEST(Compare, EscapeMethodOnNewtonsCubicIsFarFromTheCutOffSurface) {
  qjulia::Params cut = qjulia::preset("newton-cubic"), esc = qjulia::preset("newton-escape");
  cut.resolution = esc.resolution = 32;
  const TriMesh a = qjulia::run_pipeline(cut).mesh, b = qjulia::run_pipeline(esc).mesh;
  ASSERT_GT(a.face_count(), 0u);
  ASSERT_GT(b.face_count(), 0u);
  const auto r = qjulia::compare(a, b, small_options());
  // The escape solid fills most of the ball of radius 2 (volume 33.5); the shell is thin.
  EXPECT_GT(r.b.volume, 4 * r.a.volume);
  EXPECT_GT(r.b.volume, 0.5 * 4.0 / 3 * M_PI * 8);
  // Its outer surface, the bailout sphere, passes through the basins far from J: many voxels.
  const double voxel = 4.0 / 32;
  EXPECT_GT(r.hausdorff, 4 * voxel);
  EXPECT_GT(r.b_to_a.mean, voxel);
}

// ---------------------------------------------------------------------------------------------
// The command line, run as a separate process.

namespace {

struct CliRun {
  int exit_code;
  std::string output;  // stdout and stderr
};

CliRun run_cli(const std::string& args) {
  const std::string cmd = std::string(QJULIA_CLI) + " " + args + " 2>&1";
  FILE* pipe = popen(cmd.c_str(), "r");
  CliRun r{-1, ""};
  if (!pipe) return r;
  char buf[4096];
  std::size_t n;
  while ((n = fread(buf, 1, sizeof buf, pipe)) > 0) r.output.append(buf, n);
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

}  // namespace

TEST(CompareCli, GarbageMeshFileExitsTwoNamingTheFileAndTheReason) {
  const io_fixtures::TempDir scratch("compare_test_garbage");
  const auto& dir = scratch.path();
  const std::string garbage = (dir / "garbage.obj").string();
  std::ofstream(garbage) << "this is not a mesh\n\x01\x02\x03";
  const auto r = run_cli("compare " + garbage + " " + garbage);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  const auto at = r.output.find(garbage + ":");
  ASSERT_NE(at, std::string::npos) << r.output;
  EXPECT_GT(r.output.size(), at + garbage.size() + 3) << "no reason given: " << r.output;
}

TEST(CompareCli, MissingMeshFileExitsTwoNamingTheFile) {
  const io_fixtures::TempDir scratch("compare_test_missing");
  const auto& dir = scratch.path();
  const std::string missing = (dir / "nowhere.ply").string();
  const auto r = run_cli("compare " + missing + " " + missing);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find(missing + ": cannot open"), std::string::npos) << r.output;
}

TEST(CompareCli, NeedsExactlyTwoSurfaces) {
  const auto r = run_cli("compare --preset newton-cubic");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("needs two surfaces"), std::string::npos) << r.output;
  EXPECT_EQ(run_cli("compare --preset newton-cubic --preset no-such-preset").exit_code, 2);
}

TEST(CompareCli, TwoPresetsGiveATableAndJson) {
  const io_fixtures::TempDir scratch("compare_test_presets");
  const auto& dir = scratch.path();
  const std::string json = (dir / "c.json").string();
  const auto r = run_cli(
      "compare --preset newton-cubic --preset newton-escape --resolution 24 --samples 20000 "
      "--quiet --json " +
      json);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("preset newton-cubic"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("Hausdorff distance"), std::string::npos) << r.output;
  std::ifstream in(json);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find("\"hausdorff\""), std::string::npos);
  EXPECT_NE(text.str().find("\"b_name\": \"preset newton-escape\""), std::string::npos);
}

// --max-memory bounds the meshing of a parameter set and the reading of a mesh file, as in
// `qjulia mesh`: what does not fit is refused before the work, naming the limit (the refusal of
// a run too large for the memory offers --max-memory, which compare takes).
TEST(CompareCli, MaxMemoryBoundsTheMeshingAndTheReading) {
  const io_fixtures::TempDir scratch("compare_test_memory");
  const auto& dir = scratch.path();
  const std::string mesh = (dir / "u.ply").string();
  // 24,000 faces: more than a mebibyte to read.
  ASSERT_EQ(run_cli("mesh --preset classic-julia --resolution 64 --quiet -o " + mesh).exit_code, 0);
  const auto meshing = run_cli(
      "compare --preset classic-julia --preset newton-cubic "
      "--resolution 512 --max-memory 16M --quiet");
  EXPECT_EQ(meshing.exit_code, 2) << meshing.output;
  EXPECT_NE(meshing.output.find("resolution 512 needs about "), std::string::npos)
      << meshing.output;
  EXPECT_NE(meshing.output.find("16.0 MiB (--max-memory) is available"), std::string::npos)
      << meshing.output;
  const auto reading = run_cli("compare " + mesh + " " + mesh + " --max-memory 1M --quiet");
  EXPECT_EQ(reading.exit_code, 2) << reading.output;
  EXPECT_NE(reading.output.find("1.00 MiB (--max-memory)"), std::string::npos) << reading.output;
  const auto ok = run_cli("compare " + mesh +
                          " --preset classic-julia --resolution 64 "
                          "--max-memory 1G --samples 1000 --quiet");
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_EQ(run_cli("compare " + mesh + " " + mesh + " --max-memory 0").exit_code, 2);
}

TEST(ExperimentCli, CardioidDistanceShrinksAsIterationsGrow) {
  const io_fixtures::TempDir scratch("compare_test_cardioid");
  const auto& dir = scratch.path();
  const auto r = run_cli(
      "experiment cardioid --resolution 32 --iterations 6,16 --samples 20000 "
      "--out " +
      dir.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(dir / "cardioid.csv");
  std::string header, row6, row16;
  std::getline(in, header);
  std::getline(in, row6);
  std::getline(in, row16);
  auto column = [&](const std::string& row, const std::string& name) {
    std::vector<std::string> names, values;
    std::stringstream h(header), v(row);
    std::string cell;
    while (std::getline(h, cell, ',')) names.push_back(cell);
    while (std::getline(v, cell, ',')) values.push_back(cell);
    for (std::size_t i = 0; i < names.size() && i < values.size(); ++i)
      if (names[i] == name) return std::stod(values[i]);
    ADD_FAILURE() << "no column " << name << " in " << row;
    return 0.0;
  };
  EXPECT_EQ(column(row6, "iterations"), 6);
  EXPECT_EQ(column(row16, "iterations"), 16);
  // Both approximations close in on J: the escape solid shrinks, the cut-off hole grows, and
  // the surfaces come together.
  EXPECT_LT(column(row16, "hausdorff"), column(row6, "hausdorff"));
  EXPECT_LT(column(row16, "escape_volume"), column(row6, "escape_volume"));
  EXPECT_GT(column(row16, "cutoff_volume"), column(row6, "cutoff_volume"));
  EXPECT_TRUE(std::filesystem::exists(dir / "cardioid.md"));
}

TEST(ExperimentCli, Table1ShowsTheEscapeMethodFailingOnNewtonsCubic) {
  const io_fixtures::TempDir scratch("compare_test_table1");
  const auto& dir = scratch.path();
  const auto r = run_cli("experiment table1 --resolution 24 --samples 20000 --out " + dir.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(dir / "table1.csv");
  std::string line;
  std::getline(in, line);
  std::vector<std::string> names;
  {
    std::stringstream h(line);
    std::string cell;
    while (std::getline(h, cell, ',')) names.push_back(cell);
  }
  std::vector<std::map<std::string, std::string>> rows;
  while (std::getline(in, line)) {
    std::stringstream v(line);
    std::string cell;
    std::map<std::string, std::string> row;
    for (std::size_t i = 0; i < names.size() && std::getline(v, cell, ','); ++i)
      row[names[i]] = cell;
    rows.push_back(row);
  }
  ASSERT_EQ(rows.size(), 13u);  // the cut-off reference and 3 x 4 escape cells
  EXPECT_EQ(rows[0]["method"], "cutoff");
  const double cut_volume = std::stod(rows[0]["volume"]);
  for (std::size_t i = 1; i < rows.size(); ++i) {
    auto& row = rows[i];
    EXPECT_EQ(row["method"], "escape");
    const double bailout = std::stod(row["bailout"]);
    // The attracting fixed points (cube roots of unity) lie outside the ball of radius 0.8:
    // every converging orbit leaves it, nothing is kept.
    if (bailout == 0.8) {
      EXPECT_EQ(row["faces"], "0");
    }
    // With R = 2 the solid is most of the ball of radius 2 (converging orbits never leave it):
    // far more volume than the cut-off shell, and a surface far from it.
    if (bailout == 2) {
      const double volume = std::stod(row["volume"]);
      EXPECT_LT(volume, 4.0 / 3 * M_PI * 8);
      EXPECT_GT(volume, 4 * cut_volume);
      EXPECT_GT(std::stod(row["hausdorff_to_cutoff"]), 0.5);
    }
  }
  EXPECT_TRUE(std::filesystem::exists(dir / "table1.md"));
  EXPECT_TRUE(std::filesystem::exists(dir / "table1.png"));  // the renderer is on main
}

// At a resolution too coarse for the reference (newton-cubic at 8: every component below the
// dust threshold), table1 says why, exits 2 (it was an internal error, exit 1) and leaves no
// folder it made.
TEST(ExperimentCli, Table1AtAResolutionWithoutAReferenceSaysWhyAndLeavesNothing) {
  const io_fixtures::TempDir scratch("experiment_test_coarse");
  const auto out = scratch.path() / "new";
  const auto r = run_cli("experiment table1 --resolution 8 --out " + out.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("table1: the cut-off reference (newton-cubic at resolution 8) has no "
                          "surface: every component of the surface is smaller than the dust "
                          "threshold"),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(ExperimentCli, UnknownExperimentExitsTwo) {
  const auto r = run_cli("experiment table9");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("table9"), std::string::npos) << r.output;
}

TEST(CompareCli, ColoredWritesAWithItsDistanceRampAndTheLegend) {
  const io_fixtures::TempDir scratch("compare_test_colored");
  const auto& dir = scratch.path();
  const std::string a = (dir / "a.ply").string(), b = (dir / "b.ply").string(),
                    out = (dir / "colored.ply").string();
  qjulia::write_mesh(a, icosphere(3));
  qjulia::write_mesh(b, shifted(icosphere(3), 0.1f, 0, 0));
  const auto r = run_cli("compare " + a + " " + b + " --samples 20000 --quiet --colored " + out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const TriMesh colored = qjulia::read_mesh(out);
  EXPECT_EQ(colored.vertex_count(), icosphere(3).vertex_count());
  ASSERT_EQ(colored.colors.size(), colored.vertex_count());
  // Against the sphere shifted along x, the poles on the x axis move by the shift (red), the
  // circle x = 0 hardly at all (blue).
  std::size_t pole = 0, equator = 0;
  for (std::size_t v = 0; v < colored.vertex_count(); ++v) {
    if (colored.positions[v][0] > colored.positions[pole][0]) pole = v;
    if (std::abs(colored.positions[v][0]) < std::abs(colored.positions[equator][0])) equator = v;
  }
  EXPECT_GT(colored.colors[pole][0], colored.colors[pole][2]);
  EXPECT_GT(colored.colors[equator][2], colored.colors[equator][0]);
  std::ifstream in(out, std::ios::binary);
  std::stringstream bytes;
  bytes << in.rdbuf();
  EXPECT_NE(bytes.str().find("legend_max"), std::string::npos);
}

TEST(Compare, ResultDependsOnlyOnTheInputNotOnTheThreads) {
  const TriMesh a = fixtures::noisy_sphere(4), b = shifted(icosphere(5), 0.01f, 0, 0);
  qjulia::CompareResult r[3];
  for (int threads = 1; threads <= 3; ++threads) {
    tbb::task_arena arena(threads);
    arena.execute([&] { r[threads - 1] = qjulia::compare(a, b, small_options()); });
  }
  for (int k = 1; k < 3; ++k) {
    EXPECT_EQ(r[0].hausdorff, r[k].hausdorff);
    EXPECT_EQ(r[0].a_to_b.mean, r[k].a_to_b.mean);
    EXPECT_EQ(r[0].b_to_a.rms, r[k].b_to_a.rms);
    EXPECT_EQ(r[0].a_vertex_distance, r[k].a_vertex_distance);
    EXPECT_EQ(qjulia::compare_to_json(r[0]), qjulia::compare_to_json(r[k]));
  }
}

TEST(Compare, ATokenRequestedDuringTheQueriesCancels) {
  qjulia::CancelToken token;
  auto o = small_options();
  o.cancel = &token;
  o.progress = [&](double f) {
    if (f >= 0.1) token.request();  // after the set-up, before the distance queries
    return true;
  };
  EXPECT_THROW(qjulia::compare(icosphere(4), icosphere(3), o), qjulia::Cancelled);
  token.reset();
  token.request();
  o.progress = nullptr;
  EXPECT_THROW(qjulia::compare(icosphere(4), icosphere(3), o), qjulia::Cancelled);
}

TEST(Compare, DistancesAreExactForATinyDetailedPartBesideALargeOne) {
  // The tiny sphere's 1280 faces share one cell of the BVH's Morton grid (1/1024 of the box),
  // so they are split by the surface area heuristic: distances stay exact. The corner of a
  // cube shifted by s is farthest from the cube, at |s|; the tiny sphere moves by s too.
  TriMesh a = cube();
  fixtures::append(a, icosphere(3, 1e-4, {0.5, 0.5, 0.5}));
  const float s = 0.01f;
  const auto r = qjulia::compare(a, shifted(a, s, 0, 0), small_options());
  EXPECT_NEAR(r.hausdorff, s, 1e-6);
  // The tiny sphere's vertices are nearest to the shifted tiny sphere (the walls are 0.5 away):
  // about s from it (its radius is 1e-4).
  for (std::size_t v = 8; v < a.vertex_count(); ++v) EXPECT_NEAR(r.a_vertex_distance[v], s, 2e-4);
}

TEST(Compare, JsonHasTheStatsKeysOfEachSurface) {
  const auto r = qjulia::compare(cube(), icosphere(2), small_options());
  const std::string json = qjulia::compare_to_json(r);
  for (const char* key :
       {"\"vertices\"", "\"faces\"", "\"edges\"", "\"closed\"", "\"manifold\"", "\"oriented\"",
        "\"boundary_edges\"", "\"nonmanifold_edges\"", "\"nonmanifold_vertices\"",
        "\"degenerate_faces\"", "\"volume\"", "\"area\"", "\"euler\"", "\"components\": 1",
        "\"bbox\"", "\"min\"", "\"max\"", "\"genus_summary\"", "\"component_measures\""})
    EXPECT_NE(json.find(key), std::string::npos) << key;
  EXPECT_EQ(json.find("bbox_min"), std::string::npos);
  EXPECT_EQ(json.find("component_count"), std::string::npos);
}

namespace {

// The distance from p to the surface of the unit cube [0, 1]^3, from its definition.
double distance_to_unit_cube(const std::array<float, 3>& p) {
  double outside = 0, inside = 0.5;
  for (int k = 0; k < 3; ++k) {
    const double off = std::abs(double(p[k]) - 0.5) - 0.5;  // > 0 beyond the slab of axis k
    outside += off > 0 ? off * off : 0;
    inside = std::min(inside, -off);
  }
  return outside > 0 ? std::sqrt(outside) : inside;
}

}  // namespace

TEST(Compare, StreamedDistancesComeBatchByBatchInOrderWithTheWholeSequencesValues) {
  // compare() measures its samples in batches of 65,536 made on demand; a count that is not a
  // multiple of the batch, with points inside, outside and on the cube.
  const TriMesh cube_mesh = fixtures::box({0, 0, 0}, {1, 1, 1});
  const qjulia::detail::TriangleBvh tree(cube_mesh.positions, cube_mesh.triangles);
  const std::size_t n = 2 * 65536 + 4321;
  auto point = [](std::size_t i) -> std::array<float, 3> {
    std::uint64_t x = i * 0x9E3779B97F4A7C15ull + 12345;
    std::array<float, 3> p;
    for (float& c : p) {
      x ^= x >> 29;
      x *= 0xBF58476D1CE4E5B9ull;
      x ^= x >> 32;
      c = float(-0.5 + 2.0 * double(x >> 11) / 9007199254740992.0);
    }
    return p;
  };
  std::vector<std::array<float, 3>> all(n);
  for (std::size_t i = 0; i < n; ++i) all[i] = point(i);
  const std::vector<float> whole = tree.distances(all);

  std::vector<float> streamed;
  std::vector<std::size_t> made(n, 0);
  std::size_t batches = 0;
  std::vector<double> steps;
  tree.distances(
      n,
      [&](std::size_t begin, std::size_t end, std::array<float, 3>* out) {
        for (std::size_t i = begin; i < end; ++i) {
          out[i - begin] = point(i);
          ++made[i];  // each index by one block only
        }
      },
      [&](std::size_t begin, const float* d, std::size_t count) {
        EXPECT_EQ(begin, streamed.size());  // in order, none left out
        EXPECT_LE(count, std::size_t{65536});
        streamed.insert(streamed.end(), d, d + count);
        ++batches;
      },
      nullptr, [&](double f) { steps.push_back(f); });
  ASSERT_EQ(streamed.size(), n);
  EXPECT_EQ(batches, std::size_t{3});
  EXPECT_EQ(*std::min_element(made.begin(), made.end()), std::size_t{1});
  EXPECT_EQ(*std::max_element(made.begin(), made.end()), std::size_t{1});
  ASSERT_EQ(steps.size(), std::size_t{3});
  EXPECT_TRUE(std::is_sorted(steps.begin(), steps.end()));
  EXPECT_EQ(steps.back(), 1.0);
  for (std::size_t i = 0; i < n; ++i) {
    ASSERT_EQ(streamed[i], whole[i]) << "point " << i;
    ASSERT_NEAR(streamed[i], distance_to_unit_cube(all[i]), 2e-6) << "point " << i;
  }
}
