// libFuzzer target of the parameter file: any byte string must either parse or throw
// qjulia::InvalidInput; a parsed file must write back (params_to_json) to a
// file that parses to the same parameters. Run by scripts/fuzz.sh.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "qjulia/base/error.h"
#include "qjulia/field/params.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  qjulia::Params params;
  try {
    params = qjulia::parse_params(text, "fuzz");
  } catch (const qjulia::InvalidInput&) {
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "params fuzz: unexpected exception: %s\n", e.what());
    std::abort();
  }
  const std::string json = qjulia::params_to_json(params);
  try {
    const std::string again = qjulia::params_to_json(qjulia::parse_params(json, "fuzz"));
    if (again != json) {
      std::fprintf(stderr, "params fuzz: no round trip:\n%s\n---\n%s\n", json.c_str(),
                   again.c_str());
      std::abort();
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "params fuzz: its own output does not parse: %s\n%s\n", e.what(),
                 json.c_str());
    std::abort();
  }
  return 0;
}
