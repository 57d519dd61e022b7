#include "io/text.h"

#include <algorithm>
#include <charconv>
#include <cstdlib>

#include "io/formats.h"

namespace qjulia::detail {

bool LineCursor::number(float& out) {
  skip();
  if (p < end && *p == '+') ++p;
  const auto r = std::from_chars(p, end, out);
  if (r.ec == std::errc::result_out_of_range) {
    // Denormals and overflow: let strtof decide (from_chars refuses them).
    const std::string token(p, std::size_t(std::min<std::ptrdiff_t>(r.ptr - p, 64)));
    out = std::strtof(token.c_str(), nullptr);
    p = r.ptr;
    return true;
  }
  if (r.ec != std::errc()) return false;
  p = r.ptr;
  return true;
}

bool LineCursor::number(double& out) {
  skip();
  if (p < end && *p == '+') ++p;
  const auto r = std::from_chars(p, end, out);
  if (r.ec == std::errc::result_out_of_range) {
    const std::string token(p, std::size_t(std::min<std::ptrdiff_t>(r.ptr - p, 64)));
    out = std::strtod(token.c_str(), nullptr);
    p = r.ptr;
    return true;
  }
  if (r.ec != std::errc()) return false;
  p = r.ptr;
  return true;
}

std::string comment_params(std::string_view text, const std::string& comment_prefix,
                           bool header_only) {
  const std::string prefix = comment_prefix + kParamsTag;
  std::string out;
  Lines lines(text);
  LineCursor c{nullptr, nullptr};
  while (lines.next(c)) {
    std::string_view l(c.p, std::size_t(c.end - c.p));
    if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
    if (l.substr(0, prefix.size()) == prefix) {
      out.append(l.substr(prefix.size()));
      out += '\n';
    } else if (header_only && l == "end_header") {
      break;
    } else if (!header_only && !l.empty() && l[0] != '#') {
      break;  // the comment block is at the top
    }
  }
  if (!out.empty()) out.pop_back();
  return out;
}

}  // namespace qjulia::detail
