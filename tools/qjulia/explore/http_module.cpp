// libqjulia_http.so: http_module.h's interface over cpp-httplib, the only translation unit that
// sees the library.
#include "http_module.h"

#include <httplib.h>

#include <memory>

namespace qjulia::explore {
namespace {

struct Server {
  HttpServerOptions options;
  httplib::Server http;
};

HttpRequest request_of(const httplib::Request& req) {
  HttpRequest r;
  r.method = req.method;
  r.path = req.path;
  r.body = req.body;
  for (const auto& [name, value] : req.headers) r.headers.emplace_back(name, value);
  for (const auto& m : req.matches) r.matches.push_back(m.str());
  return r;
}

void apply(const HttpResponse& from, httplib::Response& res) {
  res.status = from.status;
  for (const auto& [name, value] : from.headers) res.set_header(name, value);
  if (!from.stream) {
    res.set_content(from.body, from.content_type);
    return;
  }
  std::shared_ptr<std::istream> in = from.stream;
  res.set_content_provider(from.size, from.content_type,
                           [in](std::size_t offset, std::size_t length, httplib::DataSink& sink) {
                             std::vector<char> buffer(std::min<std::size_t>(length, 1 << 16));
                             in->seekg(static_cast<std::streamoff>(offset));
                             in->read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
                             const auto got = static_cast<std::size_t>(in->gcount());
                             return got > 0 && sink.write(buffer.data(), got);
                           });
}

void* bind(const HttpServerOptions& options, int& port) {
  auto s = std::make_unique<Server>();
  s->options = options;
  const HttpServerOptions& o = s->options;
  httplib::Server& http = s->http;
  const std::size_t workers = o.workers;
  http.new_task_queue = [workers] { return new httplib::ThreadPool(workers); };
  // One request per connection: a refused request's unread body can never be taken for the
  // next request, and no idle connection holds a worker.
  http.set_keep_alive_max_count(1);
  // SO_REUSEADDR only: httplib's default also sets SO_REUSEPORT, which would let a second
  // server share the port of a running one (and take half of its connections).
  http.set_socket_options([](socket_t sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
  http.set_payload_max_length(o.max_body);
  httplib::Headers defaults;
  for (const auto& [name, value] : o.default_headers) defaults.emplace(name, value);
  http.set_default_headers(defaults);
  if (o.pre_routing)
    http.set_pre_routing_handler([&o](const httplib::Request& req, httplib::Response& res) {
      HttpResponse r;
      if (!o.pre_routing(request_of(req), r)) return httplib::Server::HandlerResponse::Unhandled;
      apply(r, res);
      return httplib::Server::HandlerResponse::Handled;
    });
  for (const HttpRoute& route : o.routes) {
    auto handler = [&route](const httplib::Request& req, httplib::Response& res) {
      HttpResponse r;
      route.handler(request_of(req), r);
      apply(r, res);
    };
    if (route.method == "GET")
      http.Get(route.pattern, handler);
    else
      http.Post(route.pattern, handler);
  }
  if (o.on_error)
    http.set_error_handler(
        httplib::Server::HandlerWithResponse([&o](const httplib::Request&, httplib::Response& res) {
          if (!res.body.empty()) return httplib::Server::HandlerResponse::Unhandled;
          HttpResponse r;
          r.status = res.status;
          o.on_error(r);
          res.set_content(r.body, r.content_type);
          return httplib::Server::HandlerResponse::Handled;
        }));
  if (o.port == 0) {
    port = http.bind_to_any_port(o.bind_address);
  } else {
    port = http.bind_to_port(o.bind_address, o.port) ? o.port : -1;
  }
  if (port <= 0) return nullptr;
  return s.release();
}

bool listen(void* s) { return static_cast<Server*>(s)->http.listen_after_bind(); }
bool is_running(void* s) { return static_cast<Server*>(s)->http.is_running(); }
void stop(void* s) { static_cast<Server*>(s)->http.stop(); }
void destroy(void* s) { delete static_cast<Server*>(s); }

}  // namespace
}  // namespace qjulia::explore

extern "C" __attribute__((visibility("default"))) const qjulia::explore::HttpApi*
qjulia_http_api() {
  static const qjulia::explore::HttpApi api = [] {
    qjulia::explore::HttpApi a;
    a.bind = qjulia::explore::bind;
    a.listen = qjulia::explore::listen;
    a.is_running = qjulia::explore::is_running;
    a.stop = qjulia::explore::stop;
    a.destroy = qjulia::explore::destroy;
    return a;
  }();
  return &api;
}
