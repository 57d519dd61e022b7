#pragma once
/// @file stage_progress.h
/// Progress and cancellation checks of the stages.
#include <mutex>

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

/// The progress of a stage whose parallel passes report as they go (the sampler, the
/// extraction). report() may be called from any thread: it checks `cancel` every time, and
/// reports a fraction only when it is not below the last one reported, one report at a time (a
/// thread that counted its share of the work earlier may reach the report later), so the
/// fractions never go back. @throws Cancelled when either asks to stop.
class RisingProgress {
 public:
  RisingProgress(const ProgressFn& progress, const CancelToken* cancel)
      : progress_(progress), cancel_(cancel) {}
  void report(double fraction) {
    throw_if_cancelled(cancel_);
    std::lock_guard<std::mutex> lock(mutex_);
    if (fraction < last_) return;
    last_ = fraction;
    report_progress(progress_, nullptr, fraction);
  }

 private:
  const ProgressFn& progress_;
  const CancelToken* cancel_;
  std::mutex mutex_;
  double last_ = 0;
};

}  // namespace qjulia::detail
