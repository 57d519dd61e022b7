#include "security.h"

#include <algorithm>
#include <cctype>

namespace qjulia::explore {
namespace {

std::string lower(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return out;
}

// An IPv6 address goes into a Host header in brackets.
std::string host_name(std::string_view address) {
  if (address.find(':') != std::string_view::npos && address.front() != '[')
    return "[" + lower(address) + "]";
  return lower(address);
}

}  // namespace

HostPolicy::HostPolicy(int port, const std::optional<std::string>& listen_address) : port_(port) {
  std::vector<std::string> names = {"127.0.0.1", "localhost", "[::1]"};
  if (listen_address && !listen_address->empty()) names.push_back(host_name(*listen_address));
  for (const std::string& name : names) {
    std::string host = name + ":" + std::to_string(port);
    if (std::find(hosts_.begin(), hosts_.end(), host) == hosts_.end())
      hosts_.push_back(std::move(host));
  }
}

bool HostPolicy::host_allowed(std::string_view host) const {
  std::string h = lower(host);
  // Without a port the client means the default one.
  const bool bracketed = !h.empty() && h.front() == '[';
  const std::size_t colon = h.rfind(':');
  const bool has_port = colon != std::string::npos && (!bracketed || colon > h.find(']'));
  if (!has_port) {
    if (port_ != 80) return false;
    h += ":80";
  }
  return std::find(hosts_.begin(), hosts_.end(), h) != hosts_.end();
}

bool HostPolicy::origin_allowed(std::string_view origin) const {
  constexpr std::string_view kScheme = "http://";
  const std::string o = lower(origin);
  if (o.compare(0, kScheme.size(), kScheme) != 0) return false;
  const std::string_view rest = std::string_view(o).substr(kScheme.size());
  if (rest.find('/') != std::string_view::npos) return false;
  return host_allowed(rest);
}

std::optional<Refusal> screen_method_and_length(const RequestHead& head) {
  if (head.method == "GET" || head.method == "HEAD") return std::nullopt;
  if (head.method != "POST") return Refusal{405, "method " + head.method + " is not allowed"};
  if (head.transfer_encoding)
    return Refusal{411, "a request body must come with a Content-Length, not a Transfer-Encoding"};
  if (!head.content_length) return Refusal{411, "a POST request needs a Content-Length"};
  const std::string& text = *head.content_length;
  const bool digits =
      !text.empty() && text.size() <= 19 &&
      std::all_of(text.begin(), text.end(), [](unsigned char c) { return std::isdigit(c) != 0; });
  if (!digits) return Refusal{400, "Content-Length '" + text + "' is not a number"};
  return std::nullopt;
}

std::optional<Refusal> screen_host_and_origin(const RequestHead& head, const HostPolicy& policy) {
  if (!head.host) return Refusal{403, "a request needs a Host header"};
  if (!policy.host_allowed(*head.host))
    return Refusal{403, "the host '" + *head.host +
                            "' is not one of this server's names (DNS rebinding is refused)"};
  if (head.origin && !policy.origin_allowed(*head.origin))
    return Refusal{403, "requests from the origin '" + *head.origin + "' are refused"};
  return std::nullopt;
}

}  // namespace qjulia::explore
