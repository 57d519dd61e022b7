#pragma once
/// @file progress.h
/// Progress and cancellation: what every long stage takes.
#include <atomic>
#include <functional>

#include "qjulia/base/error.h"

namespace qjulia {

/// Called with the fraction done in [0, 1]; return false to cancel (the stage then throws
/// Cancelled). May be called from any thread, but never concurrently.
using ProgressFn = std::function<bool(double)>;

/// The one cancellation token of the library. The caller owns it and hands a pointer to the
/// stages (`cancel` in their options); every long stage checks it often enough to stop within
/// a fraction of a second and then throws Cancelled. request() is a lock-free atomic store, so
/// a signal handler, another thread or a progress callback may call it. The library itself
/// installs no signal handlers.
class CancelToken {
 public:
  CancelToken() = default;
  CancelToken(const CancelToken&) = delete;
  CancelToken& operator=(const CancelToken&) = delete;

  /// Asks the work that checks this token to stop. Async-signal-safe.
  void request() noexcept { flag_.store(true, std::memory_order_relaxed); }
  /// True once request() was called (and reset() was not called since).
  bool requested() const noexcept { return flag_.load(std::memory_order_relaxed); }
  /// Clears the request, for reusing the token for the next job.
  void reset() noexcept { flag_.store(false, std::memory_order_relaxed); }

 private:
  std::atomic<bool> flag_{false};
  static_assert(std::atomic<bool>::is_always_lock_free, "a signal handler must be able to set it");
};

/// Throws Cancelled when `token` is set; a null token never is.
inline void throw_if_cancelled(const CancelToken* token) {
  if (token && token->requested()) throw Cancelled();
}

}  // namespace qjulia
