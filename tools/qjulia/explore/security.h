#pragma once
// The rules every request of `qjulia explore` passes before it is routed (docs/explore.md,
// "Security"): the server answers only under its own names, so a page of another site cannot
// talk to it (cross-site requests, DNS rebinding), and a body is read only when its length is
// declared and small.
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace qjulia::explore {

/// The names under which the server answers: 127.0.0.1, localhost and [::1], plus the address
/// given with --listen, each with the server's port ("127.0.0.1:8765").
class HostPolicy {
 public:
  /// @param[in] port            the port the server listens on
  /// @param[in] listen_address  the --listen address (an IPv6 one with or without brackets)
  HostPolicy(int port, const std::optional<std::string>& listen_address);

  /// True when `host` (a Host header) is one of the names with the port (case-insensitive; a
  /// name without a port only when the port is 80).
  bool host_allowed(std::string_view host) const;
  /// True when `origin` (an Origin header) is "http://" followed by an allowed host.
  bool origin_allowed(std::string_view origin) const;
  /// The allowed hosts, "name:port", lower case.
  const std::vector<std::string>& hosts() const { return hosts_; }

 private:
  std::vector<std::string> hosts_;
  int port_;
};

/// What the screen looks at: the method and four headers of a request (unset when absent).
struct RequestHead {
  std::string method;
  std::optional<std::string> host;
  std::optional<std::string> origin;
  std::optional<std::string> content_length;
  std::optional<std::string> transfer_encoding;
};

/// Why a request is refused: the HTTP status and a message for the client.
struct Refusal {
  int status = 400;
  std::string message;
};

/// Screens a request before it is routed and before its body is read: 405 for a method other
/// than GET, HEAD and POST; for POST, 411 without Content-Length or with a Transfer-Encoding and
/// 400 for a Content-Length that is not a number (a body is only read when its length is
/// declared; the server's payload limit then answers 413 for one that is too long).
/// @return the refusal, or nothing when the request may proceed.
std::optional<Refusal> screen_method_and_length(const RequestHead& head);

/// Screens a request before it is answered: 403 when the Host header is missing or not one of
/// policy.hosts(), or when an Origin header is present and is not http:// followed by one of
/// them ("null" included). Requests without Origin (same-origin GETs, curl) pass.
/// @return the refusal, or nothing when the request may proceed.
std::optional<Refusal> screen_host_and_origin(const RequestHead& head, const HostPolicy& policy);

}  // namespace qjulia::explore
