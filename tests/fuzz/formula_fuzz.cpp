// libFuzzer target for the formula compiler: any byte string must either compile or throw
// qjulia::InvalidInput with a "formula ..." message; a compiled formula must evaluate without
// crashing and deterministically. Built and run by scripts/fuzz.sh, or by hand:
//   build-fuzz/tests/fuzz/formula_fuzz -dict=tests/fuzz/formula.dict tests/fuzz/corpus/formula
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>

#include "qjulia/base/error.h"
#include "qjulia/field/formula.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using qjulia::Quat;
  const std::string text(reinterpret_cast<const char*>(data), size);
  qjulia::Formula f;
  try {
    f = qjulia::Formula::compile(text, {"c", "p", "q"});
  } catch (const qjulia::InvalidInput& e) {
    if (std::strncmp(e.what(), "formula ", 8) != 0) std::abort();
    return 0;
  }
  if (f.text() != text || f.constants_used().size() != 3) std::abort();
  const Quat constants[] = {Quat(0.5, -1, 0.25, 2), Quat(0, 0, 0, 0), Quat(1e300, 0, 0, 0)};
  const Quat points[] = {Quat(0, 0, 0, 0), Quat(0.3, -0.7, 0.4, 1.1), Quat(-1e200, 1e-200, 0, 3)};
  for (const Quat& h : points) {
    const Quat a = f.eval(h, constants);
    const Quat b = f.eval(h, constants);
    if (std::memcmp(&a, &b, sizeof a) != 0) std::abort();
  }
  f.has_real_coefficients(constants);
  return 0;
}
