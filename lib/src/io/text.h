#pragma once
/// @file text.h
/// Parsing helpers of the text formats (OBJ, ASCII PLY, ASCII STL): a file is parsed in place,
/// line by line, with std::from_chars.
#include <cstring>
#include <string>
#include <string_view>

namespace qjulia::detail {

inline bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r'; }

/// A cursor over one line of text (no '\n' inside).
struct LineCursor {
  const char* p;
  const char* end;
  void skip() {
    while (p < end && is_blank(*p)) ++p;
  }
  bool at_end() {
    skip();
    return p >= end;
  }
  /// Reads a number ("+" allowed; denormals and overflow as strtof gives them).
  bool number(float& out);
  bool number(double& out);
  /// The next run of non-blank characters ("" at the end).
  std::string_view word() {
    skip();
    const char* s = p;
    while (p < end && !is_blank(*p)) ++p;
    return {s, std::size_t(p - s)};
  }
};

/// Splits `text` into lines: call next() until it returns false.
class Lines {
 public:
  explicit Lines(std::string_view text) : p_(text.data()), end_(text.data() + text.size()) {}
  /// The next line (without its '\n'); false at the end of the text.
  bool next(LineCursor& line) {
    if (p_ >= end_) return false;
    const char* eol = static_cast<const char*>(std::memchr(p_, '\n', std::size_t(end_ - p_)));
    if (!eol) eol = end_;
    line = {p_, eol};
    p_ = eol + 1;
    ++number_;
    return true;
  }
  /// 1-based number of the line next() returned last.
  std::size_t number() const { return number_; }
  /// "line N: ", the prefix of a message about that line.
  std::string where() const { return "line " + std::to_string(number_) + ": "; }

 private:
  const char* p_;
  const char* end_;
  std::size_t number_ = 0;
};

/// The parameter lines of a comment block: every line that starts with `prefix` + kParamsTag,
/// joined with '\n'. OBJ stops at the first line that is not a comment, PLY at end_header.
std::string comment_params(std::string_view text, const std::string& prefix, bool header_only);

}  // namespace qjulia::detail
