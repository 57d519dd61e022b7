// qjulia presets / qjulia params: the built-in presets.
#include <cstdio>

#include "cli.h"
#include "commands.h"
#include "qjulia/base/error.h"

namespace qjulia::cli {

int cmd_presets(const Tokens& tokens) {
  const ParsedArgs args = parse_args(tokens, {{"help", false}}, "presets");
  if (args.has("help")) {
    std::puts("usage: qjulia presets   (lists the built-in presets, one line each)");
    return 0;
  }
  if (!args.positional.empty())
    throw InvalidInput("takes no arguments, not '" + args.positional[0] +
                       "' (qjulia params --preset NAME prints one preset)");
  for (const std::string& name : preset_names())
    std::printf("%-22s %s\n", name.c_str(), preset_description(name).c_str());
  return 0;
}

int cmd_params(const Tokens& tokens) {
  auto specs = param_option_specs();
  specs.push_back({"help", false});
  const ParsedArgs args = parse_args(tokens, specs, "params");
  if (args.has("help")) {
    std::puts(
        "usage: qjulia params [PARAMS.json | MESH] [--preset NAME] [overrides...]\n"
        "Prints the resulting parameter file (flags as for qjulia mesh; MESH: the parameters a\n"
        "mesh file written by qjulia records).");
    return 0;
  }
  if (args.positional.size() > 1)
    throw InvalidInput("expected at most one parameter file, got '" + args.positional[1] + "'");
  const Params p = params_from_args(args, args.positional.empty() ? "" : args.positional[0]);
  std::fputs(params_to_json(p).c_str(), stdout);
  return 0;
}

}  // namespace qjulia::cli
