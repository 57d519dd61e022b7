#include "server.h"

#include <httplib.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <thread>
#include <vector>

#include "assets.h"
#include "qjulia/base/error.h"
#include "security.h"

namespace qjulia::explore {
namespace {

// Connections the server handles at once. Each request has its connection to itself (see
// set_keep_alive_max_count below), so idle browser connections hold no worker.
constexpr std::size_t kWorkers = 8;

// The text of the statuses that httplib itself answers.
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

RequestHead head_of(const httplib::Request& req) {
  RequestHead h;
  h.method = req.method;
  const auto header = [&req](const char* name) -> std::optional<std::string> {
    if (!req.has_header(name)) return std::nullopt;
    return req.get_header_value(name);
  };
  h.host = header("Host");
  h.origin = header("Origin");
  h.content_length = header("Content-Length");
  h.transfer_encoding = header("Transfer-Encoding");
  return h;
}

void send(httplib::Response& res, const Reply& reply) {
  res.status = reply.status;
  bool cache_control = false;
  for (const auto& [name, value] : reply.headers) {
    res.set_header(name, value);
    cache_control = cache_control || name == "Cache-Control";
  }
  if (!cache_control) res.set_header("Cache-Control", "no-store");
  if (!reply.file) {
    res.set_content(reply.body, reply.content_type);
    return;
  }
  auto in = std::make_shared<std::ifstream>(*reply.file, std::ios::binary);
  std::error_code error;
  const auto size = std::filesystem::file_size(*reply.file, error);
  if (!*in || error) {
    const Reply gone = Api::error(404, "the file of this export is gone");
    res.status = gone.status;
    res.set_content(gone.body, gone.content_type);
    return;
  }
  res.set_content_provider(static_cast<std::size_t>(size), reply.content_type,
                           [in](std::size_t offset, std::size_t length, httplib::DataSink& sink) {
                             std::vector<char> buffer(std::min<std::size_t>(length, 1 << 16));
                             in->seekg(static_cast<std::streamoff>(offset));
                             in->read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
                             const auto got = static_cast<std::size_t>(in->gcount());
                             return got > 0 && sink.write(buffer.data(), got);
                           });
}

void refuse(httplib::Response& res, const Refusal& refusal) {
  send(res, Api::error(refusal.status, refusal.message));
}

std::uint64_t id_of(const httplib::Request& req) { return std::stoull(req.matches[1].str()); }

std::string url_host(const std::string& address) {
  return address.find(':') != std::string::npos && address.front() != '[' ? "[" + address + "]"
                                                                          : address;
}

}  // namespace

void serve(const ServerOptions& options, const CancelToken& cancel,
           const std::function<void(const std::string& url)>& on_listening) {
  httplib::Server server;
  server.new_task_queue = [] { return new httplib::ThreadPool(kWorkers); };
  // One request per connection: a refused request's unread body can never be taken for the
  // next request, and no idle connection holds a worker.
  server.set_keep_alive_max_count(1);
  // SO_REUSEADDR only: httplib's default also sets SO_REUSEPORT, which would let a second
  // server share the port of a running one (and take half of its connections).
  server.set_socket_options([](socket_t sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
  server.set_payload_max_length(options.api.max_body);  // a longer body: 413, skipped unread
  server.set_default_headers({{"X-Content-Type-Options", "nosniff"},
                              {"X-Frame-Options", "DENY"},
                              {"Referrer-Policy", "no-referrer"}});

  const std::string address = options.listen_address.value_or("127.0.0.1");
  const std::string bind_address = address.size() > 2 && address.front() == '['
                                       ? address.substr(1, address.size() - 2)
                                       : address;
  int port = options.port;
  if (port == 0) {
    port = server.bind_to_any_port(bind_address);
  } else if (!server.bind_to_port(bind_address, port)) {
    port = -1;
  }
  if (port <= 0)
    throw std::runtime_error(
        "cannot listen on " + url_host(bind_address) + ":" + std::to_string(options.port) +
        " (is the port in use? --port P picks another, --port 0 any free one)");
  const HostPolicy policy(port, options.listen_address);
  Api api(options.api);

  // Before routing and before any body is read.
  server.set_pre_routing_handler([](const httplib::Request& req, httplib::Response& res) {
    if (const auto refusal = screen_method_and_length(head_of(req))) {
      refuse(res, *refusal);
      return httplib::Server::HandlerResponse::Handled;
    }
    return httplib::Server::HandlerResponse::Unhandled;
  });
  // Every route answers only under the server's own names.
  using Route = std::function<Reply(const httplib::Request&)>;
  const auto route = [&policy](Route fn) {
    return [&policy, fn](const httplib::Request& req, httplib::Response& res) {
      if (const auto refusal = screen_host_and_origin(head_of(req), policy)) {
        refuse(res, *refusal);
        return;
      }
      send(res, Api::guarded([&] { return fn(req); }));
    };
  };
  server.Get("/api/info", route([&](const httplib::Request&) { return api.info(); }));
  server.Get("/api/presets", route([&](const httplib::Request&) { return api.presets(); }));
  server.Post("/api/check", route([&](const httplib::Request& r) { return api.check(r.body); }));
  server.Post("/api/mesh", route([&](const httplib::Request& r) { return api.mesh(r.body); }));
  server.Post("/api/compare",
              route([&](const httplib::Request& r) { return api.compare(r.body); }));
  server.Post("/api/preview/cancel",
              route([&](const httplib::Request&) { return api.stop_preview(); }));
  server.Post("/api/export",
              route([&](const httplib::Request& r) { return api.start_export(r.body); }));
  server.Get(R"(/api/export/(\d{1,18}))",
             route([&](const httplib::Request& r) { return api.export_status(id_of(r)); }));
  server.Get(R"(/api/export/(\d{1,18})/file)",
             route([&](const httplib::Request& r) { return api.export_file(id_of(r)); }));
  server.Post(R"(/api/export/(\d{1,18})/cancel)",
              route([&](const httplib::Request& r) { return api.cancel_export(id_of(r)); }));
  // The page: only embedded files, by their exact path (no file system behind it).
  server.Get(".*", route([](const httplib::Request& r) {
               const Asset* asset = find_asset(r.path);
               if (!asset) return Api::error(404, "no page at " + r.path);
               Reply reply;
               reply.content_type = std::string(asset->content_type);
               reply.body = std::string(asset->data);
               reply.headers.emplace_back("Cache-Control", "no-cache");
               return reply;
             }));
  // Statuses that no route set (404 of a POST, 413 of the payload limit, ...) in JSON too.
  server.set_error_handler(
      httplib::Server::HandlerWithResponse([](const httplib::Request&, httplib::Response& res) {
        if (!res.body.empty()) return httplib::Server::HandlerResponse::Unhandled;
        const Reply r = Api::error(res.status, status_text(res.status));
        res.set_content(r.body, r.content_type);
        return httplib::Server::HandlerResponse::Handled;
      }));

  // The CLI's signal handlers request `cancel`; this thread turns that into a stop.
  std::atomic<bool> done{false};
  std::thread watcher([&] {
    while (!done) {
      if (cancel.requested() && server.is_running()) {
        api.shutdown();
        server.stop();
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  });
  on_listening("http://" + url_host(address) + ":" + std::to_string(port) + "/");
  const bool listened = server.listen_after_bind();
  done = true;
  watcher.join();
  api.shutdown();
  throw_if_cancelled(&cancel);
  if (!listened) throw std::runtime_error("the server stopped: accepting connections failed");
}

}  // namespace qjulia::explore
