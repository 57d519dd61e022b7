#include "server.h"

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <thread>
#include <vector>

#include "assets.h"
#include "http_module.h"
#include "qjulia/base/error.h"
#include "qjulia/base/module.h"
#include "security.h"

namespace qjulia::explore {
namespace {

// Connections the server handles at once. Each request has its connection to itself (see
// http_module.cpp), so idle browser connections hold no worker.
constexpr std::size_t kWorkers = 8;

// The text of the statuses that the HTTP library itself answers.
std::string status_text(int status) {
  switch (status) {
    case 400:
      return "bad request";
    case 404:
      return "not found";
    case 413:
      return "the request body is too large";
    case 414:
      return "the request line is too long";
    default:
      return "HTTP status " + std::to_string(status);
  }
}

RequestHead head_of(const HttpRequest& req) {
  RequestHead h;
  h.method = req.method;
  h.host = req.header("Host");
  h.origin = req.header("Origin");
  h.content_length = req.header("Content-Length");
  h.transfer_encoding = req.header("Transfer-Encoding");
  return h;
}

void send(HttpResponse& res, const Reply& reply) {
  res.status = reply.status;
  bool cache_control = false;
  for (const auto& [name, value] : reply.headers) {
    res.headers.emplace_back(name, value);
    cache_control = cache_control || name == "Cache-Control";
  }
  if (!cache_control) res.headers.emplace_back("Cache-Control", "no-store");
  res.content_type = reply.content_type;
  if (!reply.file) {
    res.body = reply.body;
    return;
  }
  // Opened here: the export's file may be replaced or removed while it is sent.
  auto in = std::make_shared<std::ifstream>(*reply.file, std::ios::binary);
  std::error_code error;
  const auto size = std::filesystem::file_size(*reply.file, error);
  if (!*in || error) {
    const Reply gone = Api::error(404, "the file of this export is gone");
    res.status = gone.status;
    res.content_type = gone.content_type;
    res.body = gone.body;
    return;
  }
  res.stream = std::move(in);
  res.size = static_cast<std::size_t>(size);
}

void refuse(HttpResponse& res, const Refusal& refusal) {
  send(res, Api::error(refusal.status, refusal.message));
}

std::uint64_t id_of(const HttpRequest& req) { return std::stoull(req.matches.at(1)); }

std::string url_host(const std::string& address) {
  return address.find(':') != std::string::npos && address.front() != '[' ? "[" + address + "]"
                                                                          : address;
}

// The module's server, destroyed on every way out.
struct BoundServer {
  const HttpApi& http;
  void* server;
  ~BoundServer() {
    if (server) http.destroy(server);
  }
};

}  // namespace

const HttpApi& http_api() {
  static const ModuleSpec spec{
      "libqjulia_http.so",          "QJULIA_HTTP_MODULE", QJULIA_HTTP_BUILD_PATH,
      QJULIA_HTTP_INSTALL_PATH,     "qjulia_http_api",    kHttpApiVersion,
      "qjulia explore's web server"};
  return module_api<HttpApi>(spec);
}

void serve(const ServerOptions& options, const CancelToken& cancel,
           const std::function<void(const std::string& url)>& on_listening) {
  const HttpApi& http = http_api();
  const std::string address = options.listen_address.value_or("127.0.0.1");
  HttpServerOptions o;
  o.bind_address = address.size() > 2 && address.front() == '['
                       ? address.substr(1, address.size() - 2)
                       : address;
  o.port = options.port;
  o.workers = kWorkers;
  o.max_body = options.api.max_body;  // a longer body: 413, skipped unread
  o.default_headers = {{"X-Content-Type-Options", "nosniff"},
                       {"X-Frame-Options", "DENY"},
                       {"Referrer-Policy", "no-referrer"}};
  // The routes run only once the server is bound (they read the policy of its port).
  std::unique_ptr<HostPolicy> policy;
  Api api(options.api);

  // Before routing and before any body is read.
  o.pre_routing = [](const HttpRequest& req, HttpResponse& res) {
    if (const auto refusal = screen_method_and_length(head_of(req))) {
      refuse(res, *refusal);
      return true;
    }
    return false;
  };
  // Every route answers only under the server's own names.
  using Route = std::function<Reply(const HttpRequest&)>;
  const auto route = [&policy](Route fn) {
    return [&policy, fn](const HttpRequest& req, HttpResponse& res) {
      if (const auto refusal = screen_host_and_origin(head_of(req), *policy)) {
        refuse(res, *refusal);
        return;
      }
      send(res, Api::guarded([&] { return fn(req); }));
    };
  };
  auto add = [&o](const char* method, const char* pattern, HttpHandler h) {
    o.routes.push_back({method, pattern, std::move(h)});
  };
  add("GET", "/api/info", route([&](const HttpRequest&) { return api.info(); }));
  add("GET", "/api/presets", route([&](const HttpRequest&) { return api.presets(); }));
  add("POST", "/api/check", route([&](const HttpRequest& r) { return api.check(r.body); }));
  add("POST", "/api/mesh", route([&](const HttpRequest& r) { return api.mesh(r.body); }));
  add("POST", "/api/compare", route([&](const HttpRequest& r) { return api.compare(r.body); }));
  add("POST", "/api/preview/cancel", route([&](const HttpRequest&) { return api.stop_preview(); }));
  add("POST", "/api/export", route([&](const HttpRequest& r) { return api.start_export(r.body); }));
  add("GET", R"(/api/export/(\d{1,18}))",
      route([&](const HttpRequest& r) { return api.export_status(id_of(r)); }));
  add("GET", R"(/api/export/(\d{1,18})/file)",
      route([&](const HttpRequest& r) { return api.export_file(id_of(r)); }));
  add("POST", R"(/api/export/(\d{1,18})/cancel)",
      route([&](const HttpRequest& r) { return api.cancel_export(id_of(r)); }));
  // The page: only embedded files, by their exact path (no file system behind it).
  add("GET", ".*", route([](const HttpRequest& r) {
        const Asset* asset = find_asset(r.path);
        if (!asset) return Api::error(404, "no page at " + r.path);
        Reply reply;
        reply.content_type = std::string(asset->content_type);
        reply.body = std::string(asset->data);
        reply.headers.emplace_back("Cache-Control", "no-cache");
        return reply;
      }));
  // Statuses that no route set (404 of a POST, 413 of the payload limit, ...) in JSON too.
  o.on_error = [](HttpResponse& res) {
    const Reply r = Api::error(res.status, status_text(res.status));
    res.content_type = r.content_type;
    res.body = r.body;
  };

  int port = 0;
  BoundServer server{http, http.bind(o, port)};
  if (!server.server)
    throw std::runtime_error(
        "cannot listen on " + url_host(o.bind_address) + ":" + std::to_string(options.port) +
        " (is the port in use? --port P picks another, --port 0 any free one)");
  policy = std::make_unique<HostPolicy>(port, options.listen_address);

  // The CLI's signal handlers request `cancel`; this thread turns that into a stop.
  std::atomic<bool> done{false};
  std::thread watcher([&] {
    while (!done) {
      if (cancel.requested() && http.is_running(server.server)) {
        api.shutdown();
        http.stop(server.server);
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  });
  on_listening("http://" + url_host(address) + ":" + std::to_string(port) + "/");
  const bool listened = http.listen(server.server);
  done = true;
  watcher.join();
  api.shutdown();
  throw_if_cancelled(&cancel);
  if (!listened) throw std::runtime_error("the server stopped: accepting connections failed");
}

}  // namespace qjulia::explore
