#include "io/text.h"

#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <type_traits>

#include "io/formats.h"

namespace qjulia::detail {

namespace {

/// from_chars, with what it refuses as out of range (denormals, overflow) left to strtod.
template <class T>
bool parse_number(LineCursor& c, T& out) {
  c.skip();
  if (c.p < c.end && *c.p == '+') ++c.p;
  const auto r = std::from_chars(c.p, c.end, out);
  if (r.ec == std::errc::result_out_of_range) {
    const std::string token(c.p, std::size_t(std::min<std::ptrdiff_t>(r.ptr - c.p, 64)));
    if constexpr (std::is_same_v<T, float>)
      out = std::strtof(token.c_str(), nullptr);
    else
      out = std::strtod(token.c_str(), nullptr);
  } else if (r.ec != std::errc()) {
    return false;
  }
  c.p = r.ptr;
  return true;
}

}  // namespace

bool LineCursor::number(float& out) { return parse_number(*this, out); }
bool LineCursor::number(double& out) { return parse_number(*this, out); }

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
