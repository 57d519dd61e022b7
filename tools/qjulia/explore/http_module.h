#pragma once
// The HTTP transport of `qjulia explore`, in a module of its own (libqjulia_http.so) that only
// the explore command loads: cpp-httplib brings OpenSSL, zlib and brotli with it, about 8 ms of
// loading and relocation at the start of every process that links it. The interface holds no
// httplib type; server.cpp gives it the routes.
#include <algorithm>
#include <cstddef>
#include <functional>
#include <istream>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace qjulia::explore {

using HttpHeaders = std::vector<std::pair<std::string, std::string>>;

/// A request as the routes see it.
struct HttpRequest {
  std::string method;
  std::string path;
  std::string body;
  HttpHeaders headers;
  std::vector<std::string> matches;  ///< the route pattern's match, then its groups
  /// The first header `name` (any case), or nothing.
  std::optional<std::string> header(const std::string& name) const {
    for (const auto& [key, value] : headers)
      if (key.size() == name.size() &&
          std::equal(key.begin(), key.end(), name.begin(),
                     [](char a, char b) { return lower(a) == lower(b); }))
        return value;
    return std::nullopt;
  }

 private:
  static char lower(char c) { return c >= 'A' && c <= 'Z' ? char(c - 'A' + 'a') : c; }
};

/// What a route answers: `body`, or `size` bytes of `stream` when it is set.
struct HttpResponse {
  int status = 200;
  HttpHeaders headers;
  std::string content_type;
  std::string body;
  std::shared_ptr<std::istream> stream;
  std::size_t size = 0;
};

using HttpHandler = std::function<void(const HttpRequest&, HttpResponse&)>;

struct HttpRoute {
  std::string method;   ///< "GET" or "POST"
  std::string pattern;  ///< a regular expression the whole path must match
  HttpHandler handler;
};

struct HttpServerOptions {
  std::string bind_address;
  int port = 0;  ///< 0: any free port
  std::size_t workers = 8;
  std::size_t max_body = 0;  ///< a longer body: 413, skipped unread
  HttpHeaders default_headers;
  /// Before routing and before any body is read (the request has no body yet); true when it
  /// answered.
  std::function<bool(const HttpRequest&, HttpResponse&)> pre_routing;
  std::vector<HttpRoute> routes;
  /// For a status no route set (404 of an unknown path, 413, ...): fills the response.
  std::function<void(HttpResponse&)> on_error;
};

/// The module's entry points (kHttpApiVersion guards against a module built for another
/// version of this interface).
constexpr int kHttpApiVersion = 1;
struct HttpApi {
  int version = kHttpApiVersion;
  /// A server bound to options.bind_address (one request per connection, SO_REUSEADDR only);
  /// null when the port cannot be bound. `port` gets the port bound.
  void* (*bind)(const HttpServerOptions& options, int& port) = nullptr;
  /// Serves until stop(); false when accepting connections failed.
  bool (*listen)(void* server) = nullptr;
  bool (*is_running)(void* server) = nullptr;
  void (*stop)(void* server) = nullptr;
  void (*destroy)(void* server) = nullptr;
};

/// The module, loaded on first use. @throws std::runtime_error when it cannot be loaded.
const HttpApi& http_api();

}  // namespace qjulia::explore
