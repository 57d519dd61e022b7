// End-to-end tests of the `qjulia` executable: exit codes, messages, files written.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
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

  // Runs `qjulia ARGS` (ARGS as written on a shell command line) in work_, after the shell
  // commands `setup` (e.g. a ulimit).
  CliRun run(const std::string& args, const std::string& setup = "") const {
    const fs::path err = root_ / "stderr.txt";
    const std::string cmd = "cd '" + work_.string() + "' && " +
                            (setup.empty() ? "" : setup + " && ") + "'" QJULIA_CLI "' " + args +
                            " 2> '" + err.string() + "' < /dev/null";
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
  CliRun expect_rejected(const std::string& args, const std::string& names,
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
    return r;
  }

  // The rest of the line of `qjulia bench --malloc` that starts with `key`, run with the
  // environment assignment `env` exported first (none when empty).
  std::string bench_malloc_line(const std::string& key, const std::string& env) const {
    const CliRun r = run("bench --malloc", env.empty() ? "" : "export " + env);
    EXPECT_EQ(r.code, 0) << r.err;
    const auto at = r.out.find(key);
    if (at == std::string::npos) return "(no line) " + r.out;
    return r.out.substr(at + key.size(), r.out.find('\n', at) - at - key.size());
  }

  fs::path root_, work_;
};

// ---------------------------------------------------------------------------------------------
// Bad input to `qjulia mesh`: exit 2, one line, no file

// The dynamic loader looks for the program's libraries in absolute folders only: an empty or
// relative entry of its run path would be the current folder, where a library of the same name
// would be loaded instead (the loader's own log names every file it tries).
TEST_F(Cli, LoadsItsLibrariesFromAbsoluteFoldersOnly) {
  const CliRun r = run("--version", "export LD_DEBUG=libs QJULIA_HUGE_PAGES=0");
  ASSERT_EQ(r.code, 0) << r.err;
  std::istringstream log(r.err);
  int tried = 0;
  for (std::string line; std::getline(log, line);) {
    const std::size_t at = line.find("trying file=");
    if (at == std::string::npos) continue;
    ++tried;
    const std::string file = line.substr(at + 12);
    EXPECT_EQ(file.rfind('/', 0), 0u) << "a library looked for in the current folder: " << file;
  }
  EXPECT_GT(tried, 0) << "the loader's log was expected on stderr: " << r.err;
  EXPECT_EQ(files(), std::vector<std::string>{});
}

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

TEST_F(Cli, AnEmptySolidWritesNothingAndAClippedOneSaysTheClipPlanesEmptiedIt) {
  // Escape method with a bailout below the box's smallest |h|: no point is in the solid.
  expect_rejected("mesh --preset classic-julia --resolution 24 --bailout 0.001 -o m.ply",
                  "no grid point of the box is in it");
  // A clip plane that keeps nothing of the box.
  expect_rejected("mesh --preset classic-julia --resolution 24 --clip 1,0,0,-5 -o m.ply",
                  "no grid point of the box on the kept side of the clip planes is in it");
}

// A surface whose every component is dust is not an empty solid: the message says what removed
// it, the largest component's volume against the threshold, and how to keep it (the unit ball at
// resolution 3 has a voxel of 1 and a volume below 2 voxel^3).
TEST_F(Cli, ASurfaceThatIsAllDustSaysSoAndNotThatTheSolidIsEmpty) {
  // The run that keeps every component: its stats.
  auto kept = [&](const std::string& args) {
    const CliRun k = run(args + " --min-component 0 -o k.ply --stats k.json");
    EXPECT_EQ(k.code, 0) << k.err;
    const json stats = json::parse(read_text(work_ / "k.json"));
    fs::remove(work_ / "k.ply");
    fs::remove(work_ / "k.json");
    return stats;
  };
  const std::string ball = "mesh --preset unit-ball --resolution 3";
  const json one = kept(ball);
  ASSERT_EQ(one["components"], 1);
  char volume[32];
  std::snprintf(volume, sizeof volume, "%.3g", one["volume"].get<double>());
  const CliRun r = expect_rejected(
      ball + " -o m.ply", std::string("every component of the surface is smaller than the dust "
                                      "threshold (its one component has volume ") +
                              volume +
                              ", the threshold is 2 model units^3, 2 voxel^3 by default); "
                              "--min-component 0 keeps every component");
  EXPECT_EQ(r.err.find("the solid is empty"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("Hint"), std::string::npos) << r.err;
  const std::string julia = "mesh --preset classic-julia --resolution 24";
  const json all = kept(julia);
  expect_rejected(julia + " --min-component 1000 -o m.ply",
                  "the largest of its " + std::to_string(all["components"].get<int>()) +
                      " components has volume ");
  expect_rejected(julia + " --min-component 1000 -o m.ply",
                  ", the threshold is 1e+03 model units^3, from --min-component); a smaller "
                  "--min-component keeps them");
}

// The side outputs are named for their formats, checked before the work: the grid an OpenVDB
// file, the preview a PNG (--vdb grid.txt wrote a VDB file named .txt).
TEST_F(Cli, MeshRefusesAGridOrPreviewNamedForAnotherFormat) {
  expect_rejected("mesh --preset unit-ball --resolution 16 -o m.ply --vdb grid.txt",
                  "--vdb: 'grid.txt' must end in .vdb");
  expect_rejected("mesh --preset unit-ball --resolution 16 -o m.ply --preview p.jpg",
                  "--preview: 'p.jpg' must end in .png");
  EXPECT_EQ(run("mesh --preset unit-ball --resolution 16 -o m.ply --vdb g.VDB --quiet").code, 0);
  EXPECT_TRUE(fs::exists(work_ / "g.VDB"));
}

// A mesh file qjulia wrote records its parameters: given in place of a parameter file, the same
// mesh is made again (flags still override); an STL's are in its sidecar, a foreign file has none.
TEST_F(Cli, AMeshFileGivesTheParametersItRecords) {
  ASSERT_EQ(run("mesh --preset classic-julia --resolution 24 --quiet -o a.glb --stats a.json").code,
            0);
  const CliRun again = run("mesh a.glb --quiet -o b.ply --stats b.json");
  ASSERT_EQ(again.code, 0) << again.err;
  const json a = json::parse(read_text(work_ / "a.json")),
             b = json::parse(read_text(work_ / "b.json"));
  EXPECT_EQ(b["parameters"], a["parameters"]);
  EXPECT_EQ(b["faces"], a["faces"]);
  EXPECT_EQ(b["volume"], a["volume"]);
  const CliRun finer = run("params b.ply --resolution 40");
  ASSERT_EQ(finer.code, 0) << finer.err;
  EXPECT_EQ(json::parse(finer.out)["resolution"], 40);
  EXPECT_EQ(json::parse(finer.out)["formula"], a["parameters"]["formula"]);
  ASSERT_EQ(run("mesh --preset unit-ball --resolution 16 --quiet -o s.stl").code, 0);
  expect_rejected("mesh s.stl -o t.ply",
                  "s.stl: the mesh file records no parameters (an STL file's are in its sidecar, "
                  "s.stl.json)",
                  {"a.glb", "a.json", "b.json", "b.ply", "s.stl", "s.stl.json"});
  write_text(work_ / "f.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  expect_rejected("mesh f.obj -o t.ply", "f.obj: the mesh file records no parameters",
                  {"a.glb", "a.json", "b.json", "b.ply", "f.obj", "s.stl", "s.stl.json"});
}

// A minimum thickness above the whole model's size thickens all of it (often millimetres meant
// for a model without --size): done, with a note that says so.
TEST_F(Cli, AThicknessAboveTheWholeModelIsDoneWithANote) {
  const CliRun over = run("mesh --preset unit-ball --resolution 16 --min-thickness 5mm -o o.ply");
  ASSERT_EQ(over.code, 0) << over.err;
  // The ball at 16 is 1.98 across (its vertices lie on the sphere, inside the box).
  EXPECT_NE(over.err.find("note: --min-thickness 5 mm is more than the whole model (1.98 model "
                          "units across before thickening)"),
            std::string::npos)
      << over.err;
  EXPECT_NE(over.err.find("without --size, model units are read as mm"), std::string::npos);
  const CliRun sized = run(
      "mesh --preset unit-ball --resolution 16 --size 4mm --min-thickness 5mm -o s.ply --quiet");
  ASSERT_EQ(sized.code, 0) << sized.err;
  EXPECT_NE(sized.err.find("than the whole model (4 mm across"), std::string::npos) << sized.err;
  const CliRun under =
      run("mesh --preset unit-ball --resolution 16 --min-thickness 1mm -o u.ply --quiet");
  ASSERT_EQ(under.code, 0) << under.err;
  EXPECT_EQ(under.err.find("note:"), std::string::npos) << under.err;
}

// An output option names one file: given twice with two names, the run is refused rather than
// one of them dropped without a word; the same name twice is one file.
TEST_F(Cli, AnOutputGivenTwiceWithTwoNamesIsRefused) {
  expect_rejected("mesh --preset unit-ball --resolution 16 -o a.ply -o b.ply",
                  "--output (-o) is given twice ('a.ply' and 'b.ply')");
  expect_rejected("mesh --preset unit-ball --resolution 16 -o a.ply --stats a.json --stats=b.json",
                  "--stats is given twice");
  write_text(work_ / "m.ply", "");  // render's input; it is refused before it is read
  expect_rejected("render m.ply -o a.png -o b.png", "--output (-o) is given twice", {"m.ply"});
  fs::remove(work_ / "m.ply");
  expect_rejected("compare --preset unit-ball --preset classic-julia --json a.json --json b.json",
                  "--json is given twice");
  EXPECT_EQ(run("mesh --preset unit-ball --resolution 16 --quiet -o a.ply --output=a.ply").code, 0);
  EXPECT_EQ(files(), std::vector<std::string>{"a.ply"});
}

TEST_F(Cli, ADecimationThatStopsAboveItsTargetSaysSoOnStderr) {
  // Newton's cubic at 48 has a genus far too high for 500 faces: the collapses that keep the
  // topology stop at the shape bound first.
  const CliRun r = run("mesh --resolution 48 --faces 500 --quiet -o m.ply --stats m.json");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("note: decimation stopped at"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("above the 500 asked for"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("--max-error"), std::string::npos) << "the way further: " << r.err;
  // A larger bound goes further, with the same topology.
  const CliRun further =
      run("mesh --resolution 48 --faces 500 --max-error 1 --quiet -o e.ply --stats e.json");
  ASSERT_EQ(further.code, 0) << further.err;
  EXPECT_NE(further.err.find("within --max-error"), std::string::npos) << further.err;
  const json m = json::parse(read_text(work_ / "m.json")),
             e = json::parse(read_text(work_ / "e.json"));
  EXPECT_LT(e["faces"].get<long long>(), m["faces"].get<long long>());
  EXPECT_EQ(e["euler"], m["euler"]);
  EXPECT_EQ(e["components"], m["components"]);
  const CliRun ok = run("mesh --preset unit-ball --resolution 48 --faces 2000 --quiet -o b.ply");
  ASSERT_EQ(ok.code, 0) << ok.err;
  EXPECT_EQ(ok.err.find("note:"), std::string::npos) << ok.err;
  // Far fewer faces than a genus-12 surface can have: the mesh keeps its topology and stops
  // above the budget (it used to collapse to nothing: exit 2, "the solid is empty").
  const CliRun whole =
      run("mesh --preset classic-julia --resolution 64 --quiet -o w.ply --stats w.json");
  ASSERT_EQ(whole.code, 0) << whole.err;
  const CliRun tiny =
      run("mesh --preset classic-julia --resolution 64 --faces 4 --quiet -o t.ply --stats t.json");
  ASSERT_EQ(tiny.code, 0) << tiny.err;
  EXPECT_NE(tiny.err.find("above the 4 asked for"), std::string::npos) << tiny.err;
  const json w = json::parse(read_text(work_ / "w.json")),
             t = json::parse(read_text(work_ / "t.json"));
  EXPECT_EQ(t["decimate"]["target_reached"], false);
  EXPECT_LT(t["faces"].get<long long>(), w["faces"].get<long long>() / 10);
  EXPECT_EQ(t["euler"], w["euler"]);
  EXPECT_EQ(t["components"], w["components"]);
  EXPECT_TRUE(t["closed"].get<bool>() && t["manifold"].get<bool>());
}

TEST_F(Cli, BothDecimationsReachABudgetAHighGenusSurfaceCanHoldKeepingItsTopology) {
  // Newton's cubic at 48 (33,000 faces, genus in the hundreds) to 12,000 faces: the fast
  // method's collapses and OpenMesh's Decimater both reach it with the same components and
  // Euler characteristic.
  const CliRun whole = run("mesh --resolution 48 --quiet -o w.ply --stats w.json");
  ASSERT_EQ(whole.code, 0) << whole.err;
  const CliRun fast = run("mesh --resolution 48 --faces 12000 --quiet -o f.ply --stats f.json");
  ASSERT_EQ(fast.code, 0) << fast.err;
  const CliRun quality =
      run("mesh --resolution 48 --faces 12000 --decimate quality --quiet -o q.ply --stats q.json");
  ASSERT_EQ(quality.code, 0) << quality.err;
  EXPECT_EQ(quality.err.find("note:"), std::string::npos) << quality.err;
  const json w = json::parse(read_text(work_ / "w.json")),
             f = json::parse(read_text(work_ / "f.json")),
             q = json::parse(read_text(work_ / "q.json"));
  EXPECT_EQ(fast.err.find("note:"), std::string::npos) << fast.err;
  EXPECT_EQ(f["decimate"]["target_reached"], true);
  EXPECT_LE(f["faces"].get<long long>(), 12000);
  EXPECT_GT(f["faces"].get<long long>(), 6000);
  EXPECT_EQ(f["euler"], w["euler"]);
  EXPECT_EQ(f["components"], w["components"]);
  EXPECT_TRUE(f["closed"].get<bool>() && f["manifold"].get<bool>() && f["oriented"].get<bool>());
  EXPECT_EQ(q["decimate"]["target_reached"], true);
  EXPECT_LE(q["faces"].get<long long>(), 12000);
  EXPECT_GT(q["faces"].get<long long>(), 6000);
  EXPECT_EQ(q["euler"], w["euler"]);
  EXPECT_EQ(q["components"], w["components"]);
  EXPECT_TRUE(q["closed"].get<bool>() && q["manifold"].get<bool>() && q["oriented"].get<bool>());
  EXPECT_EQ(q["parameters"]["mesh"]["decimate"], "quality");
  EXPECT_FALSE(f["parameters"]["mesh"].contains("decimate"));
  // The method is recorded in the file: meshing its parameters again decimates the same way.
  const CliRun again = run("params q.ply");
  ASSERT_EQ(again.code, 0) << again.err;
  EXPECT_NE(again.out.find("\"decimate\": \"quality\""), std::string::npos) << again.out;
  // Alone, --decimate changes nothing, and says so.
  const CliRun alone = run("mesh --resolution 16 --decimate quality --quiet -o a.ply");
  ASSERT_EQ(alone.code, 0) << alone.err;
  EXPECT_NE(alone.err.find("without either the mesh is not decimated"), std::string::npos)
      << alone.err;
  const CliRun bad = run("mesh --resolution 16 --faces 100 --decimate best --quiet -o b.ply");
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.err.find("--decimate: expected fast or quality, not 'best'"), std::string::npos)
      << bad.err;
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
  expect_rejected("version extra", "takes no arguments, not 'extra'");
}

// `qjulia help COMMAND` is `qjulia COMMAND --help`; `presets` takes no arguments.
TEST_F(Cli, HelpNamesACommandAndCommandsWithoutArgumentsRefuseThem) {
  const CliRun help = run("help mesh");
  ASSERT_EQ(help.code, 0) << help.err;
  EXPECT_EQ(help.out, run("mesh --help").out);
  EXPECT_NE(help.out.find("usage: qjulia mesh"), std::string::npos) << help.out;
  EXPECT_EQ(run("help compare").out, run("compare --help").out);
  EXPECT_EQ(run("help frobnicate").code, 2);
  expect_rejected("help version", "'version' is not a command with options");
  expect_rejected("presets classic-julia", "takes no arguments, not 'classic-julia'");
}

// The lists are checked before the kernel's measurement and the first run: an unknown preset
// late in the list does not cost the runs before it.
TEST_F(Cli, BenchRefusesAnEmptyListOrAnUnknownPresetBeforeAnyRun) {
  const CliRun late =
      expect_rejected("bench --presets unit-ball,nope --resolutions 8", "unknown preset 'nope'");
  EXPECT_TRUE(late.out.empty()) << late.out;
  expect_rejected("bench --presets= --resolutions 8", "--presets: expected preset names");
  expect_rejected("bench --presets unit-ball --resolutions=", "--resolutions: expected");
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

TEST_F(Cli, BenchPrintsTheKernelAgainstTheReference) {
  const CliRun r = run("bench --kernel");
  ASSERT_EQ(r.code, 0) << r.err;
  // Two batches, each with the compiled and the reference speed and their ratio.
  int rows = 0;
  std::istringstream lines(r.out);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("surface band", 0) != 0 && line.rfind("whole box", 0) != 0) continue;
    ++rows;
    const auto ratio = std::stod(line.substr(line.find_last_of(' ') + 1));
    EXPECT_GT(ratio, 0.0) << line;
    EXPECT_LT(ratio, 10.0) << line;
  }
  EXPECT_EQ(rows, 2) << r.out;
  EXPECT_TRUE(files().empty()) << "bench writes nothing";
}

// The kernel's transparent huge page mode, as the bracketed word of its setting ("" if none).
std::string thp_mode() {
  const std::string line = read_text("/sys/kernel/mm/transparent_hugepage/enabled");
  const auto open = line.find('['), close = line.find(']');
  if (open == std::string::npos || close == std::string::npos || close < open) return "";
  return line.substr(open + 1, close - open - 1);
}

// The order of the free blocks the machine reports to its host, or -1 when it reports none.
int page_reporting_order() {
  const std::string text = read_text("/sys/module/page_reporting/parameters/page_reporting_order");
  try {
    const long long order = std::stoll(text);
    return order >= 0 && order < 64 ? static_cast<int>(order) : -1;
  } catch (...) {
    return -1;
  }
}

TEST_F(Cli, WorkingCommandsRunWithMallocOnHugePagesWhereTheyPayUnlessTheUserDecides) {
  // `bench` prints the state the process runs in: in mode madvise the command restarts itself
  // with glibc's tunable added to those the user set, unless the machine hands free 2 MiB
  // blocks back to its host (then each huge page is one the host backs afresh);
  // QJULIA_HUGE_PAGES=0 or 1, or a user's own glibc.malloc.hugetlb, decide instead.
  const auto state = [&](const std::string& env) {
    return bench_malloc_line("malloc on transparent huge pages: ", env);
  };
  const std::string mode = thp_mode();
  const int order = page_reporting_order();
  const bool pay = order < 0 || order > 9;
  const std::string reporting =
      "the machine hands free 2 MiB blocks back to its host, page_reporting_order <= 9";
  if (mode == "madvise") {
    const std::string on = "on (GLIBC_TUNABLES glibc.malloc.hugetlb=1)";
    EXPECT_EQ(state(""), pay ? on : "off (" + reporting + ")");
    EXPECT_EQ(state("GLIBC_TUNABLES=glibc.malloc.perturb=0"), pay ? on : "off (" + reporting + ")");
    EXPECT_EQ(state("QJULIA_HUGE_PAGES=1"), on);
    EXPECT_EQ(state("QJULIA_HUGE_PAGES=0"), "off (QJULIA_HUGE_PAGES=0)");
    EXPECT_EQ(state("GLIBC_TUNABLES=glibc.malloc.hugetlb=0"),
              "off (GLIBC_TUNABLES sets glibc.malloc.hugetlb otherwise)");
  } else if (mode == "always") {
    EXPECT_EQ(state(""), pay ? "on (the kernel's mode is always)"
                             : "off (" + reporting + "; the process opted out)");
    EXPECT_EQ(state("QJULIA_HUGE_PAGES=1"), "on (the kernel's mode is always)");
    EXPECT_EQ(state("QJULIA_HUGE_PAGES=0"), "off (QJULIA_HUGE_PAGES=0; the process opted out)");
  } else if (mode == "never") {
    EXPECT_EQ(state(""), "off (the kernel's mode is never)");
  } else {
    EXPECT_EQ(state(""), "off (the kernel offers no transparent huge pages)");
  }
}

TEST_F(Cli, MallocTakesBlocksUpTo32MiBFromTheHeapUnlessTheUserSetsAThreshold) {
  // `bench --malloc` allocates a block of 16 MiB and says where malloc put it: glibc's default
  // maps it on its own (threshold 128 KiB); the command fixes the threshold at 32 MiB, unless the
  // user set one (GLIBC_TUNABLES, or glibc's MALLOC_*_THRESHOLD_ variables). It also says how a
  // new thread's heap is made: whole (64 MiB of address space) with the command's top pad, page
  // by page with glibc's (128 KiB), each step an mprotect that stops the other threads' page
  // faults. A sanitizer's malloc has no such settings, and the line says so.
  const auto state = [&](const std::string& env) {
    return bench_malloc_line("malloc thresholds: ", env);
  };
#if defined(__SANITIZE_ADDRESS__)
  const std::string heap = "malloc is not glibc's (a sanitizer's?): its thresholds do not apply";
  const std::string mapped = heap, whole = "", by_page = "", user = "";
#else
  const std::string heap = "a 16 MiB block is on the heap";
  const std::string mapped = "a 16 MiB block is mapped on its own";
  const std::string whole = ", a new thread's heap is whole at once";
  const std::string by_page = ", a new thread's heap grows page by page";
  const std::string user = " (the user sets the ";
#endif
  EXPECT_EQ(state(""), heap + whole);
  EXPECT_EQ(state("GLIBC_TUNABLES=glibc.malloc.mmap_threshold=131072"),
            mapped + whole + (user.empty() ? "" : user + "mmap threshold)"));
  EXPECT_EQ(state("MALLOC_MMAP_THRESHOLD_=131072"),
            mapped + whole + (user.empty() ? "" : user + "mmap threshold)"));
  EXPECT_EQ(state("MALLOC_TRIM_THRESHOLD_=1048576"),
            heap + whole + (user.empty() ? "" : user + "trim threshold)"));
  EXPECT_EQ(state("MALLOC_TOP_PAD_=131072"),
            heap + by_page + (user.empty() ? "" : user + "top pad)"));
  EXPECT_EQ(state("GLIBC_TUNABLES=glibc.malloc.top_pad=131072:glibc.malloc.mmap_threshold=131072"),
            mapped + by_page + (user.empty() ? "" : user + "mmap threshold, top pad)"));
  const CliRun only = run("bench --malloc");
  EXPECT_EQ(only.out.find("kernel"), std::string::npos) << "--malloc prints only its lines";
}

TEST_F(Cli, AFileSizeLimitFailsTheWriteNamingTheFileAndLeavesNoFile) {
  // Under `ulimit -f` a write beyond the limit raises SIGXFSZ, which would kill the process
  // with its temporary file left behind; the CLI ignores it, so the write fails with EFBIG.
  for (const char* ext : {"ply", "stl", "obj", "glb", "gltf", "3mf"}) {
    SCOPED_TRACE(ext);
    const std::string out = std::string("out.") + ext;
    const CliRun r =
        run("mesh --preset unit-ball --resolution 64 --quiet -o " + out, "ulimit -f 64");
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_NE(r.err.find("File too large"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(ext == std::string("gltf") ? "out.bin" : out), std::string::npos) << r.err;
    EXPECT_EQ(files(), std::vector<std::string>{}) << "no file, not even a temporary one";
  }
}

TEST_F(Cli, TheWrittenMeshDoesNotDependOnTheThreadCount) {
  // Byte-identical files from one and two threads, through sampling, extraction, dust removal
  // and decimation, for both methods.
  for (const std::string args :
       {"--preset newton-cubic --resolution 96", "--preset classic-julia --resolution 128",
        "--preset rosa-rational --resolution 80 --faces 20000"}) {
    SCOPED_TRACE(args);
    const CliRun one = run("mesh " + args + " --threads 1 -o one.ply");
    const CliRun two = run("mesh " + args + " --threads 2 -o two.ply");
    ASSERT_EQ(one.code, 0) << one.err;
    ASSERT_EQ(two.code, 0) << two.err;
    const std::string a = read_text(work_ / "one.ply"), b = read_text(work_ / "two.ply");
    EXPECT_GT(a.size(), 1000u);
    EXPECT_TRUE(a == b) << "the files differ";
  }
}

TEST_F(Cli, EveryFormatAndTheStatsDoNotDependOnTheThreadCount) {
  // Every -o format, decimation included: the same bytes from one and two threads (for .gltf
  // also its .bin, for .stl its parameter sidecar), and the same --stats but for the timings
  // and the memory (the run's peak and the limit it was checked against).
  auto stats_without_timings = [](json s) {
    s.erase("timings");
    s.erase("peak_rss_bytes");
    s["estimate"].erase("memory_limit");
    s["estimate"].erase("memory_limit_bytes");
    return s;
  };
  fs::create_directories(work_ / "one");
  fs::create_directories(work_ / "two");
  for (const std::string ext : {"glb", "gltf", "obj", "ply", "stl", "3mf"}) {
    SCOPED_TRACE(ext);
    std::map<std::string, std::string> bytes[2];
    json stats[2];
    for (const int threads : {1, 2}) {
      const std::string dir = threads == 1 ? "one" : "two";
      const CliRun r =
          run("mesh --preset classic-julia --resolution 96 --faces 20000 --quiet --threads " +
              std::to_string(threads) + " -o " + dir + "/m." + ext + " --stats " + dir + "/s.json");
      ASSERT_EQ(r.code, 0) << r.err;
      for (const auto& entry : fs::directory_iterator(work_ / dir))
        if (entry.path().filename() != "s.json")
          bytes[threads - 1][entry.path().filename().string()] = read_text(entry.path());
      stats[threads - 1] = stats_without_timings(json::parse(read_text(work_ / dir / "s.json")));
      fs::remove_all(work_ / dir);
      fs::create_directories(work_ / dir);
    }
    EXPECT_EQ(bytes[0].size(), ext == "gltf" || ext == "stl" ? 2u : 1u);
    for (const auto& [name, content] : bytes[0]) {
      EXPECT_GT(content.size(), 500u) << name;
      EXPECT_TRUE(content == bytes[1][name]) << name << " differs";
    }
    EXPECT_LE(stats[0]["faces"].get<long long>(), 20000) << "the decimated mesh";
    EXPECT_GT(stats[0]["faces"].get<long long>(), 19000) << "the decimated mesh";
    EXPECT_EQ(stats[0], stats[1]);
  }
}

// Needs the export stage (write_mesh).
TEST_F(Cli, MeshWritesTheMeshAndTheStatsOfTheUnitBall) {
  const CliRun r = run("mesh --preset unit-ball --resolution 64 -o ball.ply --stats s.json");
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

// The summary line's share of a dense grid: a percentage on the sparse path; on the dense path
// (which evaluates each brick's 9^3 points, more calls than grid points) the factor, never a
// share above 100%.
TEST_F(Cli, SummarySaysHowTheGridEvaluationsCompareWithTheGridPoints) {
  const CliRun sparse = run("mesh --preset unit-ball --resolution 64 -o a.ply");
  ASSERT_EQ(sparse.code, 0) << sparse.err;
  EXPECT_NE(sparse.out.find("of 262144 dense)"), std::string::npos) << sparse.out;
  for (const char* dense : {"--resolution 17", "--resolution 64 --dense"}) {
    const CliRun r = run(std::string("mesh --preset unit-ball -o b.ply ") + dense);
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(r.out.find("% of"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("x the "), std::string::npos) << r.out;
    EXPECT_NE(r.out.find(" grid points: each brick's 9^3"), std::string::npos) << r.out;
  }
}

// `--stats -`: the JSON alone on standard output (the summary moves to standard error), and
// no file named "-"; the other outputs take file names only.
TEST_F(Cli, StatsToStandardOutputAreTheStatsOfTheFileWritten) {
  const CliRun r = run("mesh --preset unit-ball --resolution 32 -o ball.ply --stats -");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(files(), (std::vector<std::string>{"ball.ply"}));
  json s;
  ASSERT_NO_THROW(s = json::parse(r.out)) << r.out;
  const CliRun f = run("mesh --preset unit-ball --resolution 32 -o ball2.ply --stats s.json");
  ASSERT_EQ(f.code, 0) << f.err;
  const json from_file = json::parse(read_text(work_ / "s.json"));
  for (const char* key : {"vertices", "faces", "evaluations", "volume", "area", "euler"})
    EXPECT_EQ(s[key], from_file[key]) << key;
  EXPECT_NE(r.err.find("mesh:  ball.ply"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("evaluations:"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("stats:"), std::string::npos) << r.err;
  for (const char* option : {"--vdb", "--preview"}) {
    const CliRun bad =
        run(std::string("mesh --preset unit-ball --resolution 32 -o b.ply ") + option + " -");
    EXPECT_EQ(bad.code, 2) << option;
    EXPECT_NE(bad.err.find(std::string(option) + " takes a file name"), std::string::npos)
        << bad.err;
  }
  EXPECT_EQ(files(), (std::vector<std::string>{"ball.ply", "ball2.ply", "s.json"}));
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

// ---------------------------------------------------------------------------------------------
// Numeric ranges: every numeric option at both ends of its range, just outside, and with nan,
// inf and 1e400. Outside: exit 2, one line naming the option and the range, no file.

// One numeric option of one command.
struct NumericOption {
  std::string command;                  // the command line before the option, e.g. "params"
  std::string option;                   // "--iterations"
  std::string format;                   // how the value is given, '@' for it: "@", "c=0,@,0,0"
  std::string low, high, below, above;  // the ends and just outside them
  std::string range;                    // what the message quotes, e.g. "1..100000"
  // At the ends: "" expects exit 0; otherwise the later, deliberate failure the run reaches
  // (so an end that would take long, such as --samples 100000000, is shown to be accepted
  // without doing the work).
  std::string later_failure;
  int later_code = 2;  // the exit code of that later failure
};

std::string with_value(const std::string& format, const std::string& value) {
  std::string out = format;
  out.replace(out.find('@'), 1, value);
  return out;
}

std::vector<NumericOption> numeric_options() {
  const std::string cube = "1000000,1000000,1000000";
  const std::string render = "render missing.ply -o x.png";  // options are read first
  const std::string compare = "compare missing-a.ply missing-b.ply";
  const std::string experiment = "experiment no-such-experiment";
  const std::string bench = "bench --presets no-such-preset";
  const std::string no_dir = "/proc/qjulia-no-such-dir";
  const std::string preview =
      "mesh --preset unit-ball --resolution 16 -o " + no_dir + "/b.ply --preview p.png";
  // explore reads its options, then fails to listen on an address that is none (exit 1)
  const std::string explore = "explore --no-browser --listen 999.0.0.1";
  const std::string no_listen = "cannot listen on 999.0.0.1";
  return {
      // the parameter flags (mesh, compare, params: params prints them back)
      {"params", "--iterations", "@", "1", "100000", "0", "100001", "1..100000", ""},
      {"params", "--bailout", "@", "1e-12", "1e12", "9e-13", "1.1e12", "1e-12..1e+12", ""},
      {"params", "--resolution", "@", "1", "1000000", "0", "1000001", "1..1000000", ""},
      // min < max: each end is reached by the component on its side
      {"params", "--bounds", "@,-1000000,-1000000," + cube, "-1000000", "-1000000", "-1000001", "",
       "-1000000..1000000", ""},
      {"params", "--bounds", "-1000000,-1000000,-1000000,@,1000000,1000000", "1000000", "1000000",
       "", "1000001", "-1000000..1000000", ""},
      {"params", "--fixed", "@", "-1000000", "1000000", "-1000001", "1000001", "-1000000..1000000",
       ""},
      {"params --mode mandelbrot --formula h^2+c", "--start", "0,0,@,0", "-1000000", "1000000",
       "-1000001", "1000001", "-1000000..1000000", ""},
      {"params --formula h^2+c", "--const", "c=0,@,0,0", "-1000000", "1000000", "-1000001",
       "1000001", "-1000000..1000000", ""},
      {"params", "--clip", "0,0,1,@", "-1000000", "1000000", "-1000001", "1000001",
       "-1000000..1000000", ""},
      {"params", "--faces", "@", "4", "1000000000", "3", "1000000001", "4..1000000000", ""},
      {"params", "--max-error", "@", "1e-9", "1000000", "9e-10", "1000001", "1e-09..1000000", ""},
      {"params", "--min-component", "@", "0", "1e18", "-1e-9", "1.1e18", "0..1e+18", ""},
      {"params", "--size", "@mm", "0.001", "1000000", "0.0009", "1000001", "0.001..1000000", ""},
      {"params", "--min-thickness", "@", "0.001", "1000000", "0.0009", "1000001", "0.001..1000000",
       ""},
      // qjulia mesh's own
      {"mesh --preset unit-ball --resolution 16 -o ball.ply", "--threads", "@", "1", "1024", "0",
       "1025", "1..1024", ""},
      {"mesh --preset unit-ball --resolution 16 -o ball.ply", "--max-memory", "@", "1M", "8000000T",
       "1023K", "9000000T", "at least 1M", "memory"},
      // qjulia render (and mesh --preview-*, which share the code)
      {render, "--size", "@", "1", "16384", "0", "16385", "1..16384", "missing.ply"},
      {render, "--size", "@x1", "1", "16384", "0", "16385", "1..16384", "missing.ply"},
      {render, "--ambient", "@", "0", "1", "-0.01", "1.01", "0..1", "missing.ply"},
      {render, "--specular", "@", "0", "1", "-0.01", "1.01", "0..1", "missing.ply"},
      {render, "--shininess", "@", "1", "10000", "0.99", "10001", "1..10000", "missing.ply"},
      {render, "--margin", "@", "0", "0.45", "-0.01", "0.46", "0..0.45", "missing.ply"},
      {render, "--supersample", "@", "1", "8", "0", "9", "1..8", "missing.ply"},
      {render, "--rotate", "@,0,0", "-3600", "3600", "-3601", "3601", "-3600..3600", "missing.ply"},
      {render, "--view", "0,0,@", "-3600", "3600", "-3601", "3601", "-3600..3600", "missing.ply"},
      {render, "--light", "@,0,1", "-1000000", "1000000", "-1000001", "1000001",
       "-1000000..1000000", "missing.ply"},
      {render, "--background", "@,0,0", "0", "255", "-1", "256", "0..255", "missing.ply"},
      {render, "--base-color", "0,0,@", "0", "255", "-1", "256", "0..255", "missing.ply"},
      {render, "--columns", "@", "1", "1000", "0", "1001", "1..1000", "missing.ply"},
      {render, "--threads", "@", "1", "1024", "0", "1025", "1..1024", "missing.ply"},
      {"mesh --preset unit-ball --resolution 16 -o b.ply --preview p.png --preview-size 16",
       "--preview-supersample", "@", "1", "8", "0", "9", "1..8", ""},
      // the other --preview-* options: read before the output's folder is found missing
      {preview, "--preview-size", "@", "1", "16384", "0", "16385", "1..16384", no_dir},
      {preview, "--preview-ambient", "@", "0", "1", "-0.01", "1.01", "0..1", no_dir},
      {preview, "--preview-specular", "@", "0", "1", "-0.01", "1.01", "0..1", no_dir},
      {preview, "--preview-shininess", "@", "1", "10000", "0.99", "10001", "1..10000", no_dir},
      {preview, "--preview-margin", "@", "0", "0.45", "-0.01", "0.46", "0..0.45", no_dir},
      {preview, "--preview-rotate", "@,0,0", "-3600", "3600", "-3601", "3601", "-3600..3600",
       no_dir},
      {preview, "--preview-light", "@,0,1", "-1000000", "1000000", "-1000001", "1000001",
       "-1000000..1000000", no_dir},
      {preview, "--preview-background", "@,0,0", "0", "255", "-1", "256", "0..255", no_dir},
      {preview, "--preview-base-color", "0,0,@", "0", "255", "-1", "256", "0..255", no_dir},
      // qjulia compare, experiment, bench
      {compare, "--samples", "@", "0", "100000000", "-1", "100000001", "0..100000000",
       "missing-a.ply"},
      {compare, "--threads", "@", "1", "1024", "0", "1025", "1..1024", "missing-a.ply"},
      {experiment, "--resolution", "@", "8", "1024", "7", "1025", "8..1024", "no-such-experiment"},
      {experiment, "--samples", "@", "0", "100000000", "-1", "100000001", "0..100000000",
       "no-such-experiment"},
      {experiment, "--threads", "@", "1", "1024", "0", "1025", "1..1024", "no-such-experiment"},
      {"experiment cardioid --out /proc/qjulia-no-such-dir", "--iterations", "4,@", "1", "10000",
       "0", "10001", "1..10000", "/proc/qjulia-no-such-dir"},
      {bench, "--resolutions", "16,@", "1", "1000000", "0", "1000001", "1..1000000",
       "no-such-preset"},
      {bench, "--threads", "@", "1", "1024", "0", "1025", "1..1024", "no-such-preset"},
      {bench, "--max-memory", "@", "1M", "8000000T", "1023K", "9000000T", "at least 1M",
       "no-such-preset"},
      {explore, "--port", "@", "0", "65535", "-1", "65536", "0..65535", no_listen, 1},
      {explore, "--threads", "@", "1", "1024", "0", "1025", "1..1024", no_listen, 1},
      {explore, "--max-memory", "@", "1M", "8000000T", "1023K", "9000000T", "at least 1M",
       no_listen, 1},
  };
}

TEST_F(Cli, EveryNumericOptionIsAcceptedAtBothEndsOfItsRange) {
  for (const NumericOption& o : numeric_options())
    for (const std::string& end : {o.low, o.high}) {
      const std::string args = o.command + " " + o.option + " " + with_value(o.format, end);
      SCOPED_TRACE("qjulia " + args);
      const CliRun r = run(args);
      EXPECT_EQ(r.err.find(o.option + ":"), std::string::npos) << "refused: " << r.err;
      if (o.later_failure.empty()) {
        EXPECT_EQ(r.code, 0) << r.err;
      } else if (o.later_failure != "memory") {
        EXPECT_EQ(r.code, o.later_code) << r.err;
        EXPECT_NE(r.err.find(o.later_failure), std::string::npos) << r.err;
      } else {  // the run may still be refused by the memory estimate, never by the option
        EXPECT_TRUE(r.code == 0 || r.err.find("memory") != std::string::npos) << r.err;
      }
      std::error_code ec;
      for (const auto& f : files()) fs::remove_all(work_ / f, ec);
    }
}

TEST_F(Cli, NumericOptionsOutsideTheirRangeNameTheOptionAndTheRange) {
  for (const NumericOption& o : numeric_options()) {
    std::vector<std::string> outside = {"nan", "inf", "-inf", "1e400"};
    for (const std::string& v : {o.below, o.above})
      if (!v.empty()) outside.push_back(v);
    for (const std::string& value : outside) {
      const std::string args = o.command + " " + o.option + " " + with_value(o.format, value);
      const CliRun r = expect_rejected(args, o.option);
      EXPECT_NE(r.err.find(o.range), std::string::npos)
          << "qjulia " << args << ": the message should quote the range " << o.range << ": "
          << r.err;
    }
  }
}

TEST_F(Cli, HelpStatesTheRangeOfEveryNumericOption) {
  for (const NumericOption& o : numeric_options()) {
    const std::string command = o.command.substr(0, o.command.find(' '));
    if (command == "params") continue;  // params lists no options: mesh --help has them
    const CliRun r = run(command + " --help");
    ASSERT_EQ(r.code, 0) << command;
    EXPECT_NE(r.out.find(o.option), std::string::npos) << command << " --help: " << o.option;
    EXPECT_NE(r.out.find(o.range), std::string::npos)
        << "qjulia " << command << " --help should state the range of " << o.option << ": "
        << o.range;
  }
  const CliRun mesh = run("mesh --help");
  for (const NumericOption& o : numeric_options()) {
    if (o.command.rfind("params", 0) != 0) continue;
    EXPECT_NE(mesh.out.find(o.range), std::string::npos)
        << "qjulia mesh --help should state the range of " << o.option << ": " << o.range;
  }
}

TEST_F(Cli, AParameterFileNumberBeyondItsRangeNamesTheKeyAndTheRange) {
  write_text(work_ / "p.json", R"({"formula": "h^2", "bailout": 1e400})");
  expect_rejected("mesh p.json --resolution 16 -o out.ply", "'bailout' must be in 1e-12..1e+12",
                  {"p.json"});
  write_text(work_ / "p.json", R"({"formula": "h^2", "iterations": 100001})");
  expect_rejected("params p.json", "'iterations' must be an integer in 1..100000", {"p.json"});
  write_text(work_ / "p.json", R"({"formula": "h^2", "resolution": 1000001})");
  expect_rejected("params p.json", "1..1000000", {"p.json"});
  write_text(work_ / "p.json", R"({"formula": "h^2", "bailout": NaN})");
  expect_rejected("params p.json", "not valid JSON", {"p.json"});
}

// OpenVDB (its module) is loaded only by a run that writes a grid or thickens: the dynamic
// loader's own log (LD_DEBUG=files) names every shared object a process loads.
TEST_F(Cli, OpenVdbIsLoadedOnlyWhenARunNeedsIt) {
  const CliRun plain = run("mesh --resolution 24 -o a.ply --quiet", "export LD_DEBUG=files");
  ASSERT_EQ(plain.code, 0) << plain.err;
  EXPECT_EQ(plain.err.find("libopenvdb"), std::string::npos);
  EXPECT_EQ(plain.err.find("libqjulia_vdb"), std::string::npos);
  const CliRun grid =
      run("mesh --resolution 24 -o b.ply --vdb b.vdb --quiet", "export LD_DEBUG=files");
  ASSERT_EQ(grid.code, 0) << grid.err;
  EXPECT_NE(grid.err.find("libqjulia_vdb.so"), std::string::npos);
  EXPECT_NE(grid.err.find("libopenvdb"), std::string::npos);
  const std::string vdb = read_text(work_ / "b.vdb");
  ASSERT_GE(vdb.size(), 8u);
  EXPECT_EQ(vdb.substr(0, 4), std::string(" BDV", 4));  // OpenVDB's magic number, 0x56444220
}

// A run that needs OpenVDB's module and cannot load it stops before the work, says where it
// looked, and writes nothing; a run that does not need it is not affected.
TEST_F(Cli, AMissingOpenVdbModuleStopsTheRunsThatNeedItBeforeTheWork) {
  const std::string missing = "export QJULIA_VDB_MODULE=/nonexistent/libqjulia_vdb.so";
  for (const std::string& args : {std::string("mesh --resolution 24 -o a.ply --vdb a.vdb"),
                                  std::string("mesh --resolution 24 -o a.stl --size 40mm "
                                              "--min-thickness 2mm")}) {
    SCOPED_TRACE(args);
    const CliRun r = run(args + " --quiet", missing);
    EXPECT_NE(r.code, 0);
    EXPECT_NE(r.err.find("/nonexistent/libqjulia_vdb.so"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("QJULIA_VDB_MODULE"), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line, got: " << r.err;
    EXPECT_EQ(files(), std::vector<std::string>{});
  }
  const CliRun plain = run("mesh --resolution 24 -o a.ply --quiet", missing);
  EXPECT_EQ(plain.code, 0) << plain.err;
  EXPECT_EQ(files(), std::vector<std::string>{"a.ply"});
}

// lib3mf (and libzip, libcrypto with it) is loaded only by the runs that write or read a 3MF,
// from its module; a run that needs it and cannot load it stops before the work, says where it
// looked, and writes nothing.
TEST_F(Cli, Lib3mfIsLoadedOnlyByTheRunsThatNeedIt) {
  const CliRun plain = run("mesh --resolution 24 -o a.ply --quiet", "export LD_DEBUG=files");
  ASSERT_EQ(plain.code, 0) << plain.err;
  for (const char* library : {"lib3MF", "libzip", "libcrypto", "libqjulia_3mf"})
    EXPECT_EQ(plain.err.find(library), std::string::npos) << library;
  const CliRun written = run("mesh --resolution 24 -o b.3mf --quiet", "export LD_DEBUG=files");
  ASSERT_EQ(written.code, 0) << written.err;
  EXPECT_NE(written.err.find("libqjulia_3mf.so"), std::string::npos);
  EXPECT_NE(written.err.find("lib3MF"), std::string::npos);
  const CliRun read = run("compare b.3mf a.ply");
  EXPECT_EQ(read.code, 0) << read.err;
  const std::string missing = "export QJULIA_3MF_MODULE=/nonexistent/libqjulia_3mf.so";
  const CliRun r = run("mesh --resolution 24 -o c.3mf --quiet", missing);
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.err.find("/nonexistent/libqjulia_3mf.so"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("QJULIA_3MF_MODULE"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line, got: " << r.err;
  EXPECT_FALSE(fs::exists(work_ / "c.3mf"));
  const CliRun compare = run("compare b.3mf a.ply", missing);
  EXPECT_NE(compare.code, 0);
  EXPECT_NE(compare.err.find("QJULIA_3MF_MODULE"), std::string::npos) << compare.err;
}

// OpenMesh is loaded only by decimate()'s quality method (the library's DecimateMethod::kQuality,
// tests/decimate_test.cpp), from its module: never by the command, decimating or not.
TEST_F(Cli, OpenMeshIsNotLoadedByTheCommand) {
  for (const std::string& args :
       {std::string("mesh --resolution 24 -o a.ply --quiet"),
        std::string("mesh --resolution 48 --faces 2000 -o b.ply --quiet")}) {
    SCOPED_TRACE(args);
    const CliRun r = run(args, "export LD_DEBUG=files");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("libtbb"), std::string::npos);  // the log is there
    for (const char* library : {"libOpenMesh", "libqjulia_openmesh"})
      EXPECT_EQ(r.err.find(library), std::string::npos) << library;
  }
}

// The HTTP library (and OpenSSL, brotli with it) is loaded only by `explore`, from its module;
// without the module the explorer stops with one line that says where it looked.
TEST_F(Cli, TheWebServerIsLoadedOnlyByExplore) {
  const CliRun plain = run("mesh --resolution 24 -o a.ply --quiet", "export LD_DEBUG=files");
  ASSERT_EQ(plain.code, 0) << plain.err;
  for (const char* library : {"httplib", "libssl", "brotli", "libqjulia_http"})
    EXPECT_EQ(plain.err.find(library), std::string::npos) << library;
  const CliRun r = run("explore --no-browser --port 0",
                       "export QJULIA_HTTP_MODULE=/nonexistent/libqjulia_http.so");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("/nonexistent/libqjulia_http.so"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("QJULIA_HTTP_MODULE"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line, got: " << r.err;
}

}  // namespace
}  // namespace qjulia
