#pragma once
/// @file stage_progress.h
/// Progress and cancellation checks of the mesh stages.
#include "qjulia/base/error.h"
#include "qjulia/base/progress.h"

namespace qjulia::detail {

/// Checks `cancel`, then reports `fraction` to `progress`. @throws Cancelled when either asks
/// to stop.
inline void report_progress(const ProgressFn& progress, const CancelToken* cancel,
                            double fraction) {
  throw_if_cancelled(cancel);
  if (progress && !progress(fraction)) throw Cancelled();
}

}  // namespace qjulia::detail
