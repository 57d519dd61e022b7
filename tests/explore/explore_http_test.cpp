// `qjulia explore` over HTTP: every route of the API (docs/explore.md) and every security rule,
// against the server run as a child process, checked against the library and the CLI.
#include <gtest/gtest.h>
#include <sys/socket.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <future>
#include <nlohmann/json.hpp>
#include <thread>

#include "explore_test_support.h"
#include "qjulia/field/params.h"
#include "qjulia/io/mesh_io.h"
#include "qjulia/mesh/compare.h"
#include "qjulia/pipeline/pipeline.h"

namespace qjulia {
namespace {

using nlohmann::json;
using test::ExploreServer;
using test::HttpResponse;

namespace fs = std::filesystem;

// A fresh directory for one test's files.
fs::path temp_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() /
                       ("qjulia-explore-test-" + name + "-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string params_text(Params p) { return params_to_json(p, false); }

Params newton(int resolution) {
  Params p = preset("newton-cubic");
  p.resolution = resolution;
  return p;
}

// A preview that takes minutes: every point of the filled-in set iterates 100000 times (the
// escape method; the cut-off method stops an orbit once it converged).
std::string slow_params() {
  Params p = preset("classic-julia");
  p.resolution = 160;
  p.iterations = 100000;
  return params_text(p);
}

void write_file(const fs::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

// The message `qjulia mesh` prints (without "qjulia mesh: ") for a parameter file named
// "parameters" holding `text`: the server reads its bodies under that name.
std::string cli_message(const std::string& text) {
  const fs::path dir = temp_dir("cli");
  write_file(dir / "parameters", text);
  std::string err;
  const int code = test::run_cli({QJULIA_CLI, "mesh", "parameters", "-o", "out.glb"}, dir, &err);
  EXPECT_EQ(code, 2) << err;
  fs::remove_all(dir);
  const std::string prefix = "qjulia mesh: ";
  if (err.rfind(prefix, 0) == 0) err = err.substr(prefix.size());
  while (!err.empty() && err.back() == '\n') err.pop_back();
  return err;
}

// One server for the suite (a server per test would do, but costs a start each).
class ExploreApi : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { server_ = new ExploreServer({"--preset", "classic-julia"}); }
  static void TearDownTestSuite() {
    delete server_;
    server_ = nullptr;
  }
  static const ExploreServer& server() { return *server_; }

  // Polls an export until it leaves "running".
  static json wait_for_export(std::uint64_t id, std::vector<std::string>* states = nullptr) {
    for (int i = 0; i < 6000; ++i) {
      const HttpResponse r = server().get("/api/export/" + std::to_string(id));
      EXPECT_EQ(r.status, 200) << r.body;
      const json s = json::parse(r.body);
      if (states && (states->empty() || states->back() != s["state"]))
        states->push_back(s["state"]);
      if (s["state"] != "running") return s;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ADD_FAILURE() << "export " << id << " did not end";
    return {};
  }

 private:
  static ExploreServer* server_;
};
ExploreServer* ExploreApi::server_ = nullptr;

TEST_F(ExploreApi, ServesThePageAndTheScriptsItLoads) {
  const HttpResponse page = server().get("/");
  ASSERT_EQ(page.status, 200);
  EXPECT_EQ(page.header("content-type"), "text/html; charset=utf-8");
  EXPECT_NE(page.body.find("/vendor/three/build/three.module.js"), std::string::npos);
  EXPECT_NE(page.body.find("/src/main.js"), std::string::npos);
  for (const char* path :
       {"/src/main.js", "/src/viewer.js", "/vendor/three/build/three.module.js",
        "/vendor/three/build/three.core.js", "/vendor/three/examples/jsm/loaders/GLTFLoader.js"}) {
    const HttpResponse r = server().get(path);
    EXPECT_EQ(r.status, 200) << path;
    EXPECT_EQ(r.header("content-type"), "text/javascript; charset=utf-8") << path;
    EXPECT_EQ(r.body.size(), std::stoul(r.header("content-length"))) << path;
  }
  EXPECT_GT(server().get("/vendor/three/build/three.core.js").body.size(), 500000u);
  EXPECT_EQ(server().get("/explore.css").headers["content-type"], "text/css; charset=utf-8");
}

TEST_F(ExploreApi, NoPathReachesTheFileSystem) {
  for (const char* path : {"/nothing", "/index.html/../../etc/passwd", "/../../../../etc/passwd",
                           "/%2e%2e/%2e%2e/etc/passwd", "/web/index.html", "/etc/passwd",
                           "/vendor/three/package.json", "/src/../../CMakeLists.txt"}) {
    const HttpResponse r = server().get(path);
    EXPECT_TRUE(r.status == 404 || r.status == 400) << path << ": " << r.status;
    EXPECT_EQ(r.body.find("root:"), std::string::npos) << path;
  }
  // The API takes parameter sets, never a path: a key for one is an unknown key.
  const HttpResponse r = server().post("/api/mesh", R"({"output": "/tmp/x.glb"})");
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(json::parse(r.body)["error"].get<std::string>().find("unknown key 'output'"),
            std::string::npos);
}

TEST_F(ExploreApi, PresetsListsEveryBuiltInPresetWithItsParameters) {
  const HttpResponse r = server().get("/api/presets");
  ASSERT_EQ(r.status, 200);
  const json list = json::parse(r.body);
  const auto names = preset_names();
  ASSERT_EQ(list.size(), names.size());
  for (std::size_t i = 0; i < names.size(); ++i) {
    EXPECT_EQ(list[i]["name"], names[i]);
    EXPECT_EQ(list[i]["description"], preset_description(names[i]));
    EXPECT_EQ(params_to_json(parse_params(list[i]["params"].dump())),
              params_to_json(preset(names[i])));
  }
}

TEST_F(ExploreApi, InfoGivesTheInitialParametersAndTheLimits) {
  const json info = json::parse(server().get("/api/info").body);
  EXPECT_EQ(info["version"], version());
  EXPECT_EQ(info["initial_name"], "classic-julia");
  EXPECT_EQ(params_to_json(parse_params(info["initial"].dump())),
            params_to_json(preset("classic-julia")));
  EXPECT_EQ(info["preview_max_resolution"], 160);
  EXPECT_EQ(info["max_body_bytes"], 65536);
  EXPECT_EQ(info["formats"], json({"glb", "gltf", "obj", "ply", "stl", "3mf"}));
  EXPECT_GT(info["export_memory_bytes"].get<double>(), info["preview_memory_bytes"].get<double>());
}

TEST_F(ExploreApi, CheckAcceptsAParameterFileAndGivesItBackComplete) {
  const HttpResponse r = server().post("/api/check", R"({"formula": "h^2+c", "method": "escape",
      "constants": {"c": [-0.2, 0.8, 0, 0]}, "bailout": 4})");
  ASSERT_EQ(r.status, 200);
  const json j = json::parse(r.body);
  EXPECT_EQ(j["ok"], true);
  EXPECT_EQ(j["params"]["formula"], "h^2+c");
  EXPECT_EQ(j["params"]["resolution"], Params().resolution);  // defaults filled in
}

TEST_F(ExploreApi, CheckNamesTheFormulasColumnLikeTheCli) {
  const std::string text = R"({"formula": "(2*h^3+1)/(3*h^"})";
  const json j = json::parse(server().post("/api/check", text).body);
  EXPECT_EQ(j["ok"], false);
  EXPECT_EQ(j["key"], "formula");
  EXPECT_EQ(j["line"], 1);
  EXPECT_EQ(j["column"], 16);
  EXPECT_EQ(j["error"], cli_message(text));
}

TEST_F(ExploreApi, CheckNamesTheLineAndColumnOfAJsonError) {
  const std::string text = "{\n  \"formula\": \"h^2\",\n  \"iterations\": ,\n}";
  const json j = json::parse(server().post("/api/check", text).body);
  EXPECT_EQ(j["ok"], false);
  EXPECT_EQ(j["key"], "json");
  EXPECT_EQ(j["line"], 3);
  EXPECT_EQ(j["column"], 17);
  EXPECT_EQ(j["error"], cli_message(text));
}

TEST_F(ExploreApi, MeshAnswersTheGlbOfTheParametersWithItsFigures) {
  const Params p = newton(40);
  const HttpResponse r = server().post("/api/mesh", params_text(p));
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.header("content-type"), "model/gltf-binary");
  EXPECT_EQ(r.body.compare(0, 4, "glTF"), 0);
  const json figures = json::parse(r.header("x-qjulia-stats"));
  const PipelineResult expected = run_pipeline(p);
  EXPECT_EQ(figures["faces"], expected.mesh.face_count());
  EXPECT_EQ(figures["vertices"], expected.stats.measure.vertices);
  EXPECT_EQ(figures["closed"], true);
  EXPECT_EQ(figures["resolution"], 40);
  const fs::path dir = temp_dir("mesh");
  write_file(dir / "preview.glb", r.body);
  const TriMesh mesh = read_mesh((dir / "preview.glb").string());
  EXPECT_EQ(mesh.positions, expected.mesh.positions);
  EXPECT_EQ(mesh.triangles, expected.mesh.triangles);
  EXPECT_EQ(params_to_json(parse_params(read_mesh_params((dir / "preview.glb").string()))),
            params_to_json(p));
  fs::remove_all(dir);
  // The same parameters again come from the cache, with the same mesh.
  const HttpResponse again = server().post("/api/mesh", params_text(p));
  EXPECT_EQ(json::parse(again.header("x-qjulia-stats"))["cached"], true);
  EXPECT_EQ(again.body, r.body);
}

TEST_F(ExploreApi, MeshErrorsAre400WithTheCliMessage) {
  for (const std::string& text : std::vector<std::string>{
           R"({"formula": "(2*h^3+1)/(3*h^"})", R"({"iterations": 0})", R"({"colour": "none"})",
           R"({"bounds": {"min": [1, -2, -2], "max": [-1, 2, 2]}})", R"({"bailout": 1e400})",
           "{\"formula\": \"h^2\",", R"({"formula": "h^2+c"})", R"({"slice": {"axes": "rrm"}})"}) {
    const HttpResponse r = server().post("/api/mesh", text);
    EXPECT_EQ(r.status, 400) << text;
    EXPECT_EQ(json::parse(r.body)["error"], cli_message(text)) << text;
  }
}

TEST_F(ExploreApi, MeshRefusesAResolutionAboveThePreviewLimit) {
  const HttpResponse r = server().post("/api/mesh", params_text(newton(161)));
  EXPECT_EQ(r.status, 400);
  EXPECT_EQ(json::parse(r.body)["error"],
            "parameters: 'resolution' 161 is above the preview limit of 160 (an export runs at "
            "any resolution)");
  EXPECT_EQ(server().post("/api/mesh", params_text(newton(16))).status, 200);
}

TEST_F(ExploreApi, AnEmptySolidIs400) {
  Params p = newton(32);
  p.method = Method::kEscape;
  p.bailout = 0.8;  // every orbit leaves the ball (the paper's table 1)
  const HttpResponse r = server().post("/api/mesh", params_text(p));
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(r.body.find("the solid is empty"), std::string::npos);
  EXPECT_EQ(json::parse(r.body)["empty"], true);
}

TEST_F(ExploreApi, ANewerPreviewCancelsTheRunningOne) {
  auto slow =
      std::async(std::launch::async, [] { return server().post("/api/mesh", slow_params()); });
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // it runs
  const HttpResponse fast = server().post("/api/mesh", params_text(newton(24)));
  EXPECT_EQ(fast.status, 200) << fast.body;
  const HttpResponse cancelled = slow.get();
  EXPECT_EQ(cancelled.status, 409);
  EXPECT_EQ(json::parse(cancelled.body)["error"], "cancelled: a newer preview started");
  EXPECT_EQ(json::parse(cancelled.body)["cancelled"], true);
}

TEST_F(ExploreApi, PreviewsRunOneAtATimeAndTheNewestWins) {
  std::vector<std::future<HttpResponse>> stale;
  for (int i = 0; i < 4; ++i) {
    stale.push_back(
        std::async(std::launch::async, [] { return server().post("/api/mesh", slow_params()); }));
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const HttpResponse newest = server().post("/api/mesh", params_text(newton(20)));
  EXPECT_EQ(newest.status, 200);
  for (auto& f : stale) EXPECT_EQ(f.get().status, 409);
}

TEST_F(ExploreApi, StopEndsTheRunningPreview) {
  auto slow =
      std::async(std::launch::async, [] { return server().post("/api/mesh", slow_params()); });
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const HttpResponse stop = server().post("/api/preview/cancel", "");
  EXPECT_EQ(json::parse(stop.body)["stopped"], true);
  const HttpResponse r = slow.get();
  EXPECT_EQ(r.status, 409);
  EXPECT_EQ(json::parse(r.body)["error"], "cancelled: stopped");
  EXPECT_EQ(json::parse(server().post("/api/preview/cancel", "").body)["stopped"], false);
}

TEST_F(ExploreApi, CompareGivesTheLibrarysHausdorffDistance) {
  Params a = newton(40);
  a.method = Method::kEscape;
  a.bailout = 2;
  const Params b = newton(40);
  const json request = {
      {"a", json::parse(params_text(a))}, {"b", json::parse(params_text(b))}, {"samples", 20000}};
  const HttpResponse r = server().post("/api/compare", request.dump());
  ASSERT_EQ(r.status, 200) << r.body;
  const json j = json::parse(r.body);
  CompareOptions copts;
  copts.samples = 20000;
  const CompareResult expected = compare(run_pipeline(a).mesh, run_pipeline(b).mesh, copts);
  EXPECT_EQ(j["hausdorff"].get<double>(), expected.hausdorff);
  EXPECT_EQ(j["a"]["faces"], expected.a.faces);
  EXPECT_EQ(j["b"]["faces"], expected.b.faces);
  EXPECT_EQ(j["samples"], 20000);
  EXPECT_GT(expected.hausdorff, 0.5);  // the two methods disagree on Newton's map
}

TEST_F(ExploreApi, CompareRefusesBadRequests) {
  const std::string p = params_text(newton(24));
  EXPECT_EQ(server().post("/api/compare", "[1, 2]").status, 400);
  EXPECT_EQ(server().post("/api/compare", "{\"a\": " + p + "}").status, 400);
  EXPECT_EQ(
      server().post("/api/compare", "{\"a\": " + p + ", \"b\": " + p + ", \"samples\": 10}").status,
      400);
  const HttpResponse r =
      server().post("/api/compare", "{\"a\": " + p + ", \"b\": " + params_text(newton(400)) + "}");
  EXPECT_EQ(r.status, 400);
  EXPECT_EQ(json::parse(r.body)["error"].get<std::string>().rfind("b: 'resolution' 400", 0), 0u);
}

TEST_F(ExploreApi, ExportRunsAsAJobAndEveryFormatDownloads) {
  const Params p = newton(32);
  const std::size_t faces = run_pipeline(p).mesh.face_count();
  const fs::path dir = temp_dir("export");
  for (const std::string& format :
       std::vector<std::string>{"glb", "gltf", "obj", "ply", "stl", "3mf"}) {
    const json request = {{"params", json::parse(params_text(p))}, {"format", format}};
    const HttpResponse started = server().post("/api/export", request.dump());
    ASSERT_EQ(started.status, 202) << started.body;
    const std::uint64_t id = json::parse(started.body)["id"];
    std::vector<std::string> states;
    const json done = wait_for_export(id, &states);
    ASSERT_EQ(done["state"], "done") << done.dump();
    EXPECT_EQ(done["progress"], 1.0);
    EXPECT_EQ(done["faces"], faces);
    EXPECT_EQ(done["file"], "/api/export/" + std::to_string(id) + "/file");
    const HttpResponse file = server().get(done["file"]);
    ASSERT_EQ(file.status, 200);
    EXPECT_EQ(file.header("content-disposition"), "attachment");
    EXPECT_EQ(file.body.size(), done["bytes"].get<std::size_t>());
    // Alone in a directory: a .gltf carries its buffer inside.
    const fs::path one = dir / format;
    fs::create_directories(one);
    const fs::path path = one / ("mesh." + format);
    write_file(path, file.body);
    EXPECT_EQ(read_mesh(path.string()).face_count(), faces) << format;
    if (format == "gltf") {
      const json gltf = json::parse(file.body);
      EXPECT_EQ(gltf["buffers"][0]["uri"].get<std::string>().rfind(
                    "data:application/octet-stream;base64,", 0),
                0u);
    }
  }
  fs::remove_all(dir);
}

TEST_F(ExploreApi, AnExportCanBeCancelledAndASecondOneWaits) {
  Params p = preset("classic-julia");  // minutes: 100000 iterations in the filled-in set
  p.resolution = 256;
  p.iterations = 100000;
  const json request = {{"params", json::parse(params_text(p))}, {"format", "glb"}};
  const HttpResponse started = server().post("/api/export", request.dump());
  ASSERT_EQ(started.status, 202);
  const std::uint64_t id = json::parse(started.body)["id"];
  const HttpResponse busy = server().post("/api/export", request.dump());
  EXPECT_EQ(busy.status, 409);
  EXPECT_EQ(json::parse(busy.body)["running"], id);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const json running = json::parse(server().get("/api/export/" + std::to_string(id)).body);
  EXPECT_EQ(running["state"], "running");
  // The memory estimate's quick samplings, then the sampling itself.
  EXPECT_TRUE(running["stage"] == "estimate" || running["stage"] == "sample") << running.dump();
  EXPECT_EQ(server().post("/api/export/" + std::to_string(id) + "/cancel", "").status, 200);
  EXPECT_EQ(wait_for_export(id)["state"], "cancelled");
  EXPECT_EQ(server().get("/api/export/" + std::to_string(id) + "/file").status, 404);
}

TEST_F(ExploreApi, ExportRefusesBadRequestsAndUnknownJobs) {
  const json p = json::parse(params_text(newton(16)));
  for (const json& bad : {json{{"params", p}, {"format", "exe"}}, json{{"params", p}},
                          json{{"format", "glb"}}, json{{"params", p}, {"format", "../glb"}}}) {
    EXPECT_EQ(server().post("/api/export", bad.dump()).status, 400) << bad.dump();
  }
  json bad_params = p;
  bad_params["iterations"] = -1;
  EXPECT_EQ(
      server().post("/api/export", json{{"params", bad_params}, {"format", "glb"}}.dump()).status,
      400);
  EXPECT_EQ(server().get("/api/export/999999").status, 404);
  EXPECT_EQ(server().get("/api/export/999999/file").status, 404);
  EXPECT_EQ(server().post("/api/export/999999/cancel", "").status, 404);
}

// The security rules of docs/explore.md.
class ExploreSecurity : public ExploreApi {};

TEST_F(ExploreSecurity, TheServerAnswersUnderItsOwnNames) {
  const std::string port = std::to_string(server().port());
  for (const std::string& host : std::vector<std::string>{"127.0.0.1:" + port, "localhost:" + port,
                                                          "[::1]:" + port, "LocalHost:" + port}) {
    const HttpResponse r =
        test::send_raw(server().address(), server().port(),
                       test::make_request("GET", "/api/info", {"Host: " + host}));
    EXPECT_EQ(r.status, 200) << host;
  }
}

TEST_F(ExploreSecurity, AForeignHostIs403) {
  const std::string port = std::to_string(server().port());
  const std::string other = std::to_string(server().port() == 9 ? 10 : 9);
  for (const std::string& host : std::vector<std::string>{
           "evil.example:" + port, "evil.example", "127.0.0.1:" + other, "localhost", "127.0.0.1",
           "127.0.0.2:" + port, "localhost:" + port + ".evil.example"}) {
    for (const char* path : {"/", "/api/info"}) {
      const HttpResponse r = test::send_raw(server().address(), server().port(),
                                            test::make_request("GET", path, {"Host: " + host}));
      EXPECT_EQ(r.status, 403) << host << path;
    }
    const std::string body = params_text(newton(16));
    const HttpResponse r =
        test::send_raw(server().address(), server().port(),
                       test::make_request("POST", "/api/mesh", {"Host: " + host}, &body));
    EXPECT_EQ(r.status, 403) << host;
  }
  // HTTP/1.0 without Host.
  const HttpResponse r =
      test::send_raw(server().address(), server().port(), "GET /api/info HTTP/1.0\r\n\r\n");
  EXPECT_EQ(r.status, 403);
}

TEST_F(ExploreSecurity, AForeignOriginIs403AndTheServersOwnPasses) {
  const std::string port = std::to_string(server().port());
  const std::string body = params_text(newton(16));
  for (const std::string& origin :
       std::vector<std::string>{"http://evil.example", "null", "https://127.0.0.1:" + port,
                                "http://127.0.0.1:" + port + ".evil.example",
                                "http://evil.example:" + port, "file://"}) {
    EXPECT_EQ(server().get("/api/info", {"Origin: " + origin}).status, 403) << origin;
    EXPECT_EQ(server().post("/api/mesh", body, {"Origin: " + origin}).status, 403) << origin;
    EXPECT_EQ(server()
                  .post("/api/export", R"({"format": "glb", "params": {}})", {"Origin: " + origin})
                  .status,
              403)
        << origin;
  }
  for (const std::string& origin : std::vector<std::string>{
           "http://127.0.0.1:" + port, "http://localhost:" + port, "http://[::1]:" + port}) {
    EXPECT_EQ(server().get("/api/info", {"Origin: " + origin}).status, 200) << origin;
    EXPECT_EQ(server().post("/api/mesh", body, {"Origin: " + origin}).status, 200) << origin;
  }
}

TEST_F(ExploreSecurity, ABodyAboveTheLimitIs413) {
  const std::string big(65537, ' ');
  EXPECT_EQ(server().post("/api/mesh", big).status, 413);
  EXPECT_EQ(server().post("/api/check", big).status, 413);
  EXPECT_EQ(server().post("/api/export", big).status, 413);
  // At the limit it is read (and is not JSON).
  const std::string at_limit(65536, ' ');
  EXPECT_EQ(server().post("/api/check", at_limit).status, 200);
}

TEST_F(ExploreSecurity, ABodyWithoutALengthIsRefused) {
  const std::string host = "Host: " + server().host();
  HttpResponse r =
      test::send_raw(server().address(), server().port(),
                     "POST /api/mesh HTTP/1.1\r\n" + host + "\r\nConnection: close\r\n\r\n{}");
  EXPECT_EQ(r.status, 411);
  r = test::send_raw(
      server().address(), server().port(),
      "POST /api/mesh HTTP/1.1\r\n" + host +
          "\r\nTransfer-Encoding: chunked\r\nConnection: close\r\n\r\n2\r\n{}\r\n0\r\n\r\n");
  EXPECT_EQ(r.status, 411);
  r = test::send_raw(server().address(), server().port(),
                     "POST /api/mesh HTTP/1.1\r\n" + host +
                         "\r\nContent-Length: 1e9\r\nConnection: close\r\n\r\n{}");
  EXPECT_EQ(r.status, 400);
}

TEST_F(ExploreSecurity, OnlyGetHeadAndPostAreAllowed) {
  for (const char* method : {"PUT", "DELETE", "OPTIONS", "PATCH"}) {
    const std::string body = "{}";
    const HttpResponse r = test::send_raw(
        server().address(), server().port(),
        test::make_request(method, "/api/mesh", {"Host: " + server().host()}, &body));
    EXPECT_EQ(r.status, 405) << method;
  }
}

TEST(ExploreListen, ByDefaultOnlyLoopbackIsListenedOn) {
  ExploreServer server;
  EXPECT_EQ(server.address(), "127.0.0.1");
  // 127.0.0.2 is loopback too, but not the address the server bound.
  EXPECT_THROW(test::send_raw("127.0.0.2", server.port(),
                              test::make_request("GET", "/", {"Host: 127.0.0.2"})),
               std::runtime_error);
}

TEST(ExploreListen, ListenAddsItsAddressToTheServersNames) {
  ExploreServer server({"--listen", "127.0.0.2"});
  EXPECT_EQ(server.address(), "127.0.0.2");
  const std::string port = std::to_string(server.port());
  EXPECT_EQ(server.get("/api/info").status, 200);  // Host 127.0.0.2:PORT
  EXPECT_EQ(server.get("/api/info", {"Origin: http://127.0.0.2:" + port}).status, 200);
  EXPECT_EQ(test::send_raw("127.0.0.2", server.port(),
                           test::make_request("GET", "/", {"Host: localhost:" + port}))
                .status,
            200);
  EXPECT_EQ(test::send_raw("127.0.0.2", server.port(),
                           test::make_request("GET", "/", {"Host: 127.0.0.3:" + port}))
                .status,
            403);
}

// --max-memory is the budget of all jobs together: a quarter for the preview lane, the rest for
// the export; a job whose estimated peak does not fit is refused before it starts (estimate.h).
TEST(ExploreMemory, AJobAboveTheBudgetIsRefusedBeforeTheWork) {
  ExploreServer server({"--max-memory", "200M"});
  const json info = json::parse(server.get("/api/info").body);
  EXPECT_EQ(info["preview_memory_bytes"], 50u << 20);
  EXPECT_EQ(info["export_memory_bytes"], 150u << 20);
  // newton-cubic's estimates: about 30 MiB at 48, 62 MiB at 160 (the preview's largest).
  EXPECT_EQ(server.post("/api/mesh", params_text(newton(48))).status, 200);
  const HttpResponse big = server.post("/api/mesh", params_text(newton(160)));
  EXPECT_EQ(big.status, 400) << big.body;
  const json refusal = json::parse(big.body);
  EXPECT_EQ(refusal["too_large"], true);
  EXPECT_NE(refusal["error"].get<std::string>().find("needs about"), std::string::npos)
      << refusal.dump();
  // An export far above the budget fails at once, with the largest resolution that fits.
  const auto begin = std::chrono::steady_clock::now();
  const json request = {{"params", json::parse(params_text(newton(100000)))}, {"format", "glb"}};
  const HttpResponse started = server.post("/api/export", request.dump());
  ASSERT_EQ(started.status, 202) << started.body;
  const std::string id = std::to_string(json::parse(started.body)["id"].get<std::uint64_t>());
  json s;
  do {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    s = json::parse(server.get("/api/export/" + id).body);
  } while (s["state"] == "running" &&
           std::chrono::steady_clock::now() - begin < std::chrono::seconds(60));
  EXPECT_EQ(s["state"], "failed") << s.dump();
  EXPECT_NE(s["error"].get<std::string>().find("the largest resolution that fits is"),
            std::string::npos)
      << s.dump();
}

// SIGINT and SIGTERM end the server like every command: exit 130 / 143, a running preview
// cancelled, its directory removed.
class ExploreSignals : public ::testing::TestWithParam<int> {};

TEST_P(ExploreSignals, EndTheServerAndItsJobsCleanly) {
  const int signal = GetParam();
  const fs::path tmp = temp_dir(signal == SIGINT ? "sigint" : "sigterm");
  ExploreServer server({}, tmp.string());
  ASSERT_EQ(std::distance(fs::directory_iterator(tmp), fs::directory_iterator()), 1);
  auto slow =
      std::async(std::launch::async, [&] { return server.post("/api/mesh", slow_params()); });
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const auto begin = std::chrono::steady_clock::now();
  EXPECT_EQ(server.stop(signal), 128 + signal);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
  EXPECT_LT(seconds, 10.0);  // the running preview was cancelled, not waited for
  const HttpResponse r = slow.get();
  EXPECT_EQ(r.status, 503);
  EXPECT_TRUE(fs::is_empty(tmp)) << "the server's directory is left";
  fs::remove_all(tmp);
}

INSTANTIATE_TEST_SUITE_P(SigintAndSigterm, ExploreSignals, ::testing::Values(SIGINT, SIGTERM),
                         [](const auto& info) {
                           return std::string(info.param == SIGINT ? "Sigint" : "Sigterm");
                         });

TEST(ExploreCli, BadArgumentsExit2AndAPortInUseExits1) {
  const std::string dir = fs::temp_directory_path().string();
  std::string err;
  EXPECT_EQ(test::run_cli({QJULIA_CLI, "explore", "--port", "70000", "--no-browser"}, dir, &err),
            2);
  EXPECT_NE(err.find("--port"), std::string::npos) << err;
  EXPECT_EQ(test::run_cli({QJULIA_CLI, "explore", "--preset", "nope", "--no-browser"}, dir, &err),
            2);
  EXPECT_EQ(test::run_cli({QJULIA_CLI, "explore", "--listen=", "--no-browser"}, dir, &err), 2);
  EXPECT_EQ(test::run_cli({QJULIA_CLI, "explore", "a.json", "b.json"}, dir, &err), 2);
  ExploreServer server;
  EXPECT_EQ(test::run_cli(
                {QJULIA_CLI, "explore", "--no-browser", "--port", std::to_string(server.port())},
                dir, &err),
            1);
  EXPECT_NE(err.find("cannot listen on 127.0.0.1:" + std::to_string(server.port())),
            std::string::npos)
      << err;
  EXPECT_EQ(test::run_cli({QJULIA_CLI, "explore", "--help"}, dir, &err), 0);
}

}  // namespace
}  // namespace qjulia
