#pragma once
// The parameters' check that hands back the formula it compiled, so that a run compiles the
// formula once: the classifier takes it from here instead of compiling it again.
#include "qjulia/field/formula.h"
#include "qjulia/field/params.h"

namespace qjulia::detail {

/// validate(params), returning the formula compiled with the constants' names in the order of
/// params.constants, then "c" in Mandelbrot mode when no constant is named so.
/// @throws InvalidInput as validate().
Formula validate_and_compile(const Params& params);

}  // namespace qjulia::detail
