#pragma once
// The HTTP server of `qjulia explore`: its routes, over the transport of libqjulia_http.so
// (http_module.h), which the command loads when it starts the server.
#include <functional>
#include <optional>
#include <string>

#include "api.h"
#include "qjulia/base/progress.h"

namespace qjulia::explore {

/// Where and what the server serves.
struct ServerOptions {
  /// The --listen address; unset: 127.0.0.1 (loopback only).
  std::optional<std::string> listen_address;
  int port = 8765;  ///< 0: any free port
  ApiOptions api;
};

/// Binds, calls `on_listening` with the page's address ("http://127.0.0.1:8765/") and serves
/// until `cancel` is requested; then stops the running jobs and returns by throwing Cancelled.
/// @throws std::runtime_error when the address cannot be bound (the port is in use, ...).
void serve(const ServerOptions& options, const CancelToken& cancel,
           const std::function<void(const std::string& url)>& on_listening);

}  // namespace qjulia::explore
