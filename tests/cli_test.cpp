// End-to-end tests of the `qjulia` executable: exit codes, messages, files written.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "qjulia/field/params.h"

namespace qjulia {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr double kPi = 3.14159265358979323846;

struct CliRun {
  int code = -1;
  std::string out, err;
};

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

// Each test runs the CLI in its own empty directory `work_`; stderr goes to a file beside it,
// so the directory holds exactly what the CLI wrote.
class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = std::string(info->test_suite_name()) + "_" + info->name();
    std::replace(name.begin(), name.end(), '/', '_');
    root_ =
        fs::temp_directory_path() / ("qjulia_cli_test_" + std::to_string(::getpid()) + "_" + name);
    fs::remove_all(root_);
    work_ = root_ / "work";
    fs::create_directories(work_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(root_, ec);
  }

  // Runs `qjulia ARGS` (ARGS as written on a shell command line) in work_.
  CliRun run(const std::string& args) const {
    const fs::path err = root_ / "stderr.txt";
    const std::string cmd = "cd '" + work_.string() + "' && '" QJULIA_CLI "' " + args + " 2> '" +
                            err.string() + "' < /dev/null";
    CliRun r;
    FILE* pipe = ::popen(cmd.c_str(), "r");
    if (!pipe) {
      ADD_FAILURE() << "popen failed: " << cmd;
      return r;
    }
    char buf[4096];
    for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, pipe)) > 0;) r.out.append(buf, n);
    const int status = ::pclose(pipe);
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.err = read_text(err);
    return r;
  }

  // The files in work_ (recursively), relative names, sorted.
  std::vector<std::string> files() const {
    std::vector<std::string> out;
    for (const auto& e : fs::recursive_directory_iterator(work_))
      if (!e.is_directory()) out.push_back(fs::relative(e.path(), work_).string());
    std::sort(out.begin(), out.end());
    return out;
  }

  // Bad input: exit code 2, exactly one line on stderr that contains `names`, and no file
  // written besides `inputs`.
  void expect_rejected(const std::string& args, const std::string& names,
                       std::vector<std::string> inputs = {}) const {
    SCOPED_TRACE("qjulia " + args);
    const CliRun r = run(args);
    EXPECT_EQ(r.code, 2) << "stderr: " << r.err;
    EXPECT_FALSE(r.err.empty());
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line, got: " << r.err;
    EXPECT_EQ(r.err.back(), '\n') << r.err;
    EXPECT_NE(r.err.find(names), std::string::npos)
        << "the message should name '" << names << "': " << r.err;
    std::sort(inputs.begin(), inputs.end());
    EXPECT_EQ(files(), inputs) << "bad input must not leave files";
  }

  fs::path root_, work_;
};

// ---------------------------------------------------------------------------------------------
// Bad input to `qjulia mesh`: exit 2, one line, no file

TEST_F(Cli, MeshRejectsAMalformedFormulaNamingTheColumn) {
  expect_rejected("mesh --formula 'h^' --resolution 16 -o out.ply", "1:3");
}

TEST_F(Cli, MeshRejectsAnUnknownKeyInTheParameterFile) {
  write_text(work_ / "bad.json", R"({"formula": "h^2", "method": "escape", "colour": "red"})");
  expect_rejected("mesh bad.json --resolution 16 -o out.ply", "colour", {"bad.json"});
}

TEST_F(Cli, MeshRejectsAnUnknownKeyInANestedObjectOfTheParameterFile) {
  write_text(work_ / "bad.json", R"({"slice": {"axes": "rmn", "angle": 1}})");
  expect_rejected("mesh bad.json --resolution 16 -o out.ply", "angle", {"bad.json"});
}

TEST_F(Cli, MeshRejectsResolutionZero) {
  expect_rejected("mesh --preset unit-ball --resolution 0 -o out.ply", "resolution");
}

TEST_F(Cli, MeshRejectsBoundsWithMinAboveMax) {
  expect_rejected("mesh --preset unit-ball --resolution 16 --bounds 1,1,1,0,0,0 -o out.ply",
                  "bounds");
}

TEST_F(Cli, MeshRejectsBoundsWithTheWrongCount) {
  expect_rejected("mesh --preset unit-ball --resolution 16 --bounds=-1,-1,1 -o out.ply", "bounds");
}

TEST_F(Cli, MeshRejectsAnIterationCountThatIsNotANumber) {
  expect_rejected("mesh --preset unit-ball --resolution 16 --iterations ten -o out.ply",
                  "iterations");
}

TEST_F(Cli, MeshRejectsAnUnknownPreset) {
  expect_rejected("mesh --preset no-such-preset --resolution 16 -o out.ply", "no-such-preset");
}

TEST_F(Cli, MeshRejectsAnUnknownOption) {
  expect_rejected("mesh --preset unit-ball --resolution 16 --frobnicate 3 -o out.ply",
                  "frobnicate");
}

TEST_F(Cli, MeshRejectsAnUnknownOutputExtension) {
  expect_rejected("mesh --preset unit-ball --resolution 16 -o out.xyz", "xyz");
}

TEST_F(Cli, MeshRejectsAMissingOutput) {
  expect_rejected("mesh --preset unit-ball --resolution 16", "-o");
}

TEST_F(Cli, MeshRejectsAParameterFileThatDoesNotExist) {
  expect_rejected("mesh missing-params.json --resolution 16 -o out.ply", "missing-params.json");
}

TEST_F(Cli, MeshRejectsAParameterFileThatIsNotJson) {
  write_text(work_ / "broken.json", R"({"formula": "h^2", )");
  const CliRun r = run("mesh broken.json --resolution 16 -o out.ply");
  EXPECT_NE(r.err.find("broken.json"), std::string::npos) << r.err;
  expect_rejected("mesh broken.json --resolution 16 -o out.ply", "JSON", {"broken.json"});
}

// ---------------------------------------------------------------------------------------------
// Bad input to `qjulia params` (the same validation, no mesh stage involved)

TEST_F(Cli, ParamsRejectsBadParametersLikeMesh) {
  write_text(work_ / "bad.json", R"({"formula": "h^2", "colour": "red"})");
  write_text(work_ / "broken.json", "{");
  const std::vector<std::string> inputs = {"bad.json", "broken.json"};
  expect_rejected("params --formula 'h^'", "1:3", inputs);
  expect_rejected("params bad.json", "colour", inputs);
  expect_rejected("params --resolution 0", "resolution", inputs);
  expect_rejected("params --bounds 1,1,1,0,0,0", "bounds", inputs);
  expect_rejected("params --preset no-such-preset", "no-such-preset", inputs);
  expect_rejected("params --frobnicate", "frobnicate", inputs);
  expect_rejected("params missing-params.json", "missing-params.json", inputs);
  expect_rejected("params broken.json", "JSON", inputs);
  expect_rejected("params --axes xyz", "axes", inputs);
  expect_rejected("params --bailout -1", "bailout", inputs);
}

TEST_F(Cli, AnUnknownCommandExitsTwo) {
  const CliRun r = run("frobnicate");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("frobnicate"), std::string::npos) << r.err;
}

// ---------------------------------------------------------------------------------------------
// Commands that succeed

TEST_F(Cli, PresetsListsEveryPreset) {
  const CliRun r = run("presets");
  ASSERT_EQ(r.code, 0) << r.err;
  for (const std::string& name : preset_names()) {
    EXPECT_NE(r.out.find(name), std::string::npos) << name << " missing from:\n" << r.out;
    EXPECT_NE(r.out.find(preset_description(name)), std::string::npos) << name;
  }
  EXPECT_EQ(static_cast<std::size_t>(std::count(r.out.begin(), r.out.end(), '\n')),
            preset_names().size())
      << "one line per preset";
}

TEST_F(Cli, ParamsPrintsThePresetAsAParameterFile) {
  const CliRun r = run("params --preset classic-julia");
  ASSERT_EQ(r.code, 0) << r.err;
  json printed;
  ASSERT_NO_THROW(printed = json::parse(r.out)) << r.out;
  EXPECT_EQ(printed, json::parse(params_to_json(preset("classic-julia"))));
  // What it prints is a parameter file: it parses back to the preset.
  EXPECT_EQ(params_to_json(parse_params(r.out)), params_to_json(preset("classic-julia")));
  EXPECT_TRUE(files().empty());
}

TEST_F(Cli, ParamsShowsOverridesGivenAsOptionSpaceValue) {
  const CliRun r = run("params --preset unit-ball --iterations 7 --bounds -1,-1,-1,1,1,1");
  ASSERT_EQ(r.code, 0) << r.err;
  const json j = json::parse(r.out);
  EXPECT_EQ(j["iterations"], 7);
  EXPECT_EQ(j["bounds"]["min"], json::array({-1, -1, -1}));
  EXPECT_EQ(j["bounds"]["max"], json::array({1, 1, 1}));
  EXPECT_EQ(j["formula"], preset("unit-ball").formula) << "the rest comes from the preset";
}

TEST_F(Cli, ParamsShowsOverridesGivenAsOptionEqualsValue) {
  const CliRun r = run("params --preset unit-ball --iterations=7 --bounds=-1,-1,-1,1,1,1");
  ASSERT_EQ(r.code, 0) << r.err;
  const json j = json::parse(r.out);
  EXPECT_EQ(j["iterations"], 7);
  EXPECT_EQ(j["bounds"]["min"], json::array({-1, -1, -1}));
  EXPECT_EQ(j["bounds"]["max"], json::array({1, 1, 1}));
}

TEST_F(Cli, ParamsAppliesOverridesToAParameterFile) {
  write_text(work_ / "p.json", params_to_json(preset("classic-julia")));
  const CliRun r =
      run("params p.json --const c=0.3,0.5,0,0 --method=cutoff --axes rmp --fixed=-0.25");
  ASSERT_EQ(r.code, 0) << r.err;
  const Params p = parse_params(r.out);
  ASSERT_NE(p.constant("c"), nullptr);
  EXPECT_EQ(p.constant("c")->w, 0.3);
  EXPECT_EQ(p.constant("c")->x, 0.5);
  EXPECT_EQ(p.method, Method::kCutoff);
  EXPECT_EQ(p.slice.axes, "rmp");
  EXPECT_EQ(p.slice.fixed, -0.25);
  EXPECT_EQ(p.iterations, preset("classic-julia").iterations);
}

TEST_F(Cli, VersionPrintsOneLine) {
  const CliRun r = run("version");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out.rfind("qjulia ", 0), 0u) << r.out;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  EXPECT_EQ(run("--version").out, r.out);
}

TEST_F(Cli, BenchRunsAPresetAndPrintsItsLine) {
  const CliRun r = run("bench --presets unit-ball --resolutions 32 --threads 1");
  ASSERT_EQ(r.code, 0) << r.err;
  std::istringstream lines(r.out);
  bool found = false;
  for (std::string line; std::getline(lines, line);) {
    std::istringstream words(line);
    std::string name;
    int res = 0;
    if (words >> name >> res && name == "unit-ball") {
      found = true;
      EXPECT_EQ(res, 32) << line;
    }
  }
  EXPECT_TRUE(found) << r.out;
  EXPECT_TRUE(files().empty()) << "bench writes nothing";
}

// Needs the export stage (write_mesh).
TEST_F(Cli, MeshWritesTheMeshAndTheStatsOfTheUnitBall) {
  const CliRun r = run("mesh --preset unit-ball --resolution 32 -o ball.ply --stats s.json");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(files(), (std::vector<std::string>{"ball.ply", "s.json"}));
  const std::string ply = read_text(work_ / "ball.ply");
  EXPECT_EQ(ply.rfind("ply", 0), 0u) << "a PLY file starts with 'ply'";

  json s;
  ASSERT_NO_THROW(s = json::parse(read_text(work_ / "s.json")));
  for (const char* key : {"evaluations", "dense_evaluations", "vertices", "faces", "closed",
                          "manifold", "volume", "area", "timings", "peak_rss_bytes"})
    EXPECT_TRUE(s.contains(key)) << key << " missing from the stats";
  ASSERT_TRUE(s["evaluations"].is_number_integer());
  ASSERT_TRUE(s["dense_evaluations"].is_number_integer());
  EXPECT_GT(s["evaluations"].get<long long>(), 0);
  EXPECT_LE(s["evaluations"].get<long long>(), s["dense_evaluations"].get<long long>());
  EXPECT_TRUE(s["closed"].get<bool>());
  EXPECT_TRUE(s["manifold"].get<bool>());
  // A closed genus-0 triangle mesh: V - E + F = 2 with E = 3F/2.
  const long long v = s["vertices"].get<long long>(), f = s["faces"].get<long long>();
  EXPECT_EQ(f, 2 * (v - 2));
  EXPECT_NEAR(s["volume"].get<double>(), 4.0 / 3.0 * kPi, 0.03 * 4.0 / 3.0 * kPi);
  EXPECT_NEAR(s["area"].get<double>(), 4.0 * kPi, 0.05 * 4.0 * kPi);
  EXPECT_TRUE(s["timings"].is_object());
  EXPECT_GT(s["peak_rss_bytes"].get<double>(), 0);
  EXPECT_NE(r.out.find("ball.ply"), std::string::npos) << r.out;
}

TEST_F(Cli, MeshToStlWritesTheParametersBesideIt) {
  const CliRun r =
      run("mesh --preset unit-ball --resolution 24 --iterations 7 --quiet -o ball.stl");
  ASSERT_EQ(r.code, 0) << r.err;
  ASSERT_TRUE(fs::exists(work_ / "ball.stl.json"));
  Params expected = preset("unit-ball");
  expected.resolution = 24;
  expected.iterations = 7;
  const Params written = parse_params(read_text(work_ / "ball.stl.json"));
  EXPECT_EQ(params_to_json(written), params_to_json(expected));
}

}  // namespace
}  // namespace qjulia
